"""Pictures of a tube configuration: its planar development and the wrapped 3D cylinder.

:func:`development` draws the deformed development (s horizontal, z vertical, both in mm): the
rigid elements as light polygons (element 1 = ABCD, element 2 = EFG, global nodes of SI Eq.
global_module_min) and every fold as a line coloured by its local elongation w [mm], which is
linear along each BiPlan field (SI Eq. 17):

* helical fold of module n: from the midpoint of D/E (w = w0) to that of C/F (w = wa);
* circular fold: one line per field, midway between the facing edges (the upper module's
  bottom edge and the lower module's top edge, or the clamp line z = 0), from w_start to
  w_end over its circumferential range.

Each fold field is one :class:`~matplotlib.collections.LineCollection` of short sub-segments
(gid ``"helical-fold-n"`` or ``"circular-field-c-j"``), so the colour follows w along it.

:func:`cylinder` wraps each element onto the cylinder of radius R (MODEL.md §10): the element
polygon is cut into narrow circumferential strips (48 per turn, so that the helical crease,
half a turn, gets 24 sub-segments) and mapped by (z, s) ↦ (R cos(s/R), R sin(s/R), z), so
straight development edges become arcs and helices; open folds show as gaps (circular bands,
the wedge-shaped helical slit).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np
from matplotlib import colormaps
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import BoundaryNorm, ListedColormap, Normalize, to_rgb
from matplotlib.patches import Rectangle

from biplan.geometry import chain
from biplan.plot.response import FONT_SIZE, _new_axes, _style

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from mpl_toolkits.mplot3d.axes3d import Axes3D

    from biplan.assembly import Model

__all__ = ["cylinder", "development", "element_strips", "elongation_norm", "fold_lines"]

#: Node indices (order A..G) of the two rigid elements' polygons.
ELEMENT_NODES = ((0, 1, 2, 3), (4, 5, 6))
#: Light fills of element 1 and element 2 (colour-blind-safe blue / orange tints).
ELEMENT_FILL = ("#d5e3f0", "#f6e1c8")
ELEMENT_EDGE = "0.35"
#: Sub-segments per fold line (colour gradient); facets per circumference of the cylinder.
FOLD_SUBDIVISIONS = 24
ARC_SUBDIVISIONS = 48
#: Perceptually uniform, colour-blind-safe map; its brightest 10 % (pale yellow) is cut so that
#: open folds stay visible on the light element fills.
ELONGATION_CMAP = ListedColormap(colormaps["cividis"](np.linspace(0.0, 0.9, 256)), "cividis_cut")
PHASES = ("closed", "spinodal", "open")
LINEAR_FOLD_COLOR = "0.25"


def _segments_along(start: np.ndarray, end: np.ndarray, n: int) -> np.ndarray:
    """(n, 2, 2) sub-segments of the straight line start → end, points in (s, z) order."""
    t = np.linspace(0.0, 1.0, n + 1)[:, None]
    pts = (1 - t) * start + t * end
    return np.stack([pts[:-1], pts[1:]], axis=1)[..., ::-1]


def _edge_point(ref: np.ndarray, glob: np.ndarray, segments: tuple, s: float) -> np.ndarray:
    """Global (z, s) of the point at reference circumferential position ``s`` on an edge."""
    for _, i0, i1 in segments:
        s0, s1 = ref[i0, 1], ref[i1, 1]
        if min(s0, s1) - 1e-9 <= s <= max(s0, s1) + 1e-9:
            t = 0.0 if s1 == s0 else (s - s0) / (s1 - s0)
            return (1 - t) * glob[i0] + t * glob[i1]
    raise ValueError(f"s = {s} mm lies outside the edge")  # pragma: no cover - layout bug


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
        the fold's law.
    """
    layout, tube = model.layout, model.tube
    kin = model.kinematics(q)
    glob = model.global_nodes(q)
    out = []
    for n in range(layout.n_modules):
        start = 0.5 * (glob[n, 3] + glob[n, 4])  # D/E
        end = 0.5 * (glob[n, 2] + glob[n, 5])  # C/F
        w0, wa = kin.helical[n]
        out.append((f"helical-fold-{n}", np.r_[start, w0], np.r_[end, wa], tube.helical_laws[n]))
    if not layout.n_connectors:
        return out
    dev = tube.development
    s_of_rank = np.array([0.0, dev.element1_span, dev.helical_span, dev.circumference])
    t = chain.tables(layout)
    field_no = np.zeros(layout.n_connectors, dtype=int)
    for f, c in enumerate(t.field_conn):
        spec = layout.connectors[c]
        up, lo = spec.upper, spec.lower
        ends = []
        for pt, w in ((t.field_start[f], kin.field_start[f]), (t.field_end[f], kin.field_end[f])):
            s = s_of_rank[t.pt_s[pt]]
            upper = _edge_point(kin.reference[up], glob[up], layout.shapes[up].bottom.segments, s)
            if lo is None:
                lower = np.array([0.0, s])  # the clamp line z = 0
            else:
                top = layout.shapes[lo].top.segments
                lower = _edge_point(kin.reference[lo], glob[lo], top, s)
            ends.append(np.r_[0.5 * (upper + lower), w])
        out.append((f"circular-field-{c}-{field_no[c]}", *ends, tube.circular_laws[c]))
        field_no[c] += 1
    return out


