"""The fold fields of a configuration as lines of the development, subdivided and wrapped.

Every fold field is a straight line of the development along which the elongation w [mm]
varies linearly (SI Eq. 17):

* the helical fold of module n runs from the midpoint of D/E (w = w0) to that of C/F (w = wa);
* a circular fold has one line per field (one to three per connector), midway between the
  facing edges (the upper module's bottom edge and the lower module's top edge, or the clamp
  line z = 0), from w_start to w_end over the field's circumferential range.

:func:`fold_lines` gives their end points and end elongations; :func:`fold_mesh` subdivides
them (a number of pieces fixed by the reference span, so the topology does not depend on the
configuration) and wraps them onto the cylinder like the element facets
(:mod:`biplan.geometry.surface`); :func:`branch_index` tells the branch of a fold law.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan.geometry import chain
from biplan.geometry.development import spans
from biplan.geometry.layout import TubeLayout

__all__ = ["FoldLines", "FoldMesh", "branch_index", "fold_lines", "fold_mesh"]

#: Pieces per circumference of a fold line (as the facets of the surface).
DEFAULT_SUBDIVISIONS = 48


@dataclass(frozen=True)
class FoldLines:
    """The fold fields of a configuration as straight lines of the development.

    Attributes
    ----------
    start, end : ndarray, shape (F, 2)
        End points (z, s) [mm] of each field's line: for a helical fold the midpoints of D/E and
        C/F, for a circular field the points midway between the facing edges.
    w_start, w_end : ndarray, shape (F,)
        Elongation w [mm] at the two ends (linear in between, SI Eq. 17).
    fold : ndarray of int, shape (F,)
        Fold of each field: n for the helical fold of module n, N + c for circular fold c
        (the order of the ``fold`` dimension of result files).
    span : ndarray, shape (F,)
        Circumferential extent [mm] of the field in the reference (H2 or the field length).
    names : tuple of str
        ``"helical-fold-n"`` or ``"circular-field-c-j"`` (field j of connector c).
    """

    start: np.ndarray
    end: np.ndarray
    w_start: np.ndarray
    w_end: np.ndarray
    fold: np.ndarray
    span: np.ndarray
    names: tuple[str, ...]


def _edge_point(ref: np.ndarray, glob: np.ndarray, segments: tuple, s: float) -> np.ndarray:
    """Global (z, s) of the point at reference circumferential position ``s`` on an edge."""
    for _, i0, i1 in segments:
        s0, s1 = ref[i0, 1], ref[i1, 1]
        if min(s0, s1) - 1e-9 <= s <= max(s0, s1) + 1e-9:
            t = 0.0 if s1 == s0 else (s - s0) / (s1 - s0)
            return (1 - t) * glob[i0] + t * glob[i1]
    raise ValueError(f"s = {s} mm lies outside the edge")  # pragma: no cover - layout bug


def fold_lines(
    layout: TubeLayout, geometry: chain.GeometryParams, kin: chain.Kinematics
) -> FoldLines:
    """Geometry and elongation of every fold field of a configuration.

    Parameters
    ----------
    layout : TubeLayout
    geometry : GeometryParams
        R, l [mm] and β [rad] of the development.
    kin : Kinematics
        Kinematics of the configuration (:meth:`biplan.Model.kinematics`).

    Returns
    -------
    FoldLines
        N helical folds first, then the circular fields connector by connector.
    """
    kin = chain.Kinematics(*(np.asarray(v) for v in kin))
    glob = np.asarray(chain.global_nodes(kin))
    h, h1, h2, _ = (float(v) for v in spans(*(np.asarray(g) for g in geometry)))
    rows: list[tuple[Any, ...]] = []
    for n in range(layout.n_modules):
        start, end = 0.5 * (glob[n, 3] + glob[n, 4]), 0.5 * (glob[n, 2] + glob[n, 5])  # D/E, C/F
        rows.append((start, end, *kin.helical[n], n, h2, f"helical-fold-{n}"))
    s_of_rank = np.array([0.0, h1, h2, h])
    t = chain.tables(layout)
    field_no = np.zeros(layout.n_connectors, dtype=int)
    for f, c in enumerate(t.field_conn):
        spec = layout.connectors[c]
        up, lo = spec.upper, spec.lower
        ends = []
        for pt in (t.field_start[f], t.field_end[f]):
            s = s_of_rank[t.pt_s[pt]]
            bottom = layout.shapes[up].bottom.segments
            upper = _edge_point(kin.reference[up], glob[up], bottom, s)
            if lo is None:
                lower = np.array([0.0, s])  # the clamp line z = 0
            else:
                top = layout.shapes[lo].top.segments
                lower = _edge_point(kin.reference[lo], glob[lo], top, s)
            ends.append(0.5 * (upper + lower))
        w0, w1 = kin.field_start[f], kin.field_end[f]
        name = f"circular-field-{c}-{field_no[c]}"
        rows.append((*ends, w0, w1, layout.n_modules + c, kin.field_length[f], name))
        field_no[c] += 1
    cols = list(zip(*rows, strict=True))
    return FoldLines(
        start=np.asarray(cols[0], dtype=float),
        end=np.asarray(cols[1], dtype=float),
        w_start=np.asarray(cols[2], dtype=float),
        w_end=np.asarray(cols[3], dtype=float),
        fold=np.asarray(cols[4], dtype=np.int64),
        span=np.abs(np.asarray(cols[5], dtype=float)),
        names=tuple(cols[6]),
    )


@dataclass(frozen=True)
class FoldMesh:
    """Fold fields as wrapped polylines with their elongation at every vertex.

    Attributes
    ----------
    points : ndarray, shape (K, 3)
        Vertices on the cylinder [mm].
    plane : ndarray, shape (K, 2)
        The same vertices in the development (z, s) [mm].
    w : ndarray, shape (K,)
        Elongation [mm] at each vertex.
    segments : ndarray of int, shape (S, 2)
        Vertex indices of each line segment.
    field : ndarray of int, shape (S,)
        Field (row of the :class:`FoldLines`) of each segment.
    """

    points: np.ndarray
    plane: np.ndarray
    w: np.ndarray
    segments: np.ndarray
    field: np.ndarray


def fold_mesh(
    lines: FoldLines, radius: float, *, subdivisions: int = DEFAULT_SUBDIVISIONS
) -> FoldMesh:
    """Subdivide every fold line (about ``subdivisions`` pieces per turn) and wrap it.

    The number of pieces of a field depends only on its reference span, so the mesh topology
    is the same for every configuration of a tube.
    """
    width = 2 * np.pi * float(radius) / subdivisions
    plane, w, segments, field = [], [], [], []
    n_points = 0
    for f in range(len(lines.fold)):
        pieces = max(1, int(np.ceil(lines.span[f] / width - 1e-9)))
        t = np.linspace(0.0, 1.0, pieces + 1)
        plane.append((1 - t)[:, None] * lines.start[f] + t[:, None] * lines.end[f])
        w.append((1 - t) * lines.w_start[f] + t * lines.w_end[f])
        segments.append(n_points + np.column_stack([np.arange(pieces), np.arange(1, pieces + 1)]))
        field.append(np.full(pieces, f))
        n_points += pieces + 1
    pts = np.concatenate(plane)
    return FoldMesh(
        points=np.asarray(chain.wrap_to_cylinder(pts, float(radius))),
        plane=pts,
        w=np.concatenate(w),
        segments=np.concatenate(segments).astype(np.int64),
        field=np.concatenate(field).astype(np.int64),
    )


def branch_index(law: Any, w: np.ndarray) -> np.ndarray:
    """Branch of a fold law at elongations ``w`` [mm]: 0 closed, 1 spinodal, 2 open.

    NaN everywhere for a single-branch law (one without ``transitions``, e.g. a linear law).
    """
    w = np.asarray(w, dtype=float)
    transitions = getattr(law, "transitions", None)
    if transitions is None:
        return np.full_like(w, np.nan)
    return np.searchsorted(np.asarray(transitions, dtype=float), w, side="right").astype(float)
