"""Compiled generalized-α time steps for the constrained, contact-regularised equations of
motion (MODEL §13, CHOICE D3; Chung & Hulbert 1993 in the Arnold & Brüls 2007 form).

Per step the unknowns are z_{n+1} = [q, λ, λ_∂, μ] at t_{n+1}; with the Newmark relations::

    a_{n+1}  = (q − q_n − h v_n − h²(½ − β) a_n) / (β h²)
    v_{n+1}  = v_n + h (1 − γ) a_n + h γ a_{n+1}
    q̈_{n+1} = ((1 − α_m) a_{n+1} + α_m a_n − α_f q̈_n) / (1 − α_f)

the residual is the static KKT residual of :func:`biplan.model.lagrangian.residual` at t_{n+1} plus
the inertia and Rayleigh forces M(q)(q̈ + α_R q̇) + c(q, q̇) in the q rows; the guides and the
SFB contact conditions hold at t_{n+1} (index 3). Its Jacobian is the static KKT Jacobian plus
the autodiff derivative of the inertia rows with respect to q. :func:`chunk` advances a fixed
number of steps with ``lax.scan``; a failed step freezes the rest of the chunk (its steps are
skipped, not solved), and the driver retries from the last converged state with a smaller step.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

from biplan._compile.kernel import kernel
from biplan._compile.setup import jax, jnp
from biplan.geometry.layout import TubeLayout
from biplan.model.inertia import inertia_force, quadrature_points, quadrature_weights
from biplan.model.lagrangian import kkt_jacobian, residual, sizes
from biplan.model.params import Load, ModelParams
from biplan.model.potential import energy, load_height
from biplan.solvers.core_settings import Status
from biplan.solvers.strategies import damped

Array = Any

#: Time steps per compiled chunk.
CHUNK_STEPS = 32
#: Breakpoints of a load history (padded).
HISTORY_POINTS = 16


class DynState(NamedTuple):
    z: Array
    v: Array
    a: Array  # generalized-α pseudo-acceleration
    qdd: Array  # acceleration q̈
    force: Array  # end force F [N] (applied, or the reaction −μ)
    height: Array  # load-point displacement z_p [mm]


class StepOut(NamedTuple):
    state: DynState
    converged: Array
    iterations: Array
    kinetic: Array  # T at t_{n+1} [N·mm]
    dissipated: Array  # work of the Rayleigh force over the step [N·mm]


def coefficients(rho_inf: Array) -> tuple[Array, Array, Array, Array]:
    """(α_m, α_f, γ, β) of the generalized-α method for spectral radius ρ∞."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gamma = 0.5 + af - am
    beta = 0.25 * (gamma + 0.5) ** 2
    return am, af, gamma, beta


@kernel("kinetic_energy")
def kinetic_energy(layout: TubeLayout, p: ModelParams, q: Array, v: Array, mu_s: Array) -> Array:
    """T = ½ Σ_k w_k |J_k q̇|² [N·mm]."""
    _, jv = jax.jvp(lambda qq: quadrature_points(layout, p, qq), (q,), (v,))
    w = quadrature_weights(layout, p, mu_s)
    return 0.5 * jnp.sum(w[:, None] * jv**2)


