"""The 3D tube: a configuration's development wrapped back onto the cylinder (MODEL.md §10).

:func:`cylinder` draws the facets of :func:`biplan.geometry.surface.surface` (every rigid
element cut into narrow circumferential strips, 48 per turn, carried rigidly with its element
and wrapped by (z, s) ↦ (R cos(s/R), R sin(s/R), z)), so straight development edges become
arcs and helices and open folds show as gaps (circular bands, the wedge-shaped helical slit).
The element outlines and the fold fields are drawn on top where they face the viewer, the
folds coloured like the development (:mod:`biplan.plot.tube`): by elongation w [mm] or by the
branch of their law.

matplotlib's 3D renderer sorts whole artists, not pixels; facets are shaded with a fixed
two-sided Lambert light and drawn below the outline and fold lines (``computed_zorder`` off),
and lines on the far side of the tube are left out.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import numpy as np
from matplotlib.colors import Normalize, to_rgb

from biplan.geometry import surface
from biplan.plot.response import FONT_SIZE, _new_axes
from biplan.plot.tube import (
    ARC_SUBDIVISIONS,
    ELEMENT_EDGE,
    ELEMENT_FILL,
    LINEAR_FOLD_COLOR,
    _laws,
    add_colorbar,
    fold_scale,
    fold_values,
)

if TYPE_CHECKING:
    from mpl_toolkits.mplot3d.axes3d import Axes3D

    from biplan.model.assembly import Model

__all__ = ["cylinder", "reconstruct", "set_limits3d"]


def reconstruct(model: Model, q: np.ndarray) -> surface.Reconstruction:
    """Facets and fold lines of configuration ``q`` (see :func:`surface.reconstruct`)."""
    return surface.reconstruct(
        model.layout,
        model.params.geometry,
        model.kinematics(q),
        model.kinematics(model.zeros()),
        subdivisions=ARC_SUBDIVISIONS,
    )


def _nice_length(span: float) -> float:
    """A round scale-bar length [mm] of about a third of ``span``."""
    raw = max(span / 3.0, 1e-3)
    mag = 10.0 ** np.floor(np.log10(raw))
    return float(mag * max(m for m in (1.0, 2.0, 5.0) if m * mag <= raw))


def _shaded(centres: np.ndarray, base: list[str], elev: float, azim: float) -> np.ndarray:
    """Two-sided Lambert shading of cylinder facets: RGB (M, 3) of the ``base`` colours.

    ``centres`` (M, 3) are facet centroids relative to the tube axis; on a cylinder the facet
    normal is radial.
    """
    normal = np.column_stack([centres[:, 0], centres[:, 1], np.zeros(len(centres))])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    el, az = np.radians(elev + 25.0), np.radians(azim + 35.0)  # light above-left of the viewer
    light = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    shade = 0.55 + 0.45 * np.abs(normal @ light)
    return np.array([to_rgb(c) for c in base]) * shade[:, None]


def _facing(a: np.ndarray, b: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """Whether segments a → b (each (S, 3)) lie on the side of the tube facing ``eye``."""
    mid = 0.5 * (a + b)
    return mid[:, 0] * eye[0] + mid[:, 1] * eye[1] > 0.0


def set_limits3d(ax: Axes3D, lo: np.ndarray, hi: np.ndarray, *, zoom: float = 1.0) -> None:
    """Set x, y, z limits [mm], an equal-scale box aspect and the box ``zoom``."""
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(np.maximum(np.asarray(hi) - np.asarray(lo), 1e-6)), zoom=zoom)


def _draw_folds(
    ax: Axes3D,
    model: Model,
    rec: surface.Reconstruction,
    color_by: str,
    norm: Normalize | None,
    eye: np.ndarray,
    shift: np.ndarray,
) -> None:
    """The wrapped fold lines facing ``eye``, coloured by elongation or branch."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    folds = rec.folds
    cmap, norm = fold_scale(color_by, norm, model, model.zeros())
    a, b = folds.points[folds.segments[:, 0]], folds.points[folds.segments[:, 1]]
    laws = _laws(model)[rec.lines.fold[folds.field]]
    wmid = folds.w[folds.segments].mean(axis=1)
    values = np.array([fold_values(color_by, law, w) for law, w in zip(laws, wmid, strict=True)])
    keep = _facing(a, b, eye)
    segs, values = np.stack([a, b], axis=1)[keep] + shift, values[keep]
    single = np.isnan(values)
    coloured = Line3DCollection(list(segs[~single]), cmap=cmap, norm=norm, linewidths=1.3)
    coloured.set_array(values[~single])
    coloured.set(zorder=3, gid="cylinder-folds", capstyle="round")
    ax.add_collection3d(coloured)
    if single.any():
        plain = Line3DCollection(list(segs[single]), colors=LINEAR_FOLD_COLOR, linewidths=0.8)
        plain.set(zorder=3, gid="cylinder-linear-folds")
        ax.add_collection3d(plain)