def elongation_norm(model: Model, qs: list[np.ndarray] | np.ndarray) -> Normalize:
    """A colour scale [mm] spanning the fold elongations of one or several states ``qs``."""
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    return _span([e for q in qs for e in fold_lines(model, q)])


def _span(lines: list[tuple[str, np.ndarray, np.ndarray, Any]]) -> Normalize:
    """Colour scale from min(0, w) to max(w) [mm] over the ends of the given fold lines."""
    w = np.array([[start[2], end[2]] for _, start, end, _ in lines])
    return Normalize(vmin=min(0.0, float(w.min())), vmax=max(float(w.max()), 1e-3))


def _phase(law: Any, w: np.ndarray) -> np.ndarray:
    """Branch index 0 (closed), 1 (spinodal), 2 (open) of w, or NaN for a single-branch law."""
    transitions = getattr(law, "transitions", None)
    if transitions is None:
        return np.full_like(w, np.nan)
    return np.searchsorted(np.asarray(transitions, dtype=float), w, side="right").astype(float)


def development(
    model: Model,
    q: np.ndarray,
    *,
    ax: Axes | None = None,
    color_by: str = "elongation",
    reference: bool = False,
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
    if color_by not in ("elongation", "phase"):
        raise ValueError(f"color_by must be 'elongation' or 'phase', got {color_by!r}")
    q = np.asarray(q, dtype=float)
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

    lines = fold_lines(model, q)
    if color_by == "elongation":
        cmap = ELONGATION_CMAP
        norm = norm or _span(lines)
    else:
        cmap = ListedColormap(colormaps["cividis"]([0.05, 0.5, 0.88]), "phases")
        norm = BoundaryNorm([-0.5, 0.5, 1.5, 2.5], cmap.N)
    tt = (np.arange(FOLD_SUBDIVISIONS) + 0.5) / FOLD_SUBDIVISIONS
    for gid, start, end, law in lines:
        w = (1 - tt) * start[2] + tt * end[2]
        values = w if color_by == "elongation" else _phase(law, w)
        single = bool(np.all(np.isnan(values)))  # single-branch law in the phase view
        segs = _segments_along(start[:2], end[:2], 1 if single else FOLD_SUBDIVISIONS)
        lc = LineCollection(list(segs), zorder=3, gid=gid, capstyle="round")  # no seams
        if single:
            lc.set(color=LINEAR_FOLD_COLOR, linewidth=1.0, linestyle=(0, (3, 1.5)))
        else:
            lc.set(cmap=cmap, norm=norm, array=values, linewidth=1.8)
        ax.add_collection(lc)

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
        from matplotlib.cm import ScalarMappable

        cb = ax.figure.colorbar(ScalarMappable(norm, cmap), ax=ax, shrink=0.8, aspect=30)
        if color_by == "elongation":
            cb.set_label(r"$w$ [mm]", fontsize=FONT_SIZE)
        else:
            cb.set_ticks([0, 1, 2], labels=list(PHASES))
        cb.ax.tick_params(labelsize=FONT_SIZE)
    return ax


def _clip(poly: np.ndarray, s_cut: float, keep_above: bool) -> np.ndarray:
    """Sutherland–Hodgman clip of a convex polygon (k, 2) in (z, s) to s ≥ or ≤ ``s_cut``."""
    inside = (poly[:, 1] >= s_cut) if keep_above else (poly[:, 1] <= s_cut)
    out = []
    for i in range(len(poly)):
        p, nxt = poly[i], poly[(i + 1) % len(poly)]
        p_in, n_in = inside[i], inside[(i + 1) % len(poly)]
        if p_in:
            out.append(p)
        if p_in != n_in:
            t = (s_cut - p[1]) / (nxt[1] - p[1])
            out.append(p + t * (nxt - p))
    return np.asarray(out).reshape(-1, 2)


def element_strips(corners: np.ndarray, width: float) -> list[np.ndarray]:
    """Cut a convex element polygon (z, s) [mm] into strips of circumferential ``width`` [mm].

    Strip boundaries lie on the global grid s = k·width, so neighbouring elements share them.
    Each strip is a convex polygon of 3–6 vertices whose wrapped image is a nearly flat facet
    of the cylinder; its bottom and top edges become chords of arcs and helices.
    """
    s = corners[:, 1]
    strips = []
    for k in range(int(np.floor(s.min() / width)), int(np.ceil(s.max() / width))):
        strip = _clip(_clip(corners, k * width, True), (k + 1) * width, False)
        if len(strip) >= 3 and np.ptp(strip[:, 1]) > 1e-9 * width:
            strips.append(strip)
    return strips


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


def _front_edges(
    polygon: np.ndarray, width: float, radius: float, eye: np.ndarray
) -> list[np.ndarray]:
    """Wrapped edge pieces (2, 3) of an element polygon (z, s) that face the viewer ``eye``."""
    pieces = []
    for a, b in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
        n = max(1, int(np.ceil(abs(b[1] - a[1]) / width)))
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        xyz = np.asarray(chain.wrap_to_cylinder((1 - t) * a + t * b, radius))
        mid = 0.5 * (xyz[1:] + xyz[:-1])
        facing = mid[:, 0] * eye[0] + mid[:, 1] * eye[1] > 0.0
        pieces += [xyz[i : i + 2] for i in np.flatnonzero(facing)]
    return pieces


def cylinder(
    model: Model,
    q: np.ndarray,
    *,
    ax: Axes3D | None = None,
    elev: float = 20.0,
    azim: float = -60.0,
    offset: tuple[float, float] = (0.0, 0.0),
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

    Returns
    -------
    Axes3D
        The Axes drawn into: x, y, z [mm] at equal scale, orthographic, axes hidden, with a
        vertical scale bar next to the first tube drawn into it. Artists are drawn in zorder
        (``computed_zorder`` off): facets at 1, the element outlines facing the viewer at 2.
    """
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    q = np.asarray(q, dtype=float)
    radius = model.tube.development.radius
    ax = cast("Axes3D", _new_axes(ax, (2.6, 2.6), projection="3d"))
    first = not any(c.get_gid() == "cylinder" for c in ax.collections)
    glob = model.global_nodes(q)
    width = model.tube.development.circumference / ARC_SUBDIVISIONS
    eye = np.array([np.cos(np.radians(azim)), np.sin(np.radians(azim))])
    strips, base, edges = [], [], []
    for n in range(len(glob)):
        for k, idx in enumerate(ELEMENT_NODES):
            cut = element_strips(glob[n, list(idx)], width)
            strips += cut
            base += [ELEMENT_FILL[k]] * len(cut)
            edges += _front_edges(glob[n, list(idx)], width, radius, eye)
    facets = [np.asarray(chain.wrap_to_cylinder(p, radius)) for p in strips]
    rgb = _shaded(np.array([f.mean(axis=0) for f in facets]), base, elev, azim)
    shift = np.array([offset[0], offset[1], 0.0])
    facets = [f + shift for f in facets]
    # Edges in the face colour (not antialiased) hide the hairline seams between facets.
    poly = Poly3DCollection(facets, fc=rgb, ec=rgb, lw=0.3, aa=False, zorder=1, gid="cylinder")
    ax.add_collection3d(poly)
    # Element outlines (circular and helical creases, seam) where they face the viewer.
    outline = Line3DCollection([e + shift for e in edges], colors=ELEMENT_EDGE, linewidths=0.35)
    ax.add_collection3d(outline)
    outline.set(zorder=2, gid="cylinder-edges")

    xyz = np.concatenate(facets)
    lo, hi = np.minimum(xyz.min(axis=0), [np.inf, np.inf, 0.0]), xyz.max(axis=0)
    if first:
        bar = _nice_length(hi[2] - lo[2])
        x0, y0 = offset[0] - 1.8 * radius, offset[1]
        ax.plot([x0, x0], [y0, y0], [0.0, bar], color="0.2", lw=1.2)
        ax.text(x0, y0, 0.5 * bar, f"{bar:g} mm ", ha="right", va="center", fontsize=FONT_SIZE)
        lo[0] = min(lo[0], x0)
    else:
        lo = np.minimum(lo, [ax.get_xlim()[0], ax.get_ylim()[0], ax.get_zlim()[0]])
        hi = np.maximum(hi, [ax.get_xlim()[1], ax.get_ylim()[1], ax.get_zlim()[1]])
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(np.maximum(hi - lo, 1e-6)))
    ax.set_proj_type("ortho")
    ax.computed_zorder = False  # outlines (zorder 2) over the depth-sorted facets (zorder 1)
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    return ax
