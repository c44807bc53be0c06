"""The constrained BiPlan Lagrangian of a tube, its KKT residual and Jacobian (main Eqs. aug,
mft_energy_assembly; MODEL §11).

One JAX Lagrangian, written once::

    L(q, λ, λ_∂, μ) = Π(q) − F z_p(q) + λᵀ g(q) − λ_∂ᵀ w_∂(q) + μ d (z_p(q) − U)
                      [+ ½κ‖q − q_a‖², an optional proximal bias, κ = 0 by default]

Π sums the exact field energies of every helical field and every connector field; g are the
guides (2 per module); w_∂ the contact gaps (helical ends, connector field ends; MODEL C1);
z_p the axial displacement of the load point (MODEL W1); d ∈ {0, 1} switches displacement
control on (:mod:`biplan.model.potential` has each term as a function of q). The equilibrium
residual (MODEL §11) is::

    r = [∇_q L,  g(q),  φ_SFB(w_∂(q), λ_∂),  d (z_p − U) + (1 − d) μ]

with φ_SFB(w, λ) = √(w² + λ² + ε²) − (w + λ) (SI Eq. sfb). The residual, the KKT Jacobian and
the Hessians are assembled from per-element autodiff (:mod:`biplan.model.elements`; the whole-tube
autodiff of L is the test oracle, :mod:`biplan.model.oracle`). Every function here is pure in
(layout, params, z, load); :func:`biplan.model.assembly.autodiff_functions` compiles them once
per layout.
"""

from __future__ import annotations

from typing import Any

from biplan._compile import linalg
from biplan._compile.setup import jax, jnp
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.model import elements
from biplan.model.elements.reduced import full_coordinates, n_reduced, reduced_terms
from biplan.model.params import AT_REST, Load, ModelParams, StateData
from biplan.model.params import sizes as params_sizes

__all__ = [
    "StateData",
    "curvature",
    "full_state",
    "kkt_jacobian",
    "kkt_jacobian_at_rest",
    "kkt_matrix",
    "lagrangian_hessian",
    "reduced_kkt_jacobian_at_rest",
    "reduced_residual_at_rest",
    "residual",
    "residual_at_rest",
    "sfb",
    "sizes",
    "state_data",
    "state_data_at_rest",
    "state_from_jacobian",
    "unloaded_terms",
]

Array = Any


def sfb(w: Array, lam: Array, eps: Array) -> Array:
    """Smoothed Fischer–Burmeister function (SI Eq. sfb)."""
    return jnp.sqrt(w**2 + lam**2 + eps**2) - (w + lam)


def _terms(
    layout: TubeLayout,
    p: ModelParams,
    z: Array,
    load: Load,
    second_order: bool,
    loaded: bool = True,
) -> tuple[elements.LocalTerms, elements.ChainTerms, Array, Array]:
    """Local and chain terms at z, the ∇z_p coefficient μd − F, and the bias-free q
    (``loaded=False``: the load is :data:`~biplan.model.params.AT_REST`, whose chain terms are
    zeros)."""
    q, lam, lam_c, mu = _split(layout, z)
    local = elements.local_terms(layout, p, q, lam, lam_c, second_order)
    if loaded:
        chain_part = elements.chain_terms(layout, p.geometry, q, second_order)
    else:
        nq = q.shape[0]
        zero_h = jnp.zeros((nq, nq)) if second_order else None
        chain_part = elements.ChainTerms(jnp.zeros(()), jnp.zeros(nq), zero_h)
    return local, chain_part, mu * load.displacement_control - load.force, q


def _gradient_of_terms(
    p: ModelParams,
    local: elements.LocalTerms,
    chain_part: elements.ChainTerms,
    coef: Array,
    q: Array,
) -> Array:
    return local.gradient + coef * chain_part.gradient + p.bias_stiffness * (q - p.bias_anchor)


def _hessian_of_terms(
    p: ModelParams, local: elements.LocalTerms, chain_part: elements.ChainTerms, coef: Array
) -> Array:
    nq = local.gradient.shape[0]
    return local.hessian + coef * chain_part.hessian + p.bias_stiffness * jnp.eye(nq)


