"""The module and connector elements of the BiPlan Lagrangian and their assembly over the
chain (main Eq. mft_energy_assembly; MODEL §4–7, §11; :mod:`biplan.model.elements`)."""

from __future__ import annotations

from typing import Any, NamedTuple

from biplan._compile.setup import jax, jnp
from biplan.geometry import chain
from biplan.geometry.development import spans
from biplan.geometry.layout import TubeLayout
from biplan.geometry.module import guides, helical_boundary
from biplan.laws import _jax as law_jax
from biplan.model.elements.topology import place_matrix, place_vector, topology
from biplan.options import ContactForm

__all__ = [
    "ConnectorData",
    "LocalTerms",
    "connector_gaps",
    "connector_lagrangian",
    "connector_points",
    "local_terms",
    "module_constraints",
    "module_lagrangian",
]

Array = Any


def module_constraints(x: Array, ref: Array, n_c: Array, n_sp: Array) -> Array:
    """(g_C, g_F, w0, wa) [mm] of one module from its coordinates x = (u, φ1, φ2)."""
    return jnp.concatenate([guides(x, ref, n_c), helical_boundary(x, ref, n_sp)])


def module_lagrangian(
    x: Array,
    multipliers: Array,
    ref: Array,
    n_c: Array,
    n_sp: Array,
    length: Array,
    coeffs: Array,
) -> Array:
    """Module element's share of L [N·mm]: Ψ-energy of its helical field + λ_g·g − λ_∂·w.

    ``multipliers`` = (λ_gC, λ_gF, λ_∂0, λ_∂a); ``coeffs`` the helical law row (5,).
    """
    w = helical_boundary(x, ref, n_sp)
    energy = law_jax.field_energy(w[0], w[1], length, tuple(coeffs))
    return energy + multipliers[:2] @ guides(x, ref, n_c) - multipliers[2:] @ w


def connector_points(
    x: Array,
    ref_lower: Array,
    ref_upper: Array,
    s: Array,
    upper_element: Array,
    lower_element: Array,
    rigid: Array,
    height: Array,
    pitch: Array,
    flip: Array | None = None,
) -> Array:
    """Elongation w [mm] of a connector at its field-end points (point 0 is the seam).

    w(s) = z_U(s) + Δ − z_L(s), Δ = γ + z_L(0) − z_U(0) (SI Eqs. VC_w, MODEL §7); at the
    points marked by ``flip`` (the first field's split end of a TPC under
    ``TpcSign.AS_PRINTED``, a static table) 2γ − w instead.
    """
    lo, up, gam = x[:3], x[3:6], x[6]
    line = jax.vmap(chain.line_height, in_axes=(None, None, 0, 0, 0))
    z_up = line(up, ref_upper, upper_element, jnp.zeros_like(s), s)
    z_lo = jnp.where(rigid, height * pitch, line(lo, ref_lower, lower_element, pitch + 0.0 * s, s))
    w = z_up + (gam + z_lo[0] - z_up[0]) - z_lo
    if flip is not None:
        w = jnp.where(flip, 2.0 * gam - w, w)
    return w


class ConnectorData(NamedTuple):
    """Traced per-connector data of :func:`connector_lagrangian` (one row of each table)."""

    ref_lower: Array
    ref_upper: Array
    s: Array  # (P,) s of each point [mm]
    upper_element: Array
    lower_element: Array
    rigid: Array
    height: Array
    field_start: Array
    field_end: Array
    field_mask: Array
    gap_point: Array
    gap_point_mask: Array
    coeffs: Array  # (5,) circular law row
    flip: Array | None = None  # (P,) bool, only under TpcSign.AS_PRINTED


def connector_gaps(
    x: Array, d: ConnectorData, pitch: Array, minimum: bool, width: Array
) -> tuple[Array, Array]:
    """(field energies (F,) [N·mm], contact gaps [mm]) of one connector element."""
    w = connector_points(
        x,
        d.ref_lower,
        d.ref_upper,
        d.s,
        d.upper_element,
        d.lower_element,
        d.rigid,
        d.height,
        pitch,
        d.flip,
    )
    length = d.s[d.field_end] - d.s[d.field_start]
    energies = d.field_mask * law_jax.field_energy(
        w[d.field_start], w[d.field_end], length, tuple(d.coeffs)
    )
    pts = w[d.gap_point]
    if minimum:  # MODEL C1 MINIMUM: −τ logsumexp(−w/τ) over the connector's points
        gaps = -width * jax.nn.logsumexp(jnp.where(d.gap_point_mask > 0, -pts / width, -jnp.inf))
        return energies, gaps[None]
    return energies, pts * d.gap_point_mask


def connector_lagrangian(
    x: Array, multipliers: Array, d: ConnectorData, pitch: Array, minimum: bool, width: Array
) -> Array:
    """Connector element's share of L [N·mm]: its field energies − λ_∂·w_∂."""
    energies, gaps = connector_gaps(x, d, pitch, minimum, width)
    return energies.sum() - multipliers @ gaps


class LocalTerms(NamedTuple):
    """The local part of the KKT system at (q, λ, λ_∂), assembled over the chain."""

    gradient: Array  # (n_q,) ∇_q of Π + λ·g − λ_∂·w_∂
    hessian: Array  # (n_q, n_q) its Hessian (None unless second order)
    guides: Array  # (2N,)
    gaps: Array  # (n_c,)
    guide_jacobian: Array  # (2N, n_q) (None unless second order)
    gap_jacobian: Array  # (n_c, n_q) (None unless second order)
    helical_energy: Array  # (N,)
    circular_energy: Array  # (Nc,)


