"""The reference time loop, the oracle of the compiled dynamics (:mod:`biplan.solvers.step_loop`).

Generalized-α steps of the constrained, contact-regularised equations of motion on the JAX
autodiff model (MODEL §13, CHOICE D3; Chung & Hulbert 1993 in the Arnold & Brüls 2007 form).
Per step the unknowns are z_{n+1} = [q, λ, λ_∂, μ] at t_{n+1}; with the Newmark relations::

    a_{n+1}  = (q − q_n − h v_n − h²(½ − β) a_n) / (β h²)
    v_{n+1}  = v_n + h (1 − γ) a_n + h γ a_{n+1}
    q̈_{n+1} = ((1 − α_m) a_{n+1} + α_m a_n − α_f q̈_n) / (1 − α_f)

the residual is the static KKT residual at t_{n+1} plus the inertia and Rayleigh forces
M(q)(q̈ + α_R q̇) + c(q, q̇) of :mod:`biplan.model.inertia` in the q rows, its Jacobian the
static KKT Jacobian plus the autodiff derivative of the inertia rows.

The model's terms are JAX's (:func:`step_system`, :func:`step_energies`: one compiled function
each per layout); the loop around them is plain Python and NumPy, written from the method, not
from the compiled loop: :func:`damped` (Armijo backtracking on ½‖R‖², the Jacobian of the
accepted points, no Levenberg–Marquardt) and :func:`run` (chunks of
:data:`~biplan.solvers.step_loop.CHUNK_STEPS` steps; a failed step ends its chunk, halves the
step for the next one, and a chunk that went through doubles it back). Tracing a whole JAX
time loop cost 30–50 s a layout; the two functions here a few seconds.

:func:`run` has the signature of ``biplan.solvers.dynamics._run_system``: patched in its place
(:func:`integrate`), :func:`biplan.integrate` integrates with the reference loop and observes
the trajectory as usual.
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

__all__ = ["DAMPED_BACKTRACKS", "damped", "integrate", "run", "step_energies", "step_system"]

Array = Any

#: Step halvings of the Newton line search (smallest step fraction 2⁻¹²).
DAMPED_BACKTRACKS = 12


class DynState(NamedTuple):
    z: np.ndarray
    v: np.ndarray
    a: np.ndarray  # generalized-α pseudo-acceleration
    qdd: np.ndarray  # acceleration q̈
    force: float  # end force F [N] (applied, or the reaction −μ)
    height: float  # load-point displacement z_p [mm]


def _kinetic(layout: TubeLayout, p: ModelParams, q: Array, v: Array, mu_s: Array) -> Array:
    """T = ½ Σ_k w_k |J_k q̇|² [N·mm]."""
    _, jv = jax.jvp(lambda qq: quadrature_points(layout, p, qq), (q,), (v,))
    w = quadrature_weights(layout, p, mu_s)
    return 0.5 * jnp.sum(w[:, None] * jv**2)


def _newmark(q: Array, q_n: Array, v_n: Array, a_n: Array, qdd_n: Array, h: Array, c: Array):  # type: ignore[no-untyped-def]
    """(a, v, q̈) at t_{n+1} from q (the Newmark relations; c = α_m, α_f, γ, β, α_R, μ)."""
    am, af, gamma, beta = c[0], c[1], c[2], c[3]
    a_new = (q - q_n - h * v_n - h**2 * (0.5 - beta) * a_n) / (beta * h**2)
    v_new = v_n + h * (1.0 - gamma) * a_n + h * gamma * a_new
    qdd = ((1.0 - am) * a_new + am * a_n - af * qdd_n) / (1.0 - af)
    return a_new, v_new, qdd


@functools.partial(jax.jit, static_argnums=0, compiler_options=xla_options())
def step_system(
    layout: TubeLayout,
    p: ModelParams,
    z: Array,
    load: Load,
    q_n: Array,
    v_n: Array,
    a_n: Array,
    qdd_n: Array,
    h: Array,
    c: Array,
) -> tuple[Array, Array]:
    """(R, ∂R/∂z) of a step's system at z: the static KKT terms at the step's load plus the
    inertia rows M(q)(q̈ + α_R q̇) + c(q, q̇) (c = α_m, α_f, γ, β, α_R, μ)."""
    nq, _, _ = sizes(layout)

    def inertia(q: Array) -> Array:
        _, v_new, qdd = _newmark(q, q_n, v_n, a_n, qdd_n, h, c)
        return inertia_force(layout, p, q, v_new, qdd + c[4] * v_new, c[5])

    r = residual(layout, p, z, load).at[:nq].add(inertia(z[:nq]))
    j = kkt_jacobian(layout, p, z, load).at[:nq, :nq].add(jax.jacfwd(inertia)(z[:nq]))
    return r, j


@functools.partial(jax.jit, static_argnums=0, compiler_options=xla_options())
def step_energies(
    layout: TubeLayout, p: ModelParams, q: Array, q_n: Array, v_n: Array, v_new: Array, mu_s: Array
) -> tuple[Array, ...]:
    """(T, T_n, Π, Π_n, z_p, Δqᵀ M q̇) of a step from (q_n, v_n) to (q, v_new) [N·mm, mm]."""
    pts = functools.partial(quadrature_points, layout, p)
    _, j_dq = jax.jvp(pts, (q,), (q - q_n,))
    _, j_v = jax.jvp(pts, (q,), (v_new,))
    moved = jnp.sum(quadrature_weights(layout, p, mu_s)[:, None] * j_dq * j_v)
    return (
        _kinetic(layout, p, q, v_new, mu_s),
        _kinetic(layout, p, q_n, v_n, mu_s),
        energy(layout, p, q),
        energy(layout, p, q_n),
        load_height(layout, p, q),
        moved,
    )


def _solve(jac: np.ndarray, b: np.ndarray) -> np.ndarray:
    """J⁻¹ b by LU, NaN where J is singular."""
    try:
        return np.linalg.solve(jac, b)
    except np.linalg.LinAlgError:
        return np.full(b.shape, np.nan)


def damped(
    system: Any, z0: np.ndarray, atol: float, max_steps: int, max_backtracks: int = 12
) -> tuple[np.ndarray, int, int]:
    """Damped Newton on R(z) = 0, ``system(z) = (R, J)``: Armijo backtracking on ½‖R‖²
    (c = 1e-4, at most ``max_backtracks`` halvings; the start is accepted when finite), a
    Newton direction from the Jacobian of each accepted point, no Levenberg–Marquardt — a
    search that runs out of halvings, or a singular Newton system, fails the solve.

    Returns (z, status, accepted steps) with z the last accepted point.
    """
    alpha_min = 0.5**max_backtracks
    max_evals = max(max_steps, 1) * (max_backtracks + 1)
    z, f = np.asarray(z0, float), np.inf
    dz, alpha, slope = np.zeros_like(z), 0.0, 0.0
    steps, evals, status = 0, 0, -1
    while status < 0 and evals < max_evals:
        trial = z + alpha * dz
        r, jac = (np.asarray(x) for x in system(trial))
        evals += 1
        ft = 0.5 * r @ r
        ft = ft if np.isfinite(ft) else np.inf
        if not (np.isfinite(ft) and (not np.isfinite(f) or ft <= f + 1e-4 * alpha * slope)):
            if 0.5 * alpha < alpha_min:
                status = Status.LINE_SEARCH_FAILED.value
            alpha *= 0.5
            continue
        steps += 1 if np.isfinite(f) else 0
        z, f = trial, ft
        dz = _solve(jac, -r)
        slope, alpha = r @ (jac @ dz), 1.0
        if np.max(np.abs(r)) < atol:
            status = Status.CONVERGED.value
        elif not np.all(np.isfinite(dz)):
            status = Status.LINE_SEARCH_FAILED.value
        elif steps >= max_steps:
            status = Status.MAX_STEPS.value
    if status < 0:
        status = Status.MAX_STEPS.value
    if not np.isfinite(f):
        status = Status.NONFINITE.value
    return z, status, steps


def step(
    model: biplan.Model,
    s: DynState,
    t_next: float,
    h: float,
    ctl: np.ndarray,
    times: np.ndarray,
    values: np.ndarray,
    settings: Any,
) -> tuple[DynState, bool, int, float, float]:
    """One generalized-α step from ``s`` to ``t_next`` (= t_n + h); ``settings`` as
    :class:`biplan.solvers.step_loop.StepSettings`. A converged step is still rejected when
    it creates energy (T + Π − W + D grows by more than the tolerance plus 10 % of the energy
    the step moves). Returns (state, ok, Newton steps, T, dissipated energy of the step)."""
    am, af, gamma, beta, alpha_r, mu_s, atol, max_it, e_tol = (float(x) for x in settings)
    layout, p, nq = model.layout, model.params, model.n_coordinates
    lp = float(np.interp(t_next, times, values))
    load = Load(ctl[0] * lp, ctl[1] * lp, ctl[2]).for_jax()
    c = np.array([am, af, gamma, beta, alpha_r, mu_s])
    q_n, v_n, a_n, qdd_n = s.z[:nq], s.v, s.a, s.qdd
    fixed = tuple(jnp.asarray(x) for x in (q_n, v_n, a_n, qdd_n, h, c))
    z0 = s.z.copy()
    z0[:nq] = q_n + h * v_n + 0.5 * h**2 * qdd_n
    z, status, n_it = damped(
        lambda zz: step_system(layout, p, jnp.asarray(zz), load, *fixed), z0, atol, int(max_it)
    )
    q = z[:nq]
    a_new, v_new, qdd = _newmark(q, q_n, v_n, a_n, qdd_n, h, c)
    kinetic, kin_n, e_new, e_old, height, moved_m = (
        float(x)
        for x in step_energies(layout, p, *(jnp.asarray(x) for x in (q, q_n, v_n, v_new, mu_s)))
    )
    force = -z[-1] if ctl[2] > 0.5 else float(ctl[0] * lp)
    work = 0.5 * (force + s.force) * (height - s.height)
    dissipated = alpha_r * moved_m
    created = kinetic + e_new - kin_n - e_old - work + dissipated
    moved = abs(work) + abs(dissipated) + abs(kinetic - kin_n)
    ok = status == Status.CONVERGED.value and created <= e_tol + 0.1 * moved
    return DynState(z, v_new, a_new, qdd, force, height), ok, n_it, kinetic, dissipated


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
    return DynState(
        np.asarray(z0, float),
        np.asarray(v0, float),
        qdd,
        qdd,
        force,
        float(model.load_displacement(q0)),
    )


def run(
    model: biplan.Model,
    z0: np.ndarray,
    v: np.ndarray,
    load0: Load,
    ctl: np.ndarray,
    times: np.ndarray,
    values: np.ndarray,
    settings: Any,
    scheme: biplan.GeneralizedAlpha,
    t_end: float,
) -> tuple:
    """The reference step loop (the run tuple of ``dynamics._run_system``): chunks of
    CHUNK_STEPS steps of h = time_step·2^−halvings on the grid t + h·(1, 2, …) clipped at
    ``t_end``; a failed step ends its chunk, counts a rejection and halves h for the next
    chunk (a failed run after ``max_halvings`` halvings), a chunk that went through doubles it
    back up to the nominal step."""
    nq = model.n_coordinates
    state = _initial_state(model, z0, v, load0)
    ctl, times, values = (np.asarray(x, float) for x in (ctl, times, values))
    mu = jnp.asarray(float(model.tube.surface_density))
    q0 = jnp.asarray(state.z[:nq])
    kin0 = float(step_energies(model.layout, model.params, q0, q0, state.v, state.v, mu)[0])
    ts, zs, vs, kins, its, diss = [0.0], [state.z], [state.v], [kin0], [0], [0.0]
    t, halvings, rejected, status = 0.0, 0, 0, TrajectoryStatus.COMPLETED
    stop = t_end * (1 - 1e-12)
    while t < stop:
        h = scheme.time_step * 0.5**halvings
        t_prev, failed = t, False
        for j in range(CHUNK_STEPS):
            t_next = min(t + h * (j + 1), t_end)
            new, ok, n_it, kinetic, dissipated = step(
                model, state, t_next, t_next - t_prev, ctl, times, values, settings
            )
            if not (ok and np.all(np.isfinite(new.z))):
                failed = True
                break
            state = new
            ts.append(t_next)
            zs.append(new.z)
            vs.append(new.v)
            kins.append(kinetic)
            its.append(n_it)
            diss.append(dissipated)
            t_prev = t_next
            if t_next >= t_end:  # the rest of the chunk would repeat t_end
                break
        t = t_prev
        if failed and t < stop:
            rejected += 1
            if halvings >= scheme.max_halvings:
                status = TrajectoryStatus.STEP_FAILED
                break
            halvings += 1
        elif halvings:
            halvings -= 1
    return ts, zs, vs, kins, its, diss, rejected, status


def integrate(monkeypatch: Any, *args: Any, **kwargs: Any) -> biplan.Trajectory:
    """:func:`biplan.integrate` with the reference step loop in place of the compiled one."""
    with monkeypatch.context() as patch:
        patch.setattr(dynamics, "_run_system", run)
        return biplan.integrate(*args, **kwargs)
