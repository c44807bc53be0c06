"""Reduced coordinates: the guides solved in closed form (MODEL §16), and the penalised
energy of the state search assembled over the chain in them.

Each guide of a module (SI Eq. 11) involves one element: g_C = (χ_0(C) − C)·n_c depends on
(u, φ1), g_F = (χ_1(F) − F)·n_c on (u, φ2). With v = P − A the reference offset of the guided
node from its element's pivot, a = v·n_c, b = (Jv)·n_c (J the quarter turn),
ρ = √(a² + b²) and δ = atan2(b, a), the guide reads ρ cos(φ − δ) = a − u n_c,z, so

    φ(u) = δ − sgn(δ) arccos((a − u n_c,z) / ρ)

is the branch through φ(0) = 0 (MODEL §16's closed forms, for either module kind: the kind
enters through its reference nodes and n_c). It exists for |a − u n_c,z| ≤ ρ: beyond, the
module is kinematically locked (MODEL §16, "Kinematic lock") and φ is NaN.

The reduced coordinates x = (u_1 … u_N, γ_1 … γ_Nc) (N + Nc numbers, the tube's degrees of
freedom before contact) satisfy the guides exactly. In them the strain energy is again a sum
of local terms: a module's helical field depends on its own u, a connector's fields and gaps
on (u_lower, u_upper, γ) only. :func:`penalized_terms` evaluates the penalised energy of the
state search's descent (the JAX reading of :mod:`biplan.model.system.reduced`)

    Π(q(x)) + ½ k_p ‖min(w_∂(q(x)), 0)‖²

and its gradient and Hessian per element (local autodiff of a 1- or 3-variable function,
``vmap``-ped over the chain) and adds the blocks into the global arrays: O(N) work, where the
dense Hessian of the whole chain costs O(N²) energy evaluations. The tests compare it with
the dense autodiff of the same function written through :func:`full_coordinates`.

:func:`reduced_terms` does the same for the contact-only Lagrangian Π(q(x)) − λ_∂ᵀw_∂(q(x)):
with the guides eliminated, the KKT system of an equilibrium at rest (MODEL §11) reads

    [∇_x Π − (∂w_∂/∂x)ᵀ λ_∂,  φ_SFB(w_∂ + c λ_∂, λ_∂)] = 0

(:func:`biplan.model.lagrangian.reduced_residual_at_rest`), N + Nc + n_c unknowns instead of
3N + Nc + 2N + n_c. A solution is an equilibrium of the full system: the full stationarity
residual then lies in the range of the guide Jacobian's transpose (the columns of ∂q/∂x span
its null space), and least squares recovers the guide multipliers exactly
(:func:`biplan.model.lagrangian.full_state`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from biplan._compile.setup import jax, jnp
from biplan.geometry import chain
from biplan.geometry.development import spans
from biplan.geometry.layout import TubeLayout
from biplan.geometry.module import PIVOT, helical_boundary
from biplan.laws import _jax as law_jax
from biplan.model.elements.local import (
    ConnectorData,
    _connector_data,
    _evaluate,
    connector_gaps,
    connector_lagrangian,
)
from biplan.model.elements.topology import place_matrix, place_vector, topology
from biplan.model.params import ModelParams
from biplan.options import ContactForm

__all__ = [
    "PenalizedTerms",
    "ReducedTerms",
    "full_coordinates",
    "module_angles",
    "n_reduced",
    "penalized_energy",
    "penalized_terms",
    "reduced_coordinates",
    "reduced_terms",
]

Array = Any

#: Guided node and pivot of each element (C about A, F about G; :mod:`biplan.geometry.module`).
_GUIDED = ((2, PIVOT[0]), (5, PIVOT[1]))


def n_reduced(layout: TubeLayout) -> int:
    """Number of reduced coordinates N + Nc."""
    return layout.n_modules + layout.n_connectors


def module_angles(u: Array, ref: Array, n_c: Array) -> Array:
    """(φ1, φ2) [rad] that satisfy a module's two guides at axial displacement ``u`` [mm].

    Parameters
    ----------
    u : scalar
        The module's u [mm].
    ref : array (7, 2)
        Reference nodes of the module [mm] (:func:`biplan.geometry.chain.reference_frames`).
    n_c : array (2,)
        Crease tangent of its helical fold.
    """
    out = []
    for node, pivot in _GUIDED:
        v = ref[node] - ref[pivot]
        a = v @ n_c
        b = jnp.stack([-v[1], v[0]]) @ n_c
        rho = jnp.hypot(a, b)
        delta = jnp.arctan2(b, a)
        out.append(delta - jnp.sign(delta) * jnp.arccos((a - u * n_c[0]) / rho))
    return jnp.stack(out)


def _module_q(u: Array, ref: Array, n_c: Array) -> Array:
    return jnp.concatenate([u[None], module_angles(u, ref, n_c)])


def full_coordinates(layout: TubeLayout, p: ModelParams, x: Array) -> Array:
    """Coordinates q (3N + Nc,) of reduced coordinates x = (u, γ) (N + Nc,)."""
    n = layout.n_modules
    ref, n_c, _ = chain.reference_frames(layout, p.geometry)
    qm = jax.vmap(_module_q)(x[:n], ref, n_c)
    return jnp.concatenate([qm.reshape(-1), x[n:]])


def reduced_coordinates(layout: TubeLayout, q: Array) -> Array:
    """Reduced coordinates x = (u, γ) of coordinates q (the guides are not checked)."""
    n = layout.n_modules
    return jnp.concatenate([q[: 3 * n : 3], q[3 * n :]])


class PenalizedTerms(NamedTuple):
    """The penalised energy at x and its derivatives (second order only when asked)."""

    value: Array  # [N·mm]
    gradient: Array  # (N + Nc,)
    hessian: Array  # (N + Nc, N + Nc), or None


def _penalty(gaps: Array, stiffness: Array) -> Array:
    return 0.5 * stiffness * jnp.sum(jnp.minimum(gaps, 0.0) ** 2)


def _module_energy(
    u: Array, ref: Array, n_c: Array, n_sp: Array, length: Array, coeffs: Array, k: Array
) -> Array:
    w = helical_boundary(_module_q(u, ref, n_c), ref, n_sp)
    return law_jax.field_energy(w[0], w[1], length, tuple(coeffs)) + _penalty(w, k)


def _connector_energy(
    y: Array,
    nc_lower: Array,
    nc_upper: Array,
    d: ConnectorData,
    pitch: Array,
    minimum: bool,
    width: Array,
    k: Array,
) -> Array:
    x7 = jnp.concatenate(
        [_module_q(y[0], d.ref_lower, nc_lower), _module_q(y[1], d.ref_upper, nc_upper), y[2:]]
    )
    energies, gaps = connector_gaps(x7, d, pitch, minimum, width)
    return energies.sum() + _penalty(gaps, k)


class _Elements(NamedTuple):
    module: tuple[Array, ...]  # traced arguments of _module_energy after u
    connector: tuple[Array, ...]  # after y, up to (and without) the static flag
    dofs: np.ndarray  # (Nc, 3) reduced index of (u_lower, u_upper, γ)
    mask: np.ndarray  # (Nc, 3) 0 for the clamp's absent u_lower


def _elements(layout: TubeLayout, p: ModelParams, stiffness: Array) -> _Elements:
    geom = p.geometry
    ref, n_c, n_sp = chain.reference_frames(layout, geom)
    _, _, _, a = spans(geom.radius, geom.pitch, geom.beta)
    n = layout.n_modules
    k_m = jnp.full(n, stiffness)
    module = (ref, n_c, n_sp, jnp.full(n, a), p.helical, k_m)
    if not layout.n_connectors:
        return _Elements(module, (), np.zeros((0, 3), np.int32), np.zeros((0, 3)))
    topo = topology(layout)
    nc = layout.n_connectors
    dofs = np.stack([topo.lower, topo.upper, n + np.arange(nc)], axis=1).astype(np.int32)
    mask = np.ones((nc, 3))
    mask[:, 0] = topo.connector_dof_mask[:, 0]
    connector = (n_c[topo.lower], n_c[topo.upper], _connector_data(layout, p, ref))
    return _Elements(module, connector, dofs, mask)


def _connector_fn(layout: TubeLayout, p: ModelParams, stiffness: Array) -> Any:
    minimum = layout.options.contact is ContactForm.MINIMUM
    pitch, width = p.geometry.pitch, p.smooth_min_width

    def fn(y: Array, nc_lo: Array, nc_up: Array, d: ConnectorData) -> Array:
        return _connector_energy(y, nc_lo, nc_up, d, pitch, minimum, width, stiffness)

    return fn


def penalized_energy(layout: TubeLayout, p: ModelParams, x: Array, stiffness: Array) -> Array:
    """Π(q(x)) + ½ k_p ‖min(w_∂(q(x)), 0)‖² [N·mm] (module docstring), as a sum over the
    elements (NaN where a module is kinematically locked).

    Parameters
    ----------
    x : array (N + Nc,)
        Reduced coordinates [mm].
    stiffness : scalar
        Penalty stiffness k_p [N/mm] of the contact gaps.
    """
    el = _elements(layout, p, stiffness)
    total = jax.vmap(_module_energy)(x[: layout.n_modules], *el.module).sum()
    if layout.n_connectors:
        y = x[el.dofs] * el.mask
        total = total + jax.vmap(_connector_fn(layout, p, stiffness))(y, *el.connector).sum()
    return total


def _value_gradient_hessian(fn: Any, second_order: bool) -> Any:
    def first(y: Array, *args: Any) -> tuple[Array, tuple[Array, Array]]:
        value, grad = jax.value_and_grad(fn)(y, *args)
        return grad, (grad, value)

    def evaluate(y: Array, *args: Any) -> tuple[Array, Array, Array]:
        if not second_order:
            _, (grad, value) = first(y, *args)
            return value, grad, None
        hess, (grad, value) = jax.jacfwd(first, has_aux=True)(y, *args)
        return value, grad, hess

    return jax.vmap(evaluate)


def penalized_terms(
    layout: TubeLayout,
    p: ModelParams,
    x: Array,
    stiffness: Array,
    second_order: bool = True,
) -> PenalizedTerms:
    """:func:`penalized_energy`, its gradient and (if ``second_order``) its Hessian,
    evaluated per element and assembled (module docstring)."""
    n, size = layout.n_modules, n_reduced(layout)
    el = _elements(layout, p, stiffness)

    def module_fn(y: Array, *args: Any) -> Array:
        return _module_energy(y[0], *args)

    value_m, grad_m, hess_m = _value_gradient_hessian(module_fn, second_order)(
        x[:n, None], *el.module
    )
    index = np.arange(n, dtype=np.int32)[:, None]
    value = value_m.sum()
    gradient = place_vector(index, grad_m, size)
    hessian = place_matrix(index, hess_m, index, (size, size)) if second_order else None
    if layout.n_connectors:
        fn = _connector_fn(layout, p, stiffness)
        value_c, grad_c, hess_c = _value_gradient_hessian(fn, second_order)(
            x[el.dofs] * el.mask, *el.connector
        )
        value = value + value_c.sum()
        gradient = gradient + place_vector(el.dofs, grad_c, size, el.mask)
        if second_order:
            block = (size, size)
            hessian = hessian + place_matrix(el.dofs, hess_c, el.dofs, block, el.mask, el.mask)
    return PenalizedTerms(value, gradient, hessian)


# --- the KKT system in reduced coordinates ------------------------------------------------


class ReducedTerms(NamedTuple):
    """Per-element terms of the reduced Lagrangian Π(q(x)) − λ_∂ᵀ w_∂(q(x)), assembled."""

    gradient: Array  # (N + Nc,)
    gaps: Array  # (n_c,) w_∂
    hessian: Array  # (N + Nc, N + Nc), or None
    gap_jacobian: Array  # (n_c, N + Nc), or None


def _module_lagrangian(y: Array, m: Array, *args: Any) -> Array:
    ref, n_c, n_sp, length, coeffs = args
    w = helical_boundary(_module_q(y[0], ref, n_c), ref, n_sp)
    return law_jax.field_energy(w[0], w[1], length, tuple(coeffs)) - m @ w


def _module_values(y: Array, m: Array, *args: Any) -> tuple[Array, Array]:
    ref, n_c, n_sp, _, _ = args
    return helical_boundary(_module_q(y[0], ref, n_c), ref, n_sp), jnp.zeros(())


def reduced_terms(
    layout: TubeLayout, p: ModelParams, x: Array, lam_c: Array, second_order: bool = True
) -> ReducedTerms:
    """The local terms of the contact-only Lagrangian in reduced coordinates (module
    docstring): gradient, gaps and (if ``second_order``) Hessian and gap Jacobian with
    respect to x, each element differentiated alone and added into the global arrays.

    Parameters
    ----------
    x : array (N + Nc,)
        Reduced coordinates [mm].
    lam_c : array (n_c,)
        Contact multipliers λ_∂ [N].
    """
    n, size = layout.n_modules, n_reduced(layout)
    topo = topology(layout)
    ncr = topo.n_contacts
    el = _elements(layout, p, jnp.zeros(()))
    grad_m, gaps_m, _, hess_m, jac_m = _evaluate(_module_lagrangian, _module_values, second_order)(
        x[:n, None], lam_c[: 2 * n].reshape(n, 2), *el.module[:5]
    )
    index = np.arange(n, dtype=np.int32)[:, None]
    gradient = place_vector(index, grad_m, size)
    gaps = place_vector(topo.module_rows, gaps_m, ncr)
    hessian = place_matrix(index, hess_m, index, (size, size)) if second_order else None
    gap_jac = place_matrix(topo.module_rows, jac_m, index, (ncr, size)) if second_order else None
    if layout.n_connectors:
        minimum = layout.options.contact is ContactForm.MINIMUM
        pitch, width = p.geometry.pitch, p.smooth_min_width
        nc_lo, nc_up, data = el.connector

        def full7(y: Array, lo: Array, up: Array, d: ConnectorData) -> Array:
            return jnp.concatenate(
                [_module_q(y[0], d.ref_lower, lo), _module_q(y[1], d.ref_upper, up), y[2:]]
            )

        def lag(y: Array, m: Array, lo: Array, up: Array, d: ConnectorData) -> Array:
            return connector_lagrangian(full7(y, lo, up, d), m, d, pitch, minimum, width)

        def values(y: Array, m: Array, lo: Array, up: Array, d: ConnectorData) -> Any:
            _, rows = connector_gaps(full7(y, lo, up, d), d, pitch, minimum, width)
            return rows, jnp.zeros(())

        rows, row_mask = topo.gap_row, topo.gap_row_mask
        grad_c, gaps_c, _, hess_c, jac_c = _evaluate(lag, values, second_order)(
            x[el.dofs] * el.mask, lam_c[rows] * row_mask, nc_lo, nc_up, data
        )
        gradient = gradient + place_vector(el.dofs, grad_c, size, el.mask)
        gaps = gaps + place_vector(rows, gaps_c, ncr, row_mask)
        if second_order:
            dofs, mask = el.dofs, el.mask
            hessian = hessian + place_matrix(dofs, hess_c, dofs, (size, size), mask, mask)
            gap_jac = gap_jac + place_matrix(rows, jac_c, dofs, (ncr, size), row_mask, mask)
    return ReducedTerms(gradient, gaps, hessian, gap_jac)