def step(
    layout: TubeLayout,
    p: ModelParams,
    s: DynState,
    t_next: Array,
    h: Array,
    ctl: Array,
    times: Array,
    values: Array,
    settings: Array,
) -> StepOut:
    """One generalized-α step from ``s`` to ``t_next`` (= t_n + h).

    ``settings = [α_m, α_f, γ, β, α_R, μ_surface, atol, max_iterations, energy_tol]``. A
    converged step is still rejected when it *creates* energy: T + Π − W + D (D the work of
    the Rayleigh force) may not grow by more
    than ``energy_tol`` [N·mm] (a large step can otherwise let Newton tunnel to another
    equilibrium of the multistable landscape).
    """
    am, af, gamma, beta, alpha_r, mu_s, atol, max_it, e_tol = (settings[i] for i in range(9))
    nq, _, _ = sizes(layout)
    load_parameter = jnp.interp(t_next, times, values)
    load = Load(ctl[0] * load_parameter, ctl[1] * load_parameter, ctl[2])
    q_n, v_n, a_n, qdd_n = s.z[:nq], s.v, s.a, s.qdd

    def kin(q: Array) -> tuple[Array, Array, Array]:
        a_new = (q - q_n - h * v_n - h**2 * (0.5 - beta) * a_n) / (beta * h**2)
        v_new = v_n + h * (1.0 - gamma) * a_n + h * gamma * a_new
        qdd = ((1.0 - am) * a_new + am * a_n - af * qdd_n) / (1.0 - af)
        return a_new, v_new, qdd

    def inertia(q: Array) -> Array:
        _, v_new, qdd = kin(q)
        return inertia_force(layout, p, q, v_new, qdd + alpha_r * v_new, mu_s)

    def res(z: Array) -> Array:
        r = residual(layout, p, z, load)
        return r.at[:nq].add(inertia(z[:nq]))

    def jac(z: Array) -> Array:
        j = kkt_jacobian(layout, p, z, load)
        return j.at[:nq, :nq].add(jax.jacfwd(inertia)(z[:nq]))

    # predictor: constant acceleration extrapolation of q (multipliers as before)
    z0 = s.z.at[:nq].set(q_n + h * v_n + 0.5 * h**2 * qdd_n)
    out = damped(res, jac, z0, atol, max_it)
    q = out.z[:nq]
    a_new, v_new, qdd = kin(q)
    kinetic = kinetic_energy(layout, p, q, v_new, mu_s)
    force = jnp.where(ctl[2] > 0.5, -out.z[-1], load.force)
    height = load_height(layout, p, q)
    work = 0.5 * (force + s.force) * (height - s.height)
    kin_n = kinetic_energy(layout, p, q_n, v_n, mu_s)
    # work of the damping force α_R M q̇_{n+1} (evaluated at t_{n+1}, as the scheme applies
    # it) over the step Δq: α_R Σ_k w_k (J_k Δq)·(J_k q̇)
    pts = functools.partial(quadrature_points, layout, p)
    _, j_dq = jax.jvp(pts, (q,), (q - q_n,))
    _, j_v = jax.jvp(pts, (q,), (v_new,))
    dissipated = alpha_r * jnp.sum(quadrature_weights(layout, p, mu_s)[:, None] * j_dq * j_v)
    # energy created by the step: Δ(T + Π) − ΔW + ΔD
    created = kinetic + energy(layout, p, q) - kin_n - energy(layout, p, q_n) - work + dissipated
    # energy moved through the step: the check is relative to it (discretisation error of a
    # violent snap) with ``energy_tol`` as the absolute floor (quasi-static tunnelling)
    moved = jnp.abs(work) + jnp.abs(dissipated) + jnp.abs(kinetic - kin_n)
    new = DynState(out.z, v_new, a_new, qdd, force, height)
    ok = (out.status == Status.CONVERGED.value) & (created <= e_tol + 0.1 * moved)
    return StepOut(new, ok, out.steps, kinetic, dissipated)


@kernel("dynamics_chunk")
def chunk(
    layout: TubeLayout,
    p: ModelParams,
    s0: DynState,
    t0: Array,
    t_next: Array,
    ctl: Array,
    times: Array,
    values: Array,
    settings: Array,
) -> tuple[DynState, Array, Array, Array, Array]:
    """Advance through the times ``t_next`` (CHUNK_STEPS,) from (s0, t0).

    Returns the stacked states, converged flags, iteration counts, kinetic energies and
    dissipated energy per step; after
    the first failure the state is frozen (flags False).
    """

    def frozen(s: DynState, t: Array, t_prev: Array) -> StepOut:
        zero = jnp.zeros((), s.z.dtype)
        return StepOut(s, jnp.asarray(False), jnp.asarray(0), zero, zero)

    def advance(s: DynState, t: Array, t_prev: Array) -> StepOut:
        return step(layout, p, s, t, t - t_prev, ctl, times, values, settings)

    def body(carry: tuple, t: Array) -> tuple:
        s, t_prev, alive = carry
        # after a failure the rest of the chunk is discarded by the driver: skip its Newton
        # solves (each would run to ``max_iterations`` from the frozen state)
        out = jax.lax.cond(alive, advance, frozen, s, t, t_prev)
        ok = alive & out.converged & jnp.all(jnp.isfinite(out.state.z))
        s_new = jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), out.state, s)
        outs: tuple = (s_new, ok, out.iterations, out.kinetic, out.dissipated)
        return (s_new, jnp.where(ok, t, t_prev), ok), outs

    scanned: tuple = jax.lax.scan(body, (s0, t0, jnp.asarray(True)), t_next)[1]
    return scanned  # type: ignore[return-value]
