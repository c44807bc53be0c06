"""The compiled time-step loop: generalized-α steps of a whole trajectory in one Numba call
(MODEL §13, CHOICE D3; the loop of :func:`biplan.solvers.dynamics.integrate`, under every
chain reading).

Per step the unknowns are z_{n+1} = [q, λ, λ_∂, μ] at t_{n+1}; with the Newmark relations::

    a_{n+1}  = (q − q_n − h v_n − h²(½ − β) a_n) / (β h²)
    v_{n+1}  = v_n + h (1 − γ) a_n + h γ a_{n+1}
    q̈_{n+1} = ((1 − α_m) a_{n+1} + α_m a_n − α_f q̈_n) / (1 − α_f)

the residual is the static KKT residual (:func:`biplan.model.system.assemble.evaluate`) at
t_{n+1} plus the inertia and Rayleigh forces M(q)(q̈ + α_R q̇) + c(q, q̇) in the q rows
(:func:`biplan.model.system.inertia.add_inertia`), and its Jacobian the static KKT Jacobian
plus the exact derivative of the inertia rows (as the JAX model's autodiff, the tests'
oracle: ∂M/∂q and the derivative of the velocity-quadratic force included; dropping them, a
modified Newton, fails in violent snaps). The iteration is
:func:`biplan.solvers.iteration.newton` on that system, as the plain damped Newton of the time
step (Armijo c = 1e-4, 12 halvings, no Levenberg–Marquardt fallback).

:func:`trajectory` runs the driver's chunks of :data:`CHUNK_STEPS` steps: a failed step (no
convergence, a non-finite state, or energy created by the step, see :func:`step`) freezes the
rest of its chunk, the driver retries from the last converged state with the step halved and
resumes the nominal step after a chunk that went through. :func:`step` and the energies of
a state are inlined into their callers (``inline="always"``): compiled on its own, the step
would optimise the Newton and the assembly below it once more (docs/performance.md, "One-time
compile").
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.assemble import observe
from biplan.model.system.inertia import kinetic_and_work, kinetic_energy, step_data
from biplan.model.system.tables import SystemData
from biplan.solvers.iteration import NewtonSettings, newton
from biplan.solvers.status import Status

__all__ = ["CHUNK_STEPS", "COMPLETED", "STEP_FAILED", "StepSettings", "step", "trajectory"]

#: Time steps per chunk.
CHUNK_STEPS = 32
#: Step halvings of the Newton line search (smallest step fraction 2⁻¹²).
DAMPED_BACKTRACKS = 12
#: Codes of the loop status (``TrajectoryStatus``).
COMPLETED, STEP_FAILED = 0, 1

_CONVERGED = Status.CONVERGED.value


class StepSettings(NamedTuple):
    """The settings of a time step (:func:`step`), by name.

    Attributes
    ----------
    alpha_m, alpha_f, gamma, beta : float
        Generalized-α coefficients (:func:`coefficients`).
    rayleigh : float
        Mass-proportional damping α_R [1/s].
    surface_density : float
        Mass per area μ of the sheet [t/mm²].
    atol : float
        Newton tolerance ‖r‖∞ of a step.
    max_iterations : int
        Newton steps of a step.
    energy_tolerance : float
        Energy a converged step may create beyond 10 % of the energy it moves [N·mm].
    """

    alpha_m: float
    alpha_f: float
    gamma: float
    beta: float
    rayleigh: float
    surface_density: float
    atol: float
    max_iterations: int
    energy_tolerance: float


@kernel
def coefficients(rho_inf: float) -> tuple[float, float, float, float]:
    """(α_m, α_f, γ, β) of the generalized-α method for spectral radius ρ∞."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gamma = 0.5 + af - am
    return am, af, gamma, 0.25 * (gamma + 0.5) ** 2


@kernel(inline="always")
def _energies(d: SystemData, z: np.ndarray) -> tuple[float, float]:
    """(z_p [mm], Π [N·mm]) at z."""
    zp, _, e_hel, e_circ, _ = observe(d, z)
    return zp, e_hel.sum() + e_circ.sum()