def cylinder(
    model: Model,
    q: np.ndarray,
    *,
    ax: Axes3D | None = None,
    elev: float = 20.0,
    azim: float = -60.0,
    offset: tuple[float, float] = (0.0, 0.0),
    color_by: str | None = "elongation",
    norm: Normalize | None = None,
    colorbar: bool = False,
    scale_bar: bool = True,
) -> Axes3D:
    """Draw the configuration wrapped onto the cylinder of radius R (MODEL.md §10).

    Parameters
    ----------
    model : Model
    q : ndarray, shape (n_q,)
        Generalised coordinates.
    ax : Axes3D, optional
        3D Axes to draw into; a new figure with one 3D Axes when omitted. Tubes drawn earlier
        into the same Axes stay in view (limits grow to hold all of them).
    elev, azim : float
        View elevation and azimuth [degrees] (orthographic projection).
    offset : (float, float)
        Translation (x, y) [mm] of the tube axis, to place several states side by side.
    color_by : {"elongation", "phase", None}
        Colour of the fold lines, as in :func:`biplan.plot.development`; None draws no folds.
    norm : Normalize, optional
        Elongation colour scale [mm]; default spans this state's elongations.
    colorbar : bool
        Add a fold colorbar next to the Axes.
    scale_bar : bool
        Draw a vertical scale bar [mm] next to the first tube drawn into the Axes.

    Returns
    -------
    Axes3D
        The Axes drawn into: x, y, z [mm] at equal scale, orthographic, axes hidden. Artists
        are drawn in zorder (``computed_zorder`` off): facets (gid ``"cylinder"``) at 1, the
        element outlines facing the viewer (``"cylinder-edges"``) at 2, the fold lines facing
        the viewer (``"cylinder-folds"``) at 3.

    Raises
    ------
    ValueError
        For an unknown ``color_by``.
    """
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    q = np.asarray(q, dtype=float)
    if color_by is not None:
        norm = fold_scale(color_by, norm, model, q)[1]  # fixed before drawing: fails early
    radius = model.tube.development.radius
    ax = cast("Axes3D", _new_axes(ax, (2.6, 2.6), projection="3d"))
    first = not any(c.get_gid() == "cylinder" for c in ax.collections)
    rec = reconstruct(model, q)
    srf = rec.surface
    eye = np.array([np.cos(np.radians(azim)), np.sin(np.radians(azim))])
    shift = np.array([offset[0], offset[1], 0.0])

    # Facets padded to 6 vertices by repeating their last one: matplotlib pads ragged polygon
    # lists with uninitialised memory, which its 3D autoscaling then reads.
    count = (srf.facets >= 0).sum(axis=1)
    last = srf.facets[np.arange(srf.n_facets), count - 1]
    facets = srf.points[np.where(srf.facets >= 0, srf.facets, last[:, None])]
    centres = np.array([f[:c].mean(axis=0) for f, c in zip(facets, count, strict=True)])
    rgb = _shaded(centres, [ELEMENT_FILL[k] for k in srf.element], elev, azim)
    # Edges in the face colour (not antialiased) hide the hairline seams between facets.
    poly = Poly3DCollection(facets + shift, fc=rgb, ec=rgb, lw=0.3, aa=False)
    poly.set(zorder=1, gid="cylinder")
    ax.add_collection3d(poly)
    # Element outlines (circular and helical creases, seam) where they face the viewer.
    edges = []
    for e in srf.wrapped_edges():
        keep = _facing(e[:-1], e[1:], eye)
        edges += [e[i : i + 2] + shift for i in np.flatnonzero(keep)]
    outline = Line3DCollection(edges, colors=ELEMENT_EDGE, linewidths=0.35)
    ax.add_collection3d(outline)
    outline.set(zorder=2, gid="cylinder-edges")
    if color_by is not None:
        _draw_folds(ax, model, rec, color_by, norm, eye, shift)
        if colorbar:
            add_colorbar(ax, color_by, *fold_scale(color_by, norm, model, q))

    xyz = srf.points + shift
    lo, hi = np.minimum(xyz.min(axis=0), [np.inf, np.inf, 0.0]), xyz.max(axis=0)
    if first:
        if scale_bar:
            bar = _nice_length(hi[2] - lo[2])
            x0, y0 = offset[0] - 1.8 * radius, offset[1]
            ax.plot([x0, x0], [y0, y0], [0.0, bar], color="0.2", lw=1.2)
            ax.text(x0, y0, 0.5 * bar, f"{bar:g} mm ", ha="right", va="center", fontsize=FONT_SIZE)
            lo[0] = min(lo[0], x0)
    else:
        lo = np.minimum(lo, [ax.get_xlim()[0], ax.get_ylim()[0], ax.get_zlim()[0]])
        hi = np.maximum(hi, [ax.get_xlim()[1], ax.get_ylim()[1], ax.get_zlim()[1]])
    set_limits3d(ax, lo, hi)
    ax.set_proj_type("ortho")
    ax.computed_zorder = False  # lines (zorder 2, 3) over the depth-sorted facets (zorder 1)
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    return ax
