"""Mass matrix and inertia forces of the rigid elements (SI "Euler-Lagrange Governing
Equations"; MODEL §13).

A material point r0 of a rigid element moves with the element: r(q; r0) is affine in r0, so
∂r/∂q is affine in r0 and the integrand of M(q) = ∫ μ (∂r/∂q)ᵀ(∂r/∂q) dA is quadratic in r0.
The three-point edge-midpoint rule on each triangle is then exact. Element 0 of a module
(ABCD) is split into the triangles ABC and ACD, element 1 is the triangle EFG; a quadrature
point is the mean of two deformed nodes (rigid ⇒ affine), so the whole rule only needs the
deformed nodes of :func:`biplan.geometry.chain.global_nodes`. Fold fields are massless.

With p_k(q) the quadrature points and w_k = μ A_tri / 3 their weights::

    T = ½ q̇ᵀ M q̇ = ½ Σ_k w_k |J_k q̇|²,        J_k = ∂p_k/∂q
    d/dt ∂T/∂q̇ − ∂T/∂q = M q̈ + Σ_k w_k J_kᵀ (∂²p_k/∂q²)[q̇, q̇]

so the velocity-quadratic (Coriolis) term is a second directional derivative, computed by
nested ``jvp`` without forming ∂M/∂q.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from biplan._compile.setup import jax, jnp
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.model.params import ModelParams

__all__ = ["TRIANGLES", "inertia_force", "mass_matrix", "quadrature_points", "quadrature_weights"]

Array = Any

#: Triangles of a module by node index (A..G = 0..6): ABC, ACD (element 0), EFG (element 1).
TRIANGLES = ((0, 1, 2), (0, 2, 3), (4, 5, 6))
_EDGES = np.array([(t[i], t[(i + 1) % 3]) for t in TRIANGLES for i in range(3)])


def quadrature_points(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    """Edge midpoints of every triangle in the global development plane, (N·9, 2) [mm]."""
    nodes = chain.global_nodes(chain.kinematics(layout, p.geometry, q))
    mid = 0.5 * (nodes[:, _EDGES[:, 0]] + nodes[:, _EDGES[:, 1]])
    return mid.reshape(-1, 2)


def quadrature_weights(layout: TubeLayout, p: ModelParams, surface_density: Array) -> Array:
    """w_k = μ A_tri / 3 [t] of each quadrature point (reference areas; rigid ⇒ constant)."""
    ref = chain.global_nodes(chain.kinematics(layout, p.geometry, jnp.zeros(layout.n_coordinates)))
    areas = []
    for a, b, c in TRIANGLES:
        u, v = ref[:, b] - ref[:, a], ref[:, c] - ref[:, a]
        areas.append(0.5 * jnp.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]))
    per_tri = jnp.stack(areas, axis=1)  # (N, 3)
    return (surface_density * jnp.repeat(per_tri, 3, axis=1) / 3.0).reshape(-1)


def mass_matrix(layout: TubeLayout, p: ModelParams, q: Array, surface_density: Array) -> Array:
    """M(q) = Σ_k w_k J_kᵀ J_k, (n_q, n_q) [t·mm² per unit² of q]."""
    jac = jax.jacfwd(lambda qq: quadrature_points(layout, p, qq))(q)  # (K, 2, n_q)
    w = quadrature_weights(layout, p, surface_density)
    return jnp.einsum("k,kdi,kdj->ij", w, jac, jac)


def inertia_force(
    layout: TubeLayout, p: ModelParams, q: Array, v: Array, a: Array, surface_density: Array
) -> Array:
    """M(q) q̈ + c(q, q̇) [N], the generalized inertia force."""

    def pts(qq: Array) -> Array:
        return quadrature_points(layout, p, qq)

    def vel(qq: Array) -> Array:
        return jax.jvp(pts, (qq,), (v,))[1]

    _, jv = jax.jvp(pts, (q,), (v,))
    _, hvv = jax.jvp(vel, (q,), (v,))
    _, ja = jax.jvp(pts, (q,), (a,))
    acc = ja + hvv  # material accelerations (K, 2)
    w = quadrature_weights(layout, p, surface_density)
    _, vjp = jax.vjp(pts, q)
    del jv
    return vjp(w[:, None] * acc)[0]