@kernel(inline="always")
def step(
    d: SystemData,
    z_n: np.ndarray,
    v_n: np.ndarray,
    a_n: np.ndarray,
    qdd_n: np.ndarray,
    scalars_n: np.ndarray,
    t_next: float,
    h: float,
    ctl: np.ndarray,
    times: np.ndarray,
    values: np.ndarray,
    settings: StepSettings,
) -> tuple:  # type: ignore[type-arg]
    """One generalized-α step from the state (z_n, v_n, a_n, q̈_n, scalars_n) to ``t_next``
    (= t_n + h); scalars = (F [N], z_p [mm], T [N·mm], Π [N·mm]) of the state.

    ``settings``: :class:`StepSettings`.
    A converged step is still rejected when it
    creates energy: T + Π − W + D may not grow by more than ``energy_tol`` plus 10 % of the
    energy the step moves (|ΔW| + |ΔD| + |ΔT|).

    Returns (z, v, a, q̈, scalars, ok, Newton steps, T, dissipated energy of the step).
    """
    am, af, gamma, beta = settings.alpha_m, settings.alpha_f, settings.gamma, settings.beta
    alpha_r, mu = settings.rayleigh, settings.surface_density
    n_q = d.sizes[0]
    lp = np.interp(t_next, times, values)
    load = np.array([ctl[0] * lp, ctl[1] * lp, ctl[2]])
    q_n = z_n[:n_q]
    # the Newmark relations are affine in q: v = ṽ + c_v (q − q̃), q̈ + α_R v = Ã + c_M (q − q̃)
    q_base = q_n + h * v_n + h**2 * (0.5 - beta) * a_n
    v_base = v_n + h * (1.0 - gamma) * a_n
    c_v = gamma / (beta * h)
    c_a = (1.0 - am) / ((1.0 - af) * beta * h**2)
    a_base = (am * a_n - af * qdd_n) / (1.0 - af) + alpha_r * v_base
    data = step_data(q_base, v_base, a_base, c_v, c_a + alpha_r * c_v, mu)
    # predictor: constant acceleration extrapolation of q (multipliers as before)
    z0 = z_n.copy()
    z0[:n_q] = q_n + h * v_n + 0.5 * h**2 * qdd_n
    newton_settings = NewtonSettings(
        settings.atol, settings.max_iterations, int(DAMPED_BACKTRACKS), 1e-4, 0, False
    )
    z, _, _, _, steps, status = newton(d, load, z0, newton_settings, np.zeros(0), 0.0, data)
    q = z[:n_q]
    a_new = (q - q_n - h * v_n - h**2 * (0.5 - beta) * a_n) / (beta * h**2)
    v_new = v_n + h * (1.0 - gamma) * a_n + h * gamma * a_new
    qdd = ((1.0 - am) * a_new + am * a_n - af * qdd_n) / (1.0 - af)
    kinetic, dq_m_v = kinetic_and_work(d, q, v_new, q - q_n, mu)
    force = -z[-1] if ctl[2] > 0.5 else load[0]
    height, energy = _energies(d, z)
    work = 0.5 * (force + scalars_n[0]) * (height - scalars_n[1])
    # work of the damping force α_R M q̇_{n+1} over the step: α_R Δqᵀ M q̇_{n+1}
    dissipated = alpha_r * dq_m_v
    created = kinetic + energy - scalars_n[2] - scalars_n[3] - work + dissipated
    moved = abs(work) + abs(dissipated) + abs(kinetic - scalars_n[2])
    ok = status == _CONVERGED and created <= settings.energy_tolerance + 0.1 * moved
    scalars = np.array([force, height, kinetic, energy])
    return z, v_new, a_new, qdd, scalars, ok, steps, kinetic, dissipated


