"""Shapes of many configurations of one tube, in the compact form the explorer page draws.

Every configuration shares the facet mesh of the reference (q = 0): each rigid element's
polygon is cut into strips in the reference and carried rigidly with its element
(:func:`biplan.geometry.surface.surface`, the mesh of ``biplan plot --kind tube``). A page
therefore holds the reference mesh once — the development points (z, s) [mm], their element,
the triangles and the element outlines — and, per configuration, only each element's rigid
motion (angle [rad], shift (z, s) [mm], :func:`biplan.geometry.surface.rigid_fit`) and its fold
lines (end points and branch). The page's script moves the points by the motions and wraps
them onto the cylinder, (z, s) ↦ (R cos(s/R), R sin(s/R), z), as :func:`tube_points` does
here; ``tests/test_explore_browser.py`` checks that both agree with the surface module.

The mesh is decimated to :data:`SUBDIVISIONS` strips per circumference (the figures use 48):
it is the same surface, coarser, and the page stays small (the per-state part does not grow
with the mesh).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.geometry import chain, foldlines, surface

if TYPE_CHECKING:
    from biplan.model.assembly import Model

__all__ = ["SUBDIVISIONS", "ShapeSet", "shape_set", "tube_points"]

#: Strips per circumference of the page's mesh (decimated from the figures' 48).
SUBDIVISIONS = 24
#: Decimals kept of angles [rad] and lengths [mm] (a µm on a tube of a few mm).
DECIMALS = 5
#: Fold-line branch codes: closed, spinodal, open; −1 a single-branch law.
SINGLE_BRANCH = -1


@dataclass(frozen=True)
class ShapeSet:
    """The reference mesh of a tube and the rigid motions and folds of configurations.

    Attributes
    ----------
    radius : float
        Cylinder radius R [mm].
    plane : ndarray, shape (P, 2)
        Mesh points (z, s) [mm] of the reference development.
    element : ndarray of int, shape (P,)
        Element of every point: 2 n + k for element k (0: ABCD, 1: EFG) of module n.
    triangles : ndarray of int, shape (T, 3)
        Point indices of every triangle of the facets.
    outlines : tuple of ndarray
        Point indices of every element's outline polygon in the reference (its corners).
    motions : ndarray, shape (S, E, 3)
        Per configuration and element: rotation angle [rad] and shift (z, s) [mm], so that
        deformed = rot(angle) · reference + shift.
    folds : ndarray, shape (S, F, 5)
        Per configuration and fold field: start (z, s), end (z, s) [mm] and the branch of its
        law at the middle (0 closed, 1 spinodal, 2 open, −1 single-branch).
    """

    radius: float
    plane: np.ndarray
    element: np.ndarray
    triangles: np.ndarray
    outlines: tuple[np.ndarray, ...]
    motions: np.ndarray
    folds: np.ndarray

    def to_json(self) -> dict[str, Any]:
        """Plain lists and numbers for the page (rounded to :data:`DECIMALS`)."""
        return {
            "radius": self.radius,
            "plane": np.round(self.plane, DECIMALS).tolist(),
            "element": self.element.tolist(),
            "triangles": self.triangles.T.tolist(),
            "outlines": [o.tolist() for o in self.outlines],
            "motions": np.round(self.motions.reshape(len(self.motions), -1), DECIMALS).tolist(),
            "folds": np.round(self.folds.reshape(len(self.folds), -1), DECIMALS).tolist(),
        }


def _reference_mesh(model: Model, subdivisions: int) -> surface.Surface:
    reference = np.asarray(model.global_nodes(model.zeros()))
    return surface.surface(reference, model.tube.development.radius, subdivisions=subdivisions)


def _laws(model: Model) -> list[Any]:
    return [*model.tube.helical_laws, *model.tube.circular_laws]


def _folds(model: Model, kin: chain.Kinematics) -> np.ndarray:
    lines = foldlines.fold_lines(model.layout, model.params.geometry, kin)
    laws = _laws(model)
    branch = np.array(
        [
            foldlines.branch_index(laws[f], np.asarray([0.5 * (w0 + w1)]))[0]
            for f, w0, w1 in zip(lines.fold, lines.w_start, lines.w_end, strict=True)
        ],
        dtype=float,
    )
    branch = np.where(np.isnan(branch), SINGLE_BRANCH, branch)
    return np.column_stack([lines.start, lines.end, branch])


def _motions(kin: chain.Kinematics, reference: np.ndarray) -> np.ndarray:
    nodes = np.asarray(chain.global_nodes(kin))
    rows = []
    for n in range(len(nodes)):
        for idx in surface.ELEMENT_POLYGONS:
            rot, shift = surface.rigid_fit(reference[n, list(idx)], nodes[n, list(idx)])
            rows.append((np.arctan2(rot[1, 0], rot[0, 0]), shift[0], shift[1]))
    return np.asarray(rows, dtype=float)


def shape_set(
    model: Model, qs: Sequence[np.ndarray] | np.ndarray, *, subdivisions: int = SUBDIVISIONS
) -> ShapeSet:
    """The reference mesh of ``model``'s tube and the motions and folds of configurations.

    Parameters
    ----------
    model : Model
    qs : array_like, shape (S, n_q)
        Generalised coordinates of the configurations (rows with NaN, e.g. failed steps, get
        the reference shape).
    subdivisions : int
        Strips per circumference of the mesh.

    Returns
    -------
    ShapeSet
    """
    mesh = _reference_mesh(model, subdivisions)
    reference = np.asarray(model.global_nodes(model.zeros()))
    element = np.empty(len(mesh.points), dtype=np.int64)
    for facet, n, k in zip(mesh.facets, mesh.module, mesh.element, strict=True):
        element[facet[facet >= 0]] = 2 * n + k
    outlines = []
    for n in range(len(reference)):
        for k, idx in enumerate(surface.ELEMENT_POLYGONS):
            corners = reference[n, list(idx)]
            mine = np.flatnonzero(element == 2 * n + k)
            dist = np.linalg.norm(mesh.plane[mine][None, :, :] - corners[:, None, :], axis=2)
            outlines.append(mine[np.argmin(dist, axis=1)])
    motions, folds = [], []
    for q in np.atleast_2d(np.asarray(qs, dtype=float)):
        q = q if np.all(np.isfinite(q)) else np.zeros_like(q)
        kin = model.kinematics(q)
        motions.append(_motions(kin, reference))
        folds.append(_folds(model, kin))
    return ShapeSet(
        radius=float(mesh.radius),
        plane=mesh.plane,
        element=element,
        triangles=mesh.triangles()[0],
        outlines=tuple(outlines),
        motions=np.asarray(motions),
        folds=np.asarray(folds),
    )


def tube_points(shapes: ShapeSet, index: int) -> np.ndarray:
    """The mesh points (P, 3) [mm] on the cylinder of configuration ``index``: what the page
    draws (the reference points moved by their element's motion, then wrapped)."""
    angle, dz, ds = shapes.motions[index][shapes.element].T
    z0, s0 = shapes.plane.T
    z = np.cos(angle) * z0 - np.sin(angle) * s0 + dz
    s = np.sin(angle) * z0 + np.cos(angle) * s0 + ds
    r = shapes.radius
    return np.column_stack([r * np.cos(s / r), r * np.sin(s / r), z])