def _module_arrays(layout: TubeLayout, p: Any) -> tuple[Array, Array, Array, Array]:
    geom = p.geometry
    ref, n_c, n_sp = chain.reference_frames(layout, geom)
    _, _, _, a = spans(geom.radius, geom.pitch, geom.beta)
    return ref, n_c, n_sp, a


def _connector_data(layout: TubeLayout, p: Any, ref: Array) -> ConnectorData:
    topo = topology(layout)
    geom = p.geometry
    h, h1, h2, _ = spans(geom.radius, geom.pitch, geom.beta)
    s_values = jnp.stack([0.0 * h, h1, h2, h])
    return ConnectorData(
        ref[topo.lower],
        ref[topo.upper],
        s_values[topo.point_s],
        topo.point_upper_element,
        topo.point_lower_element,
        topo.point_rigid,
        topo.point_height,
        topo.field_start,
        topo.field_end,
        topo.field_mask,
        topo.gap_point,
        topo.gap_point_mask,
        p.circular,
        jnp.asarray(topo.point_flip) if topo.point_flip.any() else None,
    )


def _evaluate(lagrangian: Any, values: Any, second_order: bool) -> Any:
    """Per element, (∇ℓ, constraint rows c, extras, ∇²ℓ, ∂c/∂x) of an element's Lagrangian
    ℓ(x, …) and ``values(x, …) = (c, extras)``, in one forward-over-forward pass (second
    derivatives are None unless ``second_order``)."""

    def first(x: Array, *args: Any) -> tuple[tuple[Array, Array], tuple[Array, Array, Array]]:
        grad = jax.jacfwd(lagrangian)(x, *args)
        rows, extras = values(x, *args)
        return (grad, rows), (grad, rows, extras)

    def evaluate(x: Array, *args: Any) -> tuple[Array, ...]:
        if not second_order:
            grad, rows, extras = first(x, *args)[1]
            return grad, rows, extras, None, None
        (hess, jac), (grad, rows, extras) = jax.jacfwd(first, has_aux=True)(x, *args)
        return grad, rows, extras, hess, jac

    return jax.vmap(evaluate)


def local_terms(
    layout: TubeLayout,
    p: Any,
    q: Array,
    lam: Array,
    lam_c: Array,
    second_order: bool = True,
) -> LocalTerms:
    """Evaluate every element and assemble (see module docstring).

    Parameters
    ----------
    layout, p
        The tube layout and the model's traced parameters
        (:class:`biplan.model.params.ModelParams`).
    q, lam, lam_c
        Coordinates (n_q,), guide multipliers (2N,) [N], contact multipliers (n_c,) [N/mm].
    second_order
        Also assemble the Hessian and the constraint Jacobians.
    """
    topo = topology(layout)
    n, nc = layout.n_modules, layout.n_connectors
    ref, n_c, n_sp, a = _module_arrays(layout, p)
    mult = jnp.concatenate([lam.reshape(n, 2), lam_c[: 2 * n].reshape(n, 2)], axis=1)

    def mod_lag(x: Array, m: Array, r: Array, nc_: Array, nsp: Array, k: Array) -> Array:
        return module_lagrangian(x, m, r, nc_, nsp, a, k)

    def mod_values(x: Array, m: Array, r: Array, nc_: Array, nsp: Array, k: Array) -> Any:
        rows = module_constraints(x, r, nc_, nsp)
        return rows, law_jax.field_energy(rows[2], rows[3], a, tuple(k))

    grad_m, cons_m, helical_energy, hess_m, jac_m = _evaluate(mod_lag, mod_values, second_order)(
        q[topo.module_dofs], mult, ref, n_c, n_sp, p.helical
    )
    nq, ncr, mod, rows = layout.n_coordinates, topo.n_contacts, topo.module_dofs, topo.module_rows
    gradient = place_vector(mod, grad_m, nq)
    gaps = place_vector(rows, cons_m[:, 2:], ncr)
    hessian: Array = None
    guide_jac: Array = None
    gap_jac: Array = None
    if second_order:
        hessian = place_matrix(mod, hess_m, mod, (nq, nq))
        guide_jac = place_matrix(rows, jac_m[:, :2], mod, (2 * n, nq))
        gap_jac = place_matrix(rows, jac_m[:, 2:], mod, (ncr, nq))
    circular_energy = jnp.zeros((0,))

    if nc:
        minimum = layout.options.contact is ContactForm.MINIMUM
        width, pitch = p.smooth_min_width, p.geometry.pitch

        def con_lag(x: Array, m: Array, d: ConnectorData) -> Array:
            return connector_lagrangian(x, m, d, pitch, minimum, width)

        def con_values(x: Array, m: Array, d: ConnectorData) -> Any:
            energies, rows = connector_gaps(x, d, pitch, minimum, width)
            return rows, energies.sum()

        dofs, gap_row = topo.connector_dofs, topo.gap_row
        grad_c, gaps_c, circular_energy, hess_c, jac_c = _evaluate(
            con_lag, con_values, second_order
        )(q[dofs], lam_c[gap_row] * topo.gap_row_mask, _connector_data(layout, p, ref))
        dof_mask, row_mask = topo.connector_dof_mask, topo.gap_row_mask
        gradient = gradient + place_vector(dofs, grad_c, nq, dof_mask)
        gaps = gaps + place_vector(gap_row, gaps_c, ncr, row_mask)
        if second_order:
            hessian = hessian + place_matrix(dofs, hess_c, dofs, (nq, nq), dof_mask, dof_mask)
            gap_jac = gap_jac + place_matrix(gap_row, jac_c, dofs, (ncr, nq), row_mask, dof_mask)
    return LocalTerms(
        gradient,
        hessian,
        cons_m[:, :2].reshape(-1),
        gaps,
        guide_jac,
        gap_jac,
        helical_energy,
        circular_energy,
    )
