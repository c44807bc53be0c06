"""Surface of a deformed tube: its rigid elements cut into facets and wrapped onto the cylinder.

The chain reconstruction (:mod:`biplan.geometry.chain`, MODEL.md §9) places every rigid element
of every module in the global development plane (z, s) [mm]. This module turns those placed
polygons into a surface mesh of the tube (MODEL.md §10):

* Each element polygon of the *reference* development is cut into circumferential strips on
  the global grid s = k·H/n (:func:`element_strips`; n = ``subdivisions`` per turn), so that
  neighbouring elements share strip boundaries and every strip wraps onto a nearly flat
  facet. The strips are carried to the deformed development by the element's rigid motion
  (a rotation and a translation, fitted exactly to its nodes), so the mesh topology does not
  depend on the configuration and every facet keeps its shape in the development plane.
* The wrap (z, s) ↦ (R cos(s/R), R sin(s/R), z) is an isometry of the plane onto the
  cylinder: straight development edges become circular arcs and helices of the same length.
* The fold fields (helical crease of each module, circular-fold fields between modules) are
  straight lines of the development (:mod:`biplan.geometry.foldlines`); :func:`reconstruct`
  returns them with the facets, subdivided and wrapped the same way.

Open folds appear as gaps between the wrapped elements (circular bands, the helical wedge).
In-plane rotations of the chain move s off [0, H); the wrap is periodic, and where the planar
model is not compatible (B vs F when φ1 ≠ φ2, tilted module frames) the seam shows a small
step — inherent to the model, which enforces A ≡ G only (MODEL.md §10).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from biplan.geometry import chain
from biplan.geometry.foldlines import (
    DEFAULT_SUBDIVISIONS,
    FoldLines,
    FoldMesh,
    fold_lines,
    fold_mesh,
)
from biplan.geometry.layout import TubeLayout

__all__ = [
    "DEFAULT_SUBDIVISIONS",
    "ELEMENT_POLYGONS",
    "Reconstruction",
    "Surface",
    "clip_polygon",
    "element_strips",
    "reconstruct",
    "rigid_fit",
    "surface",
]

#: Node indices (order A..G) of the two rigid elements' polygons: ABCD and EFG.
ELEMENT_POLYGONS = ((0, 1, 2, 3), (4, 5, 6))
#: Largest number of vertices of a strip of a convex quadrilateral (4 + 2 cuts).
MAX_STRIP_VERTICES = 6


def clip_polygon(poly: np.ndarray, s_cut: float, keep_above: bool) -> np.ndarray:
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
        strip = clip_polygon(clip_polygon(corners, k * width, True), (k + 1) * width, False)
        if len(strip) >= 3 and np.ptp(strip[:, 1]) > 1e-9 * width:
            strips.append(strip)
    return strips


def rigid_fit(reference: np.ndarray, deformed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (2, 2) and translation (2,) with deformed ≈ reference @ rotᵀ + t (2D Procrustes)."""
    c0, c1 = reference.mean(axis=0), deformed.mean(axis=0)
    a, b = reference - c0, deformed - c1
    angle = np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a * b))
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    return rot, c1 - rot @ c0


@functools.lru_cache(maxsize=4096)
def _reference_cut(corners: bytes, n_corners: int, width: float) -> tuple[np.ndarray, np.ndarray]:
    """The strips of one reference element polygon (``corners``, (k, 2) float64 bytes):
    their distinct vertices (U, 2) [mm] and each strip's vertex rows (S, 6), padded with −1.

    Cached: every frame of a time series cuts the same reference polygons.
    """
    strips = element_strips(np.frombuffer(corners).reshape(n_corners, 2), width)
    flat = np.concatenate(strips)
    key = np.round(flat / (1e-9 * width)).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    rows = np.full((len(strips), MAX_STRIP_VERTICES), -1)
    starts = np.cumsum([0] + [len(strip) for strip in strips])
    for j, strip in enumerate(strips):
        rows[j, : len(strip)] = inverse.reshape(-1)[starts[j] : starts[j + 1]]
    points = flat[first]
    for array in (points, rows):
        array.flags.writeable = False
    return points, rows


@dataclass(frozen=True)
class Surface:
    """Facets of all rigid elements of a tube, in the development plane and on the cylinder.

    Attributes
    ----------
    points : ndarray, shape (P, 3)
        Vertices on the cylinder (x, y, z) [mm]; z along the tube axis, the clamp at z = 0.
    plane : ndarray, shape (P, 2)
        The same vertices in the deformed development (z, s) [mm].
    facets : ndarray of int, shape (M, 6)
        Vertex indices of each facet (a convex polygon of 3–6 vertices in the development),
        padded with −1.
    module, element : ndarray of int, shape (M,)
        Module (0 = base) and element (0: ABCD, 1: EFG) of each facet.
    edges : tuple of ndarray
        One polyline (k, 2) [mm] in the deformed development per element edge (the polygon's
        sides, subdivided like the facets; wrap with :attr:`radius`).
    edge_nodes : ndarray of int, shape (E, 3)
        (module, start node, end node) of each edge, nodes in order A..G.
    radius : float
        Cylinder radius R [mm].
    """

    points: np.ndarray
    plane: np.ndarray
    facets: np.ndarray
    module: np.ndarray
    element: np.ndarray
    edges: tuple[np.ndarray, ...]
    edge_nodes: np.ndarray
    radius: float

    @property
    def n_facets(self) -> int:
        """Number of facets M."""
        return len(self.facets)

    def polygons(self) -> list[np.ndarray]:
        """Wrapped facets, one (k, 3) [mm] array of vertices each."""
        return [self.points[f[f >= 0]] for f in self.facets]

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """Fan triangulation of the facets: vertex indices (T, 3) and each triangle's facet (T,)."""
        tris, owner = [], []
        for j in range(1, MAX_STRIP_VERTICES - 1):
            has = self.facets[:, j + 1] >= 0
            tris.append(self.facets[has][:, [0, j, j + 1]])
            owner.append(np.flatnonzero(has))
        order = np.argsort(np.concatenate(owner), kind="stable")
        return np.concatenate(tris)[order], np.concatenate(owner)[order]

    def wrapped_edges(self) -> list[np.ndarray]:
        """The element edges on the cylinder, one (k, 3) [mm] polyline each."""
        if not self.edges:
            return []
        wrapped = np.asarray(chain.wrap_to_cylinder(np.concatenate(self.edges), self.radius))
        return np.split(wrapped, np.cumsum([len(e) for e in self.edges])[:-1])