def residual(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Array:
    """KKT residual r(z) (MODEL §11) for z = [q, λ, λ_∂, μ], assembled over the elements."""
    return _residual(layout, p, z, load, loaded=True)


def residual_at_rest(layout: TubeLayout, p: ModelParams, z: Array) -> Array:
    """:func:`residual` at :data:`~biplan.model.params.AT_REST`. There the load point's terms
    vanish ((μd − F) ∇z_p = 0 and the last row is μ), so they are not evaluated."""
    return _residual(layout, p, z, AT_REST.for_jax(), loaded=False)


def kkt_jacobian_at_rest(layout: TubeLayout, p: ModelParams, z: Array) -> Array:
    """:func:`kkt_jacobian` at :data:`~biplan.model.params.AT_REST`, without the load point's
    terms (as :func:`residual_at_rest`)."""
    return _kkt_jacobian(layout, p, z, AT_REST.for_jax(), loaded=False)


def _residual(layout: TubeLayout, p: ModelParams, z: Array, load: Load, loaded: bool) -> Array:
    local, chain_part, coef, q = _terms(layout, p, z, load, False, loaded)
    _, _, lam_c, mu = _split(layout, z)
    d = load.displacement_control
    return jnp.concatenate(
        [
            _gradient_of_terms(p, local, chain_part, coef, q),
            local.guides,
            sfb(local.gaps + p.compliance * lam_c, lam_c, p.smoothing),
            (d * (chain_part.value - load.displacement) + (1.0 - d) * mu)[None],
        ]
    )


def kkt_jacobian(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Array:
    """∂r/∂z assembled from its blocks (MODEL §11)::

        [[K,        Gᵀ, −Cᵀ,          d a],
         [G,        0,   0,            0 ],
         [D_w C,    0,   D_λ,          0 ],
         [d aᵀ,     0,   0,        1 − d ]]

    K = ∇²_q L, the sum of the elements' local Hessians (:func:`biplan.model.elements.local_terms`)
    and (μd − F) ∇²z_p of the chain; G, C the elements' constraint Jacobians, a = ∇z_p;
    D_w = diag(ŵ/ρ − 1), D_λ = diag(c (ŵ/ρ − 1) + λ/ρ − 1), ρ = √(ŵ² + λ² + ε²), ŵ = w + c λ
    (c: ``ModelOptions.contact_compliance``).
    """
    return _kkt_jacobian(layout, p, z, load, loaded=True)


def _kkt_jacobian(layout: TubeLayout, p: ModelParams, z: Array, load: Load, loaded: bool) -> Array:
    local, chain_part, coef, _ = _terms(layout, p, z, load, True, loaded)
    _, _, lam_c, _ = _split(layout, z)
    k = _hessian_of_terms(p, local, chain_part, coef)
    return kkt_matrix(
        p, load, k, local.guide_jacobian, local.gap_jacobian, chain_part.gradient, local.gaps, lam_c
    )


def kkt_matrix(
    p: ModelParams,
    load: Load,
    k: Array,
    g_mat: Array,
    c_mat: Array,
    a: Array,
    gaps: Array,
    lam_c: Array,
) -> Array:
    """The KKT Jacobian of :func:`kkt_jacobian` from its blocks: K (n_q, n_q), G (n_g, n_q),
    C (n_c, n_q), a = ∇z_p (n_q,), the gaps w_∂ (n_c,) and the contact multipliers λ_∂."""
    ng, nc = g_mat.shape[0], c_mat.shape[0]
    w = gaps + p.compliance * lam_c
    rho = jnp.sqrt(w**2 + lam_c**2 + p.smoothing**2)
    d = load.displacement_control
    zeros = jnp.zeros
    top = jnp.concatenate([k, g_mat.T, -c_mat.T, (d * a)[:, None]], axis=1)
    mid = jnp.concatenate([g_mat, zeros((ng, ng + nc + 1))], axis=1)
    sfb_rows = jnp.concatenate(
        [
            (w / rho - 1.0)[:, None] * c_mat,
            zeros((nc, ng)),
            jnp.diag(p.compliance * (w / rho - 1.0) + lam_c / rho - 1.0),
            zeros((nc, 1)),
        ],
        axis=1,
    )
    last = jnp.concatenate([d * a, zeros(ng + nc), (1.0 - d)[None]])[None, :]
    return jnp.concatenate([top, mid, sfb_rows, last], axis=0)


def lagrangian_hessian(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Array:
    """∇²_q L at z (n_q, n_q): energy, load and multiplier curvature (MODEL CHOICE S2)."""
    local, chain_part, coef, _ = _terms(layout, p, z, load, second_order=True)
    return _hessian_of_terms(p, local, chain_part, coef)


def unloaded_terms(layout: TubeLayout, p: ModelParams, q: Array) -> elements.LocalTerms:
    """Local terms at q with zero multipliers: the energy Hessian ∇²Π and the constraint
    Jacobians ∂g/∂q, ∂w_∂/∂q."""
    _, ng, nc = _sizes(layout)
    return elements.local_terms(layout, p, q, jnp.zeros(ng), jnp.zeros(nc))


def _state(
    layout: TubeLayout,
    p: ModelParams,
    z: Array,
    load: Load,
    second_order: bool,
    blocks: Any,
    loaded: bool = True,
) -> StateData:
    """StateData at z; ``blocks(local, chain_part, coef)`` gives (K, G, C). ``loaded=False``:
    at rest, the load point's value and gradient without its Hessian."""
    local, chain_part, coef, q = _terms(layout, p, z, load, second_order, loaded)
    if not loaded:
        first = elements.chain_terms(layout, p.geometry, q, False)
        chain_part = chain_part._replace(value=first.value, gradient=first.gradient)
    k, g_mat, c_mat = blocks(local, chain_part, coef)
    return StateData(
        energy=local.helical_energy.sum() + local.circular_energy.sum(),
        helical_energy=local.helical_energy,
        circular_energy=local.circular_energy,
        load_displacement=chain_part.value,
        endpoint=chain.endpoint(layout, p.geometry, q),
        lagrangian_hessian=k,
        constraint_jacobian=jnp.concatenate([g_mat, c_mat, chain_part.gradient[None]]),
        gaps=local.gaps,
    )


def _second_order_blocks(
    p: ModelParams,
) -> Any:
    def blocks(local: Any, chain_part: Any, coef: Array) -> tuple[Array, Array, Array]:
        k = _hessian_of_terms(p, local, chain_part, coef)
        return k, local.guide_jacobian, local.gap_jacobian

    return blocks


def state_data(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> StateData:
    """Energy split, endpoint, Lagrangian Hessian and constraint Jacobians at z."""
    return _state(layout, p, z, load, True, _second_order_blocks(p))


def state_data_at_rest(layout: TubeLayout, p: ModelParams, z: Array) -> StateData:
    """:func:`state_data` at :data:`~biplan.model.params.AT_REST`: the Hessian of the load
    point's displacement z_p, whose coefficient μd − F vanishes there and which costs more
    than the rest of the state's data together, is not evaluated (z_p and ∇z_p are)."""
    return _state(layout, p, z, AT_REST.for_jax(), True, _second_order_blocks(p), False)


def state_from_jacobian(
    layout: TubeLayout, p: ModelParams, z: Array, load: Load, jac: Array
) -> StateData:
    """:func:`state_data` at z from the KKT Jacobian at z (:func:`kkt_jacobian`): K, G and C
    are its blocks, so only first-order terms are evaluated (what a solver returns with its
    solution, whose last Newton pass has the Jacobian at hand)."""
    nq, ng, nc = _sizes(layout)

    def blocks(*_: Any) -> tuple[Array, Array, Array]:
        return jac[:nq, :nq], jac[nq : nq + ng, :nq], -jac[:nq, nq + ng : nq + ng + nc].T

    return _state(layout, p, z, load, False, blocks)


def curvature(
    layout: TubeLayout, p: ModelParams, z: Array, load: Load, x: Array, eta: Array
) -> Array:
    """xᵀ K x − 2 ηᵀ A x at z, K = ∇²_q L and A = ∂[g; w_∂; z_p]/∂q (the rows of
    :attr:`StateData.constraint_jacobian`), for x (n_q,) and η (n_g + n_c + 1,).

    Computed as one directional derivative of the first-order terms along x (K x and A x by
    ``jax.jvp`` of ∇_q L and of the rows), so no matrix is formed: its derivatives with respect
    to z and the design (the sensitivity of λ_min) stay the size of a gradient.
    """
    nq = layout.n_coordinates

    def first(q: Array) -> tuple[Array, Array]:
        local, chain_part, coef, _ = _terms(
            layout, p, jnp.concatenate([q, z[nq:]]), load, second_order=False
        )
        gradient = _gradient_of_terms(p, local, chain_part, coef, q)
        return gradient, jnp.concatenate([local.guides, local.gaps, chain_part.value[None]])

    _, (kx, ax) = jax.jvp(first, (z[:nq],), (x,))
    return x @ kx - 2.0 * eta @ ax


def sizes(layout: TubeLayout) -> tuple[int, int, int]:
    """(n_q, n_g, n_c): coordinates, guide and contact multipliers of a layout."""
    return _sizes(layout)


_sizes = params_sizes


def _split(layout: TubeLayout, z: Array) -> tuple[Array, Array, Array, Array]:
    nq, ng, nc = _sizes(layout)
    return z[:nq], z[nq : nq + ng], z[nq + ng : nq + ng + nc], z[nq + ng + nc]


def reduced_residual_at_rest(layout: TubeLayout, p: ModelParams, v: Array) -> Array:
    """The KKT residual at rest in reduced coordinates (:mod:`biplan.model.elements.reduced`):
    v = [x, λ_∂, μ] (N + Nc + n_c + 1), r = [∇_x Π − (∂w_∂/∂x)ᵀλ_∂, φ_SFB(w_∂ + cλ_∂, λ_∂), μ].
    The proximal bias is not part of it (the state search runs without one)."""
    nx = n_reduced(layout)
    lam_c = v[nx:-1]
    t = reduced_terms(layout, p, v[:nx], lam_c, second_order=False)
    contacts = sfb(t.gaps + p.compliance * lam_c, lam_c, p.smoothing)
    return jnp.concatenate([t.gradient, contacts, v[-1:]])


def reduced_kkt_jacobian_at_rest(layout: TubeLayout, p: ModelParams, v: Array) -> Array:
    """∂r/∂v of :func:`reduced_residual_at_rest`: :func:`kkt_matrix` without guide rows."""
    nx = n_reduced(layout)
    lam_c = v[nx:-1]
    t = reduced_terms(layout, p, v[:nx], lam_c)
    no_guides = jnp.zeros((0, nx))
    return kkt_matrix(
        p, AT_REST.for_jax(), t.hessian, no_guides, t.gap_jacobian, jnp.zeros(nx), t.gaps, lam_c
    )


def full_state(layout: TubeLayout, p: ModelParams, v: Array) -> Array:
    """The full state z = [q, λ, λ_∂, μ] of a reduced one v = [x, λ_∂, μ]: q = q(x), and the
    guide multipliers λ by least squares on the stationarity rows ∇Π + Gᵀλ − Cᵀλ_∂ = 0 (exact
    where v solves the reduced system, :mod:`biplan.model.elements.reduced`)."""
    nx = n_reduced(layout)
    _, ng, _ = _sizes(layout)
    q = full_coordinates(layout, p, v[:nx])
    local = elements.local_terms(layout, p, q, jnp.zeros(ng), v[nx:-1])
    g_mat = local.guide_jacobian
    lam = -linalg.solve(g_mat @ g_mat.T, g_mat @ local.gradient)
    return jnp.concatenate([q, lam, v[nx:]])
