"""One MFT module: two rigid elements joined by a helical BiPlan field (MODEL.md §4–5).

Standard module (S) in its own frame, coordinates (z, s)::

    element 1 (ABCD):  A(0,0)  B(l,0)  C(l,H)  D(0,H1)        pivot A
    element 2 (EFG):   E(0,H1) F(l,H)  G(0,H)                 pivot G

The mirrored module (M) is the image r ↦ Q r + c of S (``MirrorConvention``): reflection
z ↦ l − z (Q = diag(−1, 1)) or a point reflection (Q = −I). Directions transform with Q:
crease tangent n_c = Q[cos β, sin β], opening normal n_sp = Q[−sin β, cos β].

Rigid maps (SI Eq. 10 with the pivot added back, MODEL CHOICE K1), q = (u, φ1, φ2)::

    χ_i(r0) = R(φ_i)(r0 − P_i) + P_i + [u, 0]

Guides (SI Eq. 11): g_C = (r_C − r0_C)·n_c, g_F = (r_F − r0_F)·n_c.
Helical boundary elongations (SI Eq. bound, sign of MODEL CHOICE K2, w > 0 ⇔ opening)::

    w0 = (r_E − r_D)·n_sp,   wa = (r_F − r_C)·n_sp
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from biplan._compile.setup import jnp
from biplan.options import MirrorConvention, ModuleKind

__all__ = [
    "ELEMENT_OF",
    "NODES",
    "PIVOT",
    "Edge",
    "ModuleShape",
    "element_map",
    "guides",
    "helical_boundary",
    "module_shape",
    "node_positions",
]

Array = Any

#: Node names in storage order, the element (0 or 1) each belongs to and each element's pivot.
NODES = ("A", "B", "C", "D", "E", "F", "G")
ELEMENT_OF = (0, 0, 0, 0, 1, 1, 1)
PIVOT = (0, 6)  # A for element 0, G for element 1
_IDX = {n: i for i, n in enumerate(NODES)}


@dataclass(frozen=True)
class Edge:
    """Static description of a module's top or bottom edge.

    ``segments`` are (element, start node, end node) in order of increasing s; ``split`` names
    the circumferential position of the split point (``"H1"``, ``"H2"``) or is ``None`` for a
    full edge held by one element.
    """

    segments: tuple[tuple[int, int, int], ...]
    split: str | None


@dataclass(frozen=True)
class ModuleShape:
    """Static (hashable) shape of a module: its kind and its bottom/top edges."""

    kind: ModuleKind
    mirror: MirrorConvention
    bottom: Edge
    top: Edge


def _seg(element: int, a: str, b: str) -> tuple[int, int, int]:
    return (element, _IDX[a], _IDX[b])


def module_shape(kind: ModuleKind, mirror: MirrorConvention) -> ModuleShape:
    """Edges of a module of the given kind under the given mirror convention."""
    if kind is ModuleKind.STANDARD:
        bottom = Edge((_seg(0, "A", "D"), _seg(1, "E", "G")), "H1")
        top = Edge((_seg(0, "B", "C"),), None)
    elif mirror is MirrorConvention.REFLECTION:
        bottom = Edge((_seg(0, "B", "C"),), None)
        top = Edge((_seg(0, "A", "D"), _seg(1, "E", "G")), "H1")
    else:  # point reflection: A(l,H) B(0,H) C(0,0) D(l,H2) E(l,H2) F(0,0) G(l,0)
        bottom = Edge((_seg(0, "C", "B"),), None)
        top = Edge((_seg(1, "G", "E"), _seg(0, "D", "A")), "H2")
    return ModuleShape(kind, mirror, bottom, top)


def _transform(kind: ModuleKind, mirror: MirrorConvention, l: Array, h: Array) -> tuple:
    """(Q diagonal, offset c) mapping the standard module onto this kind."""
    if kind is ModuleKind.STANDARD:
        return (1.0, 1.0), (0.0, 0.0)
    if mirror is MirrorConvention.REFLECTION:
        return (-1.0, 1.0), (l, 0.0)
    return (-1.0, -1.0), (l, h)


def reference_nodes(
    kind: ModuleKind, mirror: MirrorConvention, l: Array, h: Array, h1: Array
) -> Array:
    """Reference node coordinates (7, 2) [mm] in the module frame (order :data:`NODES`)."""
    zero = jnp.zeros_like(jnp.asarray(l, dtype=float))
    std = jnp.stack(
        [
            jnp.stack([zero, zero]),
            jnp.stack([l + zero, zero]),
            jnp.stack([l + zero, h + zero]),
            jnp.stack([zero, h1 + zero]),
            jnp.stack([zero, h1 + zero]),
            jnp.stack([l + zero, h + zero]),
            jnp.stack([zero, h + zero]),
        ]
    )
    (qz, qs), (cz, cs) = _transform(kind, mirror, l, h)
    return jnp.stack([qz * std[:, 0] + cz, qs * std[:, 1] + cs], axis=1)


def directions(kind: ModuleKind, mirror: MirrorConvention, beta: Array) -> tuple[Array, Array]:
    """(n_c, n_sp): crease tangent and opening normal of the helical fold in the module frame."""
    (qz, qs), _ = _transform(kind, mirror, 0.0, 0.0)
    n_c = jnp.stack([qz * jnp.cos(beta), qs * jnp.sin(beta)])
    n_sp = jnp.stack([-qz * jnp.sin(beta), qs * jnp.cos(beta)])
    return n_c, n_sp


def rotation(phi: Array) -> Array:
    """R(φ) (SI Eq. 9)."""
    c, s = jnp.cos(phi), jnp.sin(phi)
    # stacked, not ``jnp.array`` of nested tracers: a smaller graph at every call site
    return jnp.stack([jnp.stack([c, -s]), jnp.stack([s, c])])


def element_map(q: Array, ref: Array, element: int, r0: Array) -> Array:
    """χ_i(r0) = R(φ_i)(r0 − P_i) + P_i + [u, 0] for points r0 (..., 2) of element i."""
    pivot = ref[PIVOT[element]]
    rot = rotation(q[1 + element])
    return (r0 - pivot) @ rot.T + pivot + jnp.stack([q[0], 0.0])


def node_positions(q: Array, ref: Array) -> Array:
    """Deformed node positions (7, 2) [mm] in the module frame."""
    e0 = element_map(q, ref, 0, ref[:4])
    e1 = element_map(q, ref, 1, ref[4:])
    return jnp.concatenate([e0, e1], axis=0)


def guides(q: Array, ref: Array, n_c: Array) -> Array:
    """Guide measures (g_C, g_F) [mm] (SI Eq. 11)."""
    r = node_positions(q, ref)
    return jnp.stack([(r[2] - ref[2]) @ n_c, (r[5] - ref[5]) @ n_c])


def helical_boundary(q: Array, ref: Array, n_sp: Array) -> Array:
    """Boundary elongations (w0, wa) [mm] of the helical field (SI Eq. bound, MODEL K2)."""
    r = node_positions(q, ref)
    return jnp.stack([(r[4] - r[3]) @ n_sp, (r[5] - r[2]) @ n_sp])