@kernel
def initial_scalars(
    d: SystemData, z0: np.ndarray, v0: np.ndarray, force: float, surface_density: float
) -> np.ndarray:
    """(F, z_p, T, Π) of the start state (the ``scalars`` of :func:`step`)."""
    n_q = d.sizes[0]
    kinetic = kinetic_energy(d, z0[:n_q], v0, surface_density)
    height, energy = _energies(d, z0)
    return np.array([force, height, kinetic, energy])


@kernel
def _grow(a: np.ndarray, size: int) -> np.ndarray:  # type: ignore[type-arg]
    out = np.zeros((size,) + a.shape[1:], dtype=a.dtype)  # noqa: RUF005 (Numba)
    out[: a.shape[0]] = a
    return out


@kernel
def trajectory(
    d: SystemData,
    z0: np.ndarray,
    v0: np.ndarray,
    qdd0: np.ndarray,
    scalars0: np.ndarray,
    ctl: np.ndarray,
    times: np.ndarray,
    values: np.ndarray,
    settings: StepSettings,
    t_end: float,
    time_step: float,
    max_halvings: int,
) -> tuple:  # type: ignore[type-arg]
    """Integrate from the state (z0, v0, q̈0 = a0, scalars0) at t = 0 to ``t_end`` (the loop
    of :func:`biplan.solvers.dynamics.integrate`).

    Chunks of :data:`CHUNK_STEPS` steps of h = ``time_step``·2^−halvings on the grid
    t + h·(1, 2, …) clipped at ``t_end``; a failed step ends its chunk, counts a rejection
    and halves h for the next chunk (``STEP_FAILED`` once ``max_halvings`` halvings failed),
    a chunk that went through doubles it back up to the nominal step.

    Returns (t (B,), z (B, n_z), v (B, n_q), T (B,), Newton steps (B,), dissipated energy per
    step (B,), count, rejected, status), the first ``count`` rows filled (row 0: the start).
    """
    n_q = d.sizes[0]
    size = int(t_end / time_step) + CHUNK_STEPS + 2
    buf_t = np.zeros(size)
    buf_z = np.zeros((size, z0.shape[0]))
    buf_v = np.zeros((size, n_q))
    buf_k = np.zeros(size)
    buf_i = np.zeros(size, dtype=np.int64)
    buf_d = np.zeros(size)
    buf_z[0], buf_v[0], buf_k[0] = z0, v0, scalars0[2]
    count = 1
    z, v, a, qdd, sc = z0.copy(), v0.copy(), qdd0.copy(), qdd0.copy(), scalars0.copy()
    t, halvings, rejected, status = 0.0, 0, 0, COMPLETED
    stop = t_end * (1 - 1e-12)
    while t < stop:
        if count + CHUNK_STEPS > buf_t.shape[0]:
            size = 2 * buf_t.shape[0]
            buf_t, buf_z, buf_v = _grow(buf_t, size), _grow(buf_z, size), _grow(buf_v, size)
            buf_k, buf_i, buf_d = _grow(buf_k, size), _grow(buf_i, size), _grow(buf_d, size)
        h = time_step * 0.5**halvings
        t_prev, failed = t, False
        for j in range(CHUNK_STEPS):
            t_next = min(t + h * (j + 1), t_end)
            out = step(d, z, v, a, qdd, sc, t_next, t_next - t_prev, ctl, times, values, settings)
            if not (out[5] and np.all(np.isfinite(out[0]))):
                failed = True
                break
            z, v, a, qdd, sc = out[0], out[1], out[2], out[3], out[4]
            buf_t[count], buf_z[count], buf_v[count] = t_next, z, v
            buf_k[count], buf_i[count], buf_d[count] = out[7], out[6], out[8]
            count += 1
            t_prev = t_next
            if t_next >= t_end:  # the rest of the chunk would repeat t_end
                break
        t = t_prev
        if failed and t < stop:
            rejected += 1
            if halvings >= max_halvings:
                status = STEP_FAILED
                break
            halvings += 1
        elif halvings:
            halvings -= 1
    return buf_t, buf_z, buf_v, buf_k, buf_i, buf_d, count, rejected, status
