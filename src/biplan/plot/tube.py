"""The planar development of a tube configuration, and the fold colouring shared by all views.

:func:`development` draws the deformed development (s horizontal, z vertical, both in mm): the
rigid elements as light polygons (element 1 = ABCD, element 2 = EFG, global nodes of SI Eq.
global_module_min) and every fold as a line coloured by its local elongation w [mm], which is
linear along each BiPlan field (SI Eq. 17), or by the branch of its law (closed, spinodal,
open):

* helical fold of module n: from the midpoint of D/E (w = w0) to that of C/F (w = wa);
* circular fold: one line per field, midway between the facing edges (the upper module's
  bottom edge and the lower module's top edge, or the clamp line z = 0), from w_start to
  w_end over its circumferential range.

Each fold field is one :class:`~matplotlib.collections.LineCollection` of short sub-segments
(gid ``"helical-fold-n"`` or ``"circular-field-c-j"``), so the colour follows w along it. On
request the guides (the rails along n_sp through the reference nodes C and F, SI Eq. 11) and
the rotation centres (pivots A and G) are drawn too. :func:`development_panels` puts several
states (e.g. the reference and a deformed one) side by side on one colour scale.

The geometry comes from :mod:`biplan.geometry.surface`; this module only draws it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib import colormaps
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import BoundaryNorm, Colormap, ListedColormap, Normalize
from matplotlib.patches import Rectangle

from biplan.geometry import foldlines, surface
from biplan.geometry.foldlines import branch_index
from biplan.geometry.module import directions
from biplan.geometry.surface import ELEMENT_POLYGONS as ELEMENT_NODES
from biplan.geometry.surface import element_strips
from biplan.plot.response import FONT_SIZE, _new_axes, _style

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from biplan.model.assembly import Model

__all__ = [
    "ARC_SUBDIVISIONS",
    "ELEMENT_NODES",
    "development",
    "development_panels",
    "element_strips",
    "elongation_norm",
    "fold_lines",
]

#: Light fills of element 1 and element 2 (colour-blind-safe blue / orange tints).
ELEMENT_FILL = ("#d5e3f0", "#f6e1c8")
ELEMENT_EDGE = "0.35"
#: Sub-segments per fold line (colour gradient); facets per circumference of the cylinder.
FOLD_SUBDIVISIONS = 24
ARC_SUBDIVISIONS = surface.DEFAULT_SUBDIVISIONS
#: Perceptually uniform, colour-blind-safe map; its brightest 10 % (pale yellow) is cut so that
#: open folds stay visible on the light element fills.
ELONGATION_CMAP = ListedColormap(colormaps["cividis"](np.linspace(0.0, 0.9, 256)), "cividis_cut")
PHASES = ("closed", "spinodal", "open")
PHASE_CMAP = ListedColormap(colormaps["cividis"]([0.05, 0.5, 0.88]), "phases")
PHASE_NORM = BoundaryNorm([-0.5, 0.5, 1.5, 2.5], 3)
LINEAR_FOLD_COLOR = "0.25"
#: Guides (Okabe–Ito reddish purple) and rotation centres.
GUIDE_COLOR = "#CC79A7"
PIVOT_COLOR = "0.15"


def fold_lines(model: Model, q: np.ndarray) -> list[tuple[str, np.ndarray, np.ndarray, Any]]:
    """Geometry and elongation of every fold field at ``q``.

    Parameters
    ----------
    model : Model
    q : ndarray, shape (n_q,)
        Generalised coordinates.

    Returns
    -------
    list of (gid, start, end, law)
        One entry per helical fold (N) and per circular fold field: an identifier, start and
        end points ``(z, s, w)`` [mm] (position in the development and elongation there) and
        the fold's law (see :func:`biplan.geometry.foldlines.fold_lines`).
    """
    lines = _lines(model, q)
    laws = _laws(model)
    return [
        (name, np.r_[lines.start[f], lines.w_start[f]], np.r_[lines.end[f], lines.w_end[f]], law)
        for f, (name, law) in enumerate(zip(lines.names, laws[lines.fold], strict=True))
    ]


def _lines(model: Model, q: np.ndarray) -> foldlines.FoldLines:
    return foldlines.fold_lines(model.layout, model.params.geometry, model.kinematics(q))


def _laws(model: Model) -> np.ndarray:
    """Law of every fold, helical then circular (object array, indexable by fold)."""
    laws = np.empty(model.layout.n_modules + model.layout.n_connectors, dtype=object)
    laws[:] = [*model.tube.helical_laws, *model.tube.circular_laws]
    return laws


def elongation_norm(model: Model, qs: list[np.ndarray] | np.ndarray) -> Normalize:
    """A colour scale [mm] spanning the fold elongations of one or several states ``qs``.

    From min(0, w) to max(w) over every fold field of every state (at least 1 µm wide).
    """
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    w = np.concatenate([np.r_[ln.w_start, ln.w_end] for ln in (_lines(model, q) for q in qs)])
    return Normalize(vmin=min(0.0, float(w.min())), vmax=max(float(w.max()), 1e-3))


def fold_scale(
    color_by: str, norm: Normalize | None, model: Model, q: np.ndarray
) -> tuple[Colormap, Normalize]:
    """Colour map and norm of a fold view: ``"elongation"`` (w [mm]) or ``"phase"``.

    Raises
    ------
    ValueError
        For an unknown ``color_by``.
    """
    if color_by == "elongation":
        return ELONGATION_CMAP, norm or elongation_norm(model, q)
    if color_by == "phase":
        return PHASE_CMAP, PHASE_NORM
    raise ValueError(f"color_by must be 'elongation' or 'phase', got {color_by!r}")


def fold_values(color_by: str, law: Any, w: np.ndarray) -> np.ndarray:
    """What the colour shows at elongations ``w``: w itself or the branch (NaN: single-branch)."""
    return np.asarray(w, dtype=float) if color_by == "elongation" else branch_index(law, w)


def add_colorbar(ax: Axes | list[Axes], color_by: str, cmap: Colormap, norm: Normalize) -> None:
    """A colorbar for the folds next to ``ax`` (one Axes or a row of them): "w [mm]" or the
    three phase names."""
    from matplotlib.cm import ScalarMappable

    fig = (ax[0] if isinstance(ax, list) else ax).figure
    cb = fig.colorbar(ScalarMappable(norm, cmap), ax=ax, shrink=0.8, aspect=30)
    if color_by == "elongation":
        cb.set_label(r"$w$ [mm]", fontsize=FONT_SIZE)
    else:
        cb.set_ticks([0, 1, 2], labels=list(PHASES))
    cb.ax.tick_params(labelsize=FONT_SIZE)


def _segments_along(start: np.ndarray, end: np.ndarray, n: int) -> np.ndarray:
    """(n, 2, 2) sub-segments of the straight line start → end, points in (s, z) order."""
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    pts = (1 - t) * start + t * end
    return np.stack([pts[:-1], pts[1:]], axis=1)[..., ::-1]


def _draw_guides(ax: Axes, model: Model, q: np.ndarray, nodes: np.ndarray) -> None:
    """Guide rails through the reference C and F (along n_sp) and the pivots A and G."""
    kin = model.kinematics(q)
    beta, half = model.tube.development.beta, 0.3 * model.tube.development.pitch
    rails = []
    for n, shape in enumerate(model.layout.shapes):
        n_sp = np.asarray(directions(shape.kind, shape.mirror, beta)[1])
        for node in (2, 5):  # C, F
            ends = kin.reference[n, node] + np.outer([-half, half], n_sp)
            glob = ends @ kin.frames[n, :2, :2].T + kin.frames[n, :2, 2]
            rails.append(glob[:, ::-1])
    guides = LineCollection(rails, colors=GUIDE_COLOR, linewidths=0.9, linestyles=(0, (2, 1)))
    guides.set(zorder=4, gid="guides")
    ax.add_collection(guides, autolim=False)
    pivots = nodes[:, [0, 6]].reshape(-1, 2)
    ax.plot(pivots[:, 1], pivots[:, 0], "o", ms=3.0, mfc="white", mec=PIVOT_COLOR, mew=0.7)
    ax.lines[-1].set(zorder=5, gid="pivots")


def development(
    model: Model,
    q: np.ndarray,
    *,
    ax: Axes | None = None,
    color_by: str = "elongation",
    reference: bool = False,
    guides: bool = False,
    norm: Normalize | None = None,
    colorbar: bool = True,
) -> Axes:
    """Draw the deformed planar development with folds coloured by elongation or phase.

    Parameters
    ----------
    model : Model
    q : ndarray, shape (n_q,)
        Generalised coordinates (``solution.q``; zeros for the reference shape).
    ax : Axes, optional
        Axes to draw into; a new column-width figure when omitted.
    color_by : {"elongation", "phase"}
        Colour each fold by its local elongation w [mm] (continuous scale) or by the branch of
        its law it lies on (closed / spinodal / open; folds with a single-branch law are
        drawn as thin dark dashed lines).
    reference : bool
        Overlay the reference development (q = 0) as grey dashed outlines on top.
    guides : bool
        Draw the guides (dashed rails along the opening normal n_sp through the reference
        positions of C and F, gid ``"guides"``) and the rotation centres (pivots A and G,
        open circles, gid ``"pivots"``).
    norm : Normalize, optional
        Elongation colour scale [mm] (share one between panels, see :func:`elongation_norm`);
        default spans this state's elongations.
    colorbar : bool
        Add a colorbar ("w [mm]" or the phase names) next to the Axes.

    Returns
    -------
    Axes
        The Axes drawn into: s [mm] horizontal, z [mm] vertical, equal aspect.

    Raises
    ------
    ValueError
        For an unknown ``color_by``.
    """
    q = np.asarray(q, dtype=float)
    cmap, norm = fold_scale(color_by, norm, model, q)
    dev = model.tube.development
    ax = _new_axes(ax, (2.6, 3.4))
    glob = model.global_nodes(q)

    def polygons(nodes: np.ndarray) -> list[np.ndarray]:  # (s, z) outlines of all elements
        return [nodes[n, list(idx)][:, ::-1] for n in range(len(nodes)) for idx in ELEMENT_NODES]

    fills = [ELEMENT_FILL[k] for _ in range(len(glob)) for k in range(len(ELEMENT_NODES))]
    elements = PolyCollection(polygons(glob), fc=fills, ec=ELEMENT_EDGE, lw=0.4, zorder=2)
    ax.add_collection(elements, autolim=False)
    elements.set_gid("elements")
    if reference:
        ref = PolyCollection(polygons(model.global_nodes(model.zeros())), fc="none", ec="0.55")
        ref.set(linestyle="--", linewidth=0.5, zorder=2.5, gid="reference")
        ax.add_collection(ref, autolim=False)

    tt = (np.arange(FOLD_SUBDIVISIONS) + 0.5) / FOLD_SUBDIVISIONS
    for gid, start, end, law in fold_lines(model, q):
        values = fold_values(color_by, law, (1 - tt) * start[2] + tt * end[2])
        single = bool(np.all(np.isnan(values)))  # single-branch law in the phase view
        segs = _segments_along(start[:2], end[:2], 1 if single else FOLD_SUBDIVISIONS)
        lc = LineCollection(list(segs), zorder=3, gid=gid, capstyle="round")  # no seams
        if single:
            lc.set(color=LINEAR_FOLD_COLOR, linewidth=1.0, linestyle=(0, (3, 1.5)))
        else:
            lc.set(cmap=cmap, norm=norm, array=values, linewidth=1.8)
        ax.add_collection(lc)
    if guides:
        _draw_guides(ax, model, q, glob)

    clamp = Rectangle((0.0, -0.6), dev.circumference, 0.6, fill=False, hatch="////", lw=0.0)
    ax.add_patch(clamp).set(edgecolor="0.3", zorder=1)
    ax.plot([0.0, dev.circumference], [0.0, 0.0], color="0.3", lw=1.0, zorder=2)

    s_all, z_all = glob[..., 1], glob[..., 0]
    pad = 0.04 * dev.circumference
    ax.set_xlim(min(0.0, s_all.min()) - pad, max(dev.circumference, s_all.max()) + pad)
    ax.set_ylim(-0.6 - pad, z_all.max() + 2 * pad)
    ax.set_aspect("equal")
    ax.set_xlabel(r"$s$ [mm]")
    ax.set_ylabel(r"$z$ [mm]")
    _style(ax)
    if colorbar:
        add_colorbar(ax, color_by, cmap, norm)
    return ax


def development_panels(
    model: Model,
    qs: list[np.ndarray] | np.ndarray,
    *,
    titles: list[str] | None = None,
    color_by: str = "elongation",
    guides: bool = False,
    width: float | None = None,
) -> Figure:
    """Several developments side by side on one colour scale and one frame.

    Parameters
    ----------
    model : Model
    qs : sequence of ndarray, each (n_q,)
        The states, e.g. ``[model.zeros(), solution.q]`` for reference and deformed.
    titles : list of str, optional
        One panel title per state.
    color_by : {"elongation", "phase"}
        As for :func:`development`; one colorbar for all panels.
    guides : bool
        Draw guides and rotation centres in every panel.
    width : float, optional
        Figure width [in]; default 1.7 in per panel plus the colorbar, at most 7.0 in (a
        journal page; 3.4 in is a column).

    Returns
    -------
    Figure
        One row of Axes, the first with the z label; equal limits in all panels.
    """
    import matplotlib.pyplot as plt

    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    width = width or min(7.0, 1.7 * len(qs) + 0.9)
    fig, axes = plt.subplots(1, len(qs), figsize=(width, 3.6), layout="constrained", squeeze=False)
    norm = elongation_norm(model, qs) if color_by == "elongation" else None
    for i, (ax, q) in enumerate(zip(axes[0], qs, strict=True)):
        development(model, q, ax=ax, color_by=color_by, guides=guides, norm=norm, colorbar=False)
        if titles is not None:
            ax.set_title(titles[i], fontsize=FONT_SIZE)
    xlim = min(a.get_xlim()[0] for a in axes[0]), max(a.get_xlim()[1] for a in axes[0])
    ylim = min(a.get_ylim()[0] for a in axes[0]), max(a.get_ylim()[1] for a in axes[0])
    for i, a in enumerate(axes[0]):
        a.set(xlim=xlim, ylim=ylim)
        if i:
            a.set_ylabel("")
            a.tick_params(labelleft=False)
    add_colorbar(list(axes[0]), color_by, *fold_scale(color_by, norm, model, qs[0]))
    return fig