def surface(
    nodes: np.ndarray,
    radius: float,
    *,
    reference: np.ndarray | None = None,
    subdivisions: int = DEFAULT_SUBDIVISIONS,
    polygons: tuple[tuple[int, ...], ...] = ELEMENT_POLYGONS,
) -> Surface:
    """Facet mesh of a deformed tube from its global development nodes.

    Parameters
    ----------
    nodes : ndarray, shape (N, 7, 2)
        Deformed global nodes A..G of every module in the development (z, s) [mm]
        (:meth:`biplan.Model.global_nodes`).
    radius : float
        Cylinder radius R [mm].
    reference : ndarray, shape (N, 7, 2), optional
        Reference global nodes (q = 0). The strips are cut in the reference and moved
        rigidly, which keeps the mesh topology fixed over a time series; without it the
        deformed polygons are cut on the global grid.
    subdivisions : int
        Strips per circumference H = 2πR.
    polygons : tuple of tuple of int
        Node indices of each rigid element's convex polygon.

    Returns
    -------
    Surface

    Raises
    ------
    ValueError
        For node arrays of different shapes or ``subdivisions`` < 3.
    """
    nodes = np.asarray(nodes, dtype=float)
    ref = nodes if reference is None else np.asarray(reference, dtype=float)
    if ref.shape != nodes.shape or nodes.ndim != 3:
        raise ValueError(f"nodes {nodes.shape} and reference {ref.shape} must be (N, 7, 2)")
    if subdivisions < 3:
        raise ValueError(f"subdivisions must be >= 3, got {subdivisions}")
    radius = float(radius)
    width = 2 * np.pi * radius / subdivisions
    plane, facets, module, element, edges, edge_nodes = [], [], [], [], [], []
    n_points = 0
    for n in range(len(nodes)):
        for k, idx in enumerate(polygons):
            corners0, corners = ref[n, list(idx)], nodes[n, list(idx)]
            rot, shift = rigid_fit(corners0, corners)
            cut, rows = _reference_cut(corners0.tobytes(), len(idx), width)
            plane.append(cut @ rot.T + shift)
            facets.append(np.where(rows >= 0, rows + n_points, -1))
            n_points += len(cut)
            module += [n] * len(rows)
            element += [k] * len(rows)
            for a, b in zip(idx, (*idx[1:], idx[0]), strict=True):
                pieces = max(1, int(np.ceil(abs(ref[n, b, 1] - ref[n, a, 1]) / width - 1e-9)))
                t = np.linspace(0.0, 1.0, pieces + 1)[:, None]
                edges.append((1 - t) * nodes[n, a] + t * nodes[n, b])
                edge_nodes.append((n, a, b))
    points = np.concatenate(plane)
    return Surface(
        points=np.asarray(chain.wrap_to_cylinder(points, radius)),
        plane=points,
        facets=np.concatenate(facets).astype(np.int64),
        module=np.asarray(module, dtype=np.int64),
        element=np.asarray(element, dtype=np.int64),
        edges=tuple(edges),
        edge_nodes=np.asarray(edge_nodes, dtype=np.int64),
        radius=radius,
    )


@dataclass(frozen=True)
class Reconstruction:
    """Everything drawn or exported of one configuration: facets, fold lines, wrapped folds."""

    surface: Surface
    lines: FoldLines
    folds: FoldMesh


def reconstruct(
    layout: TubeLayout,
    geometry: chain.GeometryParams,
    kin: chain.Kinematics,
    reference: chain.Kinematics,
    *,
    subdivisions: int = DEFAULT_SUBDIVISIONS,
) -> Reconstruction:
    """Reconstruct a configuration on the cylinder from its kinematics.

    Parameters
    ----------
    layout : TubeLayout
    geometry : GeometryParams
        R, l [mm] and β [rad].
    kin, reference : Kinematics
        Kinematics of the configuration and of the reference q = 0
        (:meth:`biplan.Model.kinematics`).
    subdivisions : int
        Facets per circumference.

    Returns
    -------
    Reconstruction
        Facets cut in the reference and moved rigidly (fixed topology), fold lines and their
        subdivided, wrapped form.
    """
    radius = float(geometry.radius)
    srf = surface(
        np.asarray(chain.global_nodes(kin)),
        radius,
        reference=np.asarray(chain.global_nodes(reference)),
        subdivisions=subdivisions,
    )
    lines = fold_lines(layout, geometry, kin)
    return Reconstruction(srf, lines, fold_mesh(lines, radius, subdivisions=subdivisions))
