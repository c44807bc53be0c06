"""The JAX time loop, the oracle of the compiled dynamics (:mod:`biplan.solvers.step_loop`).

Generalized-α steps of the constrained, contact-regularised equations of motion on the JAX
autodiff model (MODEL §13, CHOICE D3; Chung & Hulbert 1993 in the Arnold & Brüls 2007 form),
once ``biplan.solvers._dynkernel`` and the JAX driver of :func:`biplan.integrate`. Per step
the unknowns are z_{n+1} = [q, λ, λ_∂, μ] at t_{n+1}; with the Newmark relations::

    a_{n+1}  = (q − q_n − h v_n − h²(½ − β) a_n) / (β h²)
    v_{n+1}  = v_n + h (1 − γ) a_n + h γ a_{n+1}
    q̈_{n+1} = ((1 − α_m) a_{n+1} + α_m a_n − α_f q̈_n) / (1 − α_f)

the residual is the static KKT residual at t_{n+1} plus the inertia and Rayleigh forces
M(q)(q̈ + α_R q̇) + c(q, q̇) of :mod:`biplan.model.inertia` in the q rows, its Jacobian the
static KKT Jacobian plus the autodiff derivative of the inertia rows. :func:`chunk` advances
:data:`CHUNK_STEPS` steps with ``lax.scan`` (a failed step freezes the rest of the chunk) and
:func:`run` retries from the last converged state with smaller steps, as the compiled loop.

:func:`run` has the signature of ``biplan.solvers.dynamics._run_system``: patched in its place
(:func:`integrate`), :func:`biplan.integrate` integrates with the JAX loop and observes the
trajectory as usual.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np

import biplan
from biplan._compile.setup import jax, jnp, xla_options
from biplan.geometry.layout import TubeLayout
from biplan.model.inertia import inertia_force, quadrature_points, quadrature_weights
from biplan.model.lagrangian import kkt_jacobian, residual, sizes
from biplan.model.params import Load, ModelParams
from biplan.model.potential import energy, load_height
from biplan.solvers import dynamics
from biplan.solvers.status import Status
from biplan.solvers.step_loop import CHUNK_STEPS
from biplan.solvers.trajectory_results import TrajectoryStatus
from jax_oracle.strategies import damped

__all__ = ["chunk", "integrate", "kinetic_energy", "run", "step"]

Array = Any


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


def _kinetic(layout: TubeLayout, p: ModelParams, q: Array, v: Array, mu_s: Array) -> Array:
    """T = ½ Σ_k w_k |J_k q̇|² [N·mm]."""
    _, jv = jax.jvp(lambda qq: quadrature_points(layout, p, qq), (q,), (v,))
    w = quadrature_weights(layout, p, mu_s)
    return 0.5 * jnp.sum(w[:, None] * jv**2)


kinetic_energy = functools.partial(jax.jit, static_argnums=0, compiler_options=xla_options())(
    _kinetic
)


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
    """One generalized-α step from ``s`` to ``t_next`` (= t_n + h); ``settings`` as
    :func:`biplan.solvers.step_loop.step`."""
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

    z0 = s.z.at[:nq].set(q_n + h * v_n + 0.5 * h**2 * qdd_n)
    out = damped(res, jac, z0, atol, max_it)
    q = out.z[:nq]
    a_new, v_new, qdd = kin(q)
    kinetic = _kinetic(layout, p, q, v_new, mu_s)
    force = jnp.where(ctl[2] > 0.5, -out.z[-1], load.force)
    height = load_height(layout, p, q)
    work = 0.5 * (force + s.force) * (height - s.height)
    kin_n = _kinetic(layout, p, q_n, v_n, mu_s)
    pts = functools.partial(quadrature_points, layout, p)
    _, j_dq = jax.jvp(pts, (q,), (q - q_n,))
    _, j_v = jax.jvp(pts, (q,), (v_new,))
    dissipated = alpha_r * jnp.sum(quadrature_weights(layout, p, mu_s)[:, None] * j_dq * j_v)
    created = kinetic + energy(layout, p, q) - kin_n - energy(layout, p, q_n) - work + dissipated
    moved = jnp.abs(work) + jnp.abs(dissipated) + jnp.abs(kinetic - kin_n)
    new = DynState(out.z, v_new, a_new, qdd, force, height)
    ok = (out.status == Status.CONVERGED.value) & (created <= e_tol + 0.1 * moved)
    return StepOut(new, ok, out.steps, kinetic, dissipated)


@functools.partial(jax.jit, static_argnums=0, compiler_options=xla_options())
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
    """Advance through the times ``t_next`` (CHUNK_STEPS,) from (s0, t0): the stacked states,
    converged flags, iteration counts, kinetic energies and dissipated energy per step; after
    the first failure the state is frozen (flags False)."""

    def frozen(s: DynState, t: Array, t_prev: Array) -> StepOut:
        zero = jnp.zeros((), s.z.dtype)
        return StepOut(s, jnp.asarray(False), jnp.asarray(0), zero, zero)

    def advance(s: DynState, t: Array, t_prev: Array) -> StepOut:
        return step(layout, p, s, t, t - t_prev, ctl, times, values, settings)

    def body(carry: tuple, t: Array) -> tuple:
        s, t_prev, alive = carry
        out = jax.lax.cond(alive, advance, frozen, s, t, t_prev)
        ok = alive & out.converged & jnp.all(jnp.isfinite(out.state.z))
        s_new = jax.tree_util.tree_map(lambda a, b: jnp.where(ok, a, b), out.state, s)
        outs: tuple = (s_new, ok, out.iterations, out.kinetic, out.dissipated)
        return (s_new, jnp.where(ok, t, t_prev), ok), outs

    scanned: tuple = jax.lax.scan(body, (s0, t0, jnp.asarray(True)), t_next)[1]
    return scanned  # type: ignore[return-value]


def _initial_state(model: biplan.Model, z0: np.ndarray, v0: np.ndarray, load: Load) -> DynState:
    """Consistent initial acceleration: [[M, Aᵀ], [A, 0]] [q̈; ν] = [−f(q0); 0] with A the
    guides and the closed contacts, on the JAX model."""
    from biplan.model.inertia import mass_matrix

    nq = model.n_coordinates
    q0 = z0[:nq]
    r = model.residual(model.pack(q0), load)[:nq]
    m = np.asarray(
        jax.jit(mass_matrix, static_argnums=0)(
            model.layout, model.params, jnp.asarray(q0), model.tube.surface_density
        )
    )
    gaps = model.contact_gaps(q0)
    a = np.concatenate([model.constraint_jacobian(q0), model.contact_jacobian(q0)[gaps < 1e-8]])
    if load.is_displacement_controlled:
        a = np.concatenate([a, model.load_gradient(q0)[None, :]])
    k = a.shape[0]
    mat = np.block([[m, a.T], [a, np.zeros((k, k))]])
    sol = np.linalg.lstsq(mat, np.concatenate([-r, np.zeros(k)]), rcond=None)[0]
    qdd = sol[:nq]
    force = -z0[-1] if load.is_displacement_controlled else float(load.force)
    # strongly typed float64 leaves, as the chunk returns them (a weak Python-float leaf would
    # make the second chunk call retrace)
    f64 = functools.partial(jnp.asarray, dtype=jnp.float64)
    return DynState(
        f64(z0), f64(v0), f64(qdd), f64(qdd), f64(force), f64(model.load_displacement(q0))
    )


def run(
    model: biplan.Model,
    z0: np.ndarray,
    v: np.ndarray,
    load0: Load,
    ctl: np.ndarray,
    times: np.ndarray,
    values: np.ndarray,
    settings: np.ndarray,
    scheme: biplan.GeneralizedAlpha,
    t_end: float,
) -> tuple:
    """The JAX step loop: compiled chunks, retried with smaller steps from Python (the run
    tuple of ``dynamics._run_system``)."""
    nq = model.n_coordinates
    state = _initial_state(model, z0, v, load0)
    args = (jnp.asarray(ctl), jnp.asarray(times), jnp.asarray(values), jnp.asarray(settings))
    mu = model.tube.surface_density
    kin0 = float(kinetic_energy(model.layout, model.params, jnp.asarray(z0[:nq]), v, mu))
    ts, zs, vs, kins, its, diss = [0.0], [np.asarray(z0)], [v], [kin0], [0], [0.0]
    t, h0 = 0.0, scheme.time_step
    halvings, rejected, status = 0, 0, TrajectoryStatus.COMPLETED
    while t < t_end * (1 - 1e-12):
        h = h0 * 0.5**halvings
        grid = np.minimum(t + h * np.arange(1, CHUNK_STEPS + 1), t_end)
        states, ok, n_it, kin, dis = chunk(
            model.layout,
            model.params,
            state,
            jnp.asarray(t, dtype=jnp.float64),
            jnp.asarray(grid),
            *args,
        )
        ok = np.asarray(ok)
        n_ok = int(np.argmin(ok)) if not ok.all() else ok.size
        # steps that land exactly on t_end repeat it: keep the first only
        n_keep = min(n_ok, int(np.searchsorted(grid, t_end, side="left")) + 1)
        if n_keep:
            zs.extend(np.asarray(states.z)[:n_keep])
            vs.extend(np.asarray(states.v)[:n_keep])
            kins.extend(np.asarray(kin)[:n_keep])
            its.extend(np.asarray(n_it)[:n_keep])
            diss.extend(np.asarray(dis)[:n_keep])
            ts.extend(grid[:n_keep])
            state = jax.tree_util.tree_map(lambda a, k=n_keep: a[k - 1], states)
            t = float(grid[n_keep - 1])
        if n_ok < ok.size and t < t_end * (1 - 1e-12):
            rejected += 1
            if halvings >= scheme.max_halvings:
                status = TrajectoryStatus.STEP_FAILED
                break
            halvings += 1
        elif halvings:
            halvings -= 1
    return ts, zs, vs, kins, its, diss, rejected, status


def integrate(monkeypatch: Any, *args: Any, **kwargs: Any) -> biplan.Trajectory:
    """:func:`biplan.integrate` with the JAX step loop in place of the compiled one."""
    with monkeypatch.context() as patch:
        patch.setattr(dynamics, "_run_system", run)
        return biplan.integrate(*args, **kwargs)
