"""Implicit dynamics of a tube: ``integrate(model, method, start, load, t_end=...)``.

The constrained equations of motion (SI Eq. governing, in Lagrangian form, MODEL §13)::

    M(q) q̈ + c(q, q̇) + α_R M q̇ + ∇Π − ∇W_ext + Gᵀλ − Cᵀλ_∂ = 0,   g(q) = 0,   φ_SFB = 0

are integrated by the generalized-α method (:class:`GeneralizedAlpha`, MODEL CHOICE D3) with
the mass matrix of :mod:`biplan.model.system.inertia` (surface density μ =
``tube.surface_density``). Rayleigh damping D = α_R M is optional (CHOICE D2; the paper states
none). The load follows a piecewise-linear :class:`LoadHistory` of force, displacement or
pressure — by default the paper's ramp F(t) = 0.8 N/s · t for 0 ≤ t ≤ 2 s. The schemes and
the load history are declared in :mod:`biplan.solvers.schemes`.

Step size: fixed, ``time_step``; a step whose Newton iteration fails is retried with the step
halved (up to ``max_halvings`` times) from the last converged state, and the nominal step is
resumed after the retried stretch. Every retry is counted in ``Trajectory.stats``.

The whole step loop, retries included, runs in one compiled call on the model's
:class:`~biplan.model.system.System` (:mod:`biplan.solvers.step_loop`, the inertia of
:mod:`biplan.model.system.inertia`, under every chain reading).

Energy bookkeeping: kinetic T, strain Π, external work W = ∫ F dz_p (trapezoidal) and Rayleigh
dissipation D = Σ Δqᵀ α_R M q̇_{n+1} (the work of the damping force as the scheme applies
it); ``total_energy = T + Π − W + dissipated`` is conserved up to the
scheme's numerical dissipation (none for ρ∞ = 1, to O(h²)).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from biplan._compile.numba_cache import kernel_array
from biplan._errors import (
    ConfigError,
    ConvergenceError,
    check_range,
)
from biplan.model.assembly import Load, Model
from biplan.model.system import System, assemble, chainterm
from biplan.model.system import inertia as system_inertia
from biplan.solvers import observation, step_loop
from biplan.solvers.control import Control
from biplan.solvers.newton import Solution, relaxed_reference
from biplan.solvers.results import observables
from biplan.solvers.schemes import BackwardEuler, GeneralizedAlpha, LoadHistory
from biplan.solvers.trajectory_results import Trajectory, TrajectoryStats, TrajectoryStatus

__all__ = ["BackwardEuler", "GeneralizedAlpha", "LoadHistory", "integrate", "mass_matrix_at"]


def mass_matrix_at(model: Model, q: np.ndarray) -> np.ndarray:
    """M(q) (n_q, n_q) of ``model`` [t·mm² per unit² of q] (SI governing equations)."""
    q = np.asarray(q, dtype=float)
    if q.shape != (model.n_coordinates,):
        raise ConfigError("q", q.shape, f"shape ({model.n_coordinates},)")
    return system_inertia.mass_matrix(model.system().data, q, float(model.tube.surface_density))


def integrate(
    model: Model,
    method: GeneralizedAlpha | None = None,
    start: Solution | np.ndarray | None = None,
    load: LoadHistory | None = None,
    *,
    v0: np.ndarray | None = None,
    t_end: float = 2.0,
    throw: bool = False,
) -> Trajectory:
    """Integrate the equations of motion from t = 0 to ``t_end`` [s].

    Parameters
    ----------
    model : Model
    method : GeneralizedAlpha (or its BackwardEuler), optional
        Default ``GeneralizedAlpha()``.
    start : Solution or ndarray, optional
        Start state (a converged Solution, or coordinates satisfying the guides); default the
        relaxed reference.
    load : LoadHistory, optional
        Default the paper's force ramp (0.8 N/s for 2 s).
    v0 : ndarray, optional
        Initial velocity q̇ (n_q,); default at rest.
    t_end : float
        Final time [s] > 0.
    throw : bool
        Raise :class:`~biplan.ConvergenceError` instead of returning a trajectory whose status
        is not ``ok`` (default ``False``, as for every driver).

    Returns
    -------
    Trajectory
        Check ``trajectory.status``; on a failed step the trajectory ends at the last
        converged time.
    """
    scheme = method or GeneralizedAlpha()
    load = load or LoadHistory.ramp()
    check_range("t_end", t_end, low=0.0)
    nq = model.n_coordinates
    if start is None:
        z0 = relaxed_reference(model, throw=True).z
    elif isinstance(start, Solution):
        if not start.converged:
            raise ConfigError("start", start.status.name, "a converged Solution")
        z0 = np.asarray(start.z, dtype=float)
    else:
        q = np.asarray(start, dtype=float)
        if q.shape != (nq,) or not np.all(np.isfinite(q)):
            raise ConfigError("start", q.shape, f"finite coordinates of shape ({nq},)")
        g = float(np.max(np.abs(model.constraints(q)), initial=0.0))
        if g > 1e-8:
            raise ConfigError("start", f"max |g| = {g:.2e} mm", "coordinates satisfying the guides")
        z0 = model.pack(q)
    v = np.zeros(nq) if v0 is None else np.asarray(v0, dtype=float)
    if v.shape != (nq,) or not np.all(np.isfinite(v)):
        raise ConfigError("v0", v.shape, f"finite velocities of shape ({nq},)")

    control = Control(load.kind, float(load.values[-1]))
    ctl = control.coefficients(model)
    times, values = load.padded()
    settings = step_loop.StepSettings(
        *scheme.coefficients(),
        float(scheme.rayleigh),
        float(model.tube.surface_density),
        float(scheme.atol),
        int(scheme.max_iterations),
        float(scheme.energy_tolerance),
    )
    load0 = _load_at(ctl, load.value(0.0))
    ts, zs, vs, kins, its, diss, rejected, status = _run_system(
        model, z0, v, load0, ctl, times, values, settings, scheme, t_end
    )
    z_all = np.asarray(zs)
    if not np.all(np.isfinite(z_all)):
        status = TrajectoryStatus.NONFINITE
    t_all = np.asarray(ts)
    load_parameter = load.value(t_all)
    loads = _load_at(ctl, load_parameter)
    weak = model.options.weak_contacts_active
    obs = observation.observe(model.system(), z_all, loads, weak)
    kinetic = np.asarray(kins)
    force, zp = np.asarray(obs.force), np.asarray(obs.displacement)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (force[1:] + force[:-1]) * np.diff(zp))])
    dissipated = np.cumsum(np.asarray(diss))
    total = kinetic + np.asarray(obs.energy) - work + dissipated
    keep = np.arange(0, len(t_all), scheme.save_every)
    if keep[-1] != len(t_all) - 1:
        keep = np.append(keep, len(t_all) - 1)
    dt = np.diff(t_all)
    stats = TrajectoryStats(
        n_steps=len(t_all) - 1,
        n_rejected=rejected,
        newton_iterations=int(np.sum(its)),
        smallest_step=float(dt.min()) if dt.size else float("nan"),
        largest_step=float(dt.max()) if dt.size else float("nan"),
        max_constraint_residual=float(np.max(obs.constraint_residual)),
    )
    common = observables(model, obs, load_parameter)
    trajectory = Trajectory(
        model=model,
        control=control,
        method=scheme.describe(),
        time=t_all[keep],
        **{k: np.asarray(v)[keep] for k, v in common.items()},  # type: ignore[arg-type]
        kinetic_energy=kinetic[keep],
        external_work=work[keep],
        dissipated_energy=dissipated[keep],
        total_energy=total[keep],
        q=z_all[keep, :nq],
        velocity=np.asarray(vs)[keep],
        z=z_all[keep],
        status=status,
        stats=stats,
    )
    if throw and not status.ok:
        raise ConvergenceError(f"integration under {load}: {trajectory.message}")
    return trajectory


#: What the step loop returns: t, z, v, T, Newton steps and dissipated energy per step (lists
#: or arrays, the start first), the number of rejected chunks and the status.
_Run = tuple[Any, Any, Any, Any, Any, Any, int, TrajectoryStatus]


def _run_system(
    model: Model,
    z0: np.ndarray,
    v: np.ndarray,
    load0: Load,
    ctl: np.ndarray,
    times: np.ndarray,
    values: np.ndarray,
    settings: step_loop.StepSettings,
    scheme: GeneralizedAlpha,
    t_end: float,
) -> _Run:
    """The step loop of the compiled system: the whole trajectory, retries included, in one
    call of :func:`step_loop.trajectory`."""
    system = model.system()
    d = system.data
    mu = float(model.tube.surface_density)
    z0, v = kernel_array(z0, float), kernel_array(v, float)
    qdd0, force0 = _initial_acceleration(system, z0, v, load0, mu)
    scalars0 = step_loop.initial_scalars(d, z0, v, force0, mu)
    ts, zs, vs, kins, its, diss, count, rejected, code = step_loop.trajectory(
        d,
        z0,
        v,
        kernel_array(qdd0, float),
        scalars0,
        kernel_array(ctl, float),
        kernel_array(times, float),
        kernel_array(values, float),
        settings,
        float(t_end),
        float(scheme.time_step),
        int(scheme.max_halvings),
    )
    status = (
        TrajectoryStatus.COMPLETED if code == step_loop.COMPLETED else TrajectoryStatus.STEP_FAILED
    )
    return (
        ts[:count],
        zs[:count],
        vs[:count],
        kins[:count],
        its[:count],
        diss[:count],
        int(rejected),
        status,
    )


def _initial_acceleration(
    system: System, z0: np.ndarray, v0: np.ndarray, load: Load, surface_density: float
) -> tuple[np.ndarray, float]:
    """(q̈0, F0): the consistent initial acceleration, [[M, Aᵀ], [A, 0]] [q̈; ν] = [−f(q0); 0]
    with A the guides and the closed contacts (v0 assumed tangent to them), and the end
    force."""
    n_q, n_g, n_c = system.sizes
    d = system.data
    q0 = np.asarray(z0[:n_q], dtype=float)
    z = np.concatenate([q0, np.zeros(n_g + n_c + 1)])
    at = np.array([float(load.force), float(load.displacement), float(load.displacement_control)])
    r, jac, _, _, terms = assemble.evaluate_into(d, z, at, True, np.zeros((z.size, z.size)))
    m = system_inertia.mass_matrix(d, q0, surface_density)
    c0 = n_q + n_g  # ∂g/∂q and ∂w_∂/∂q from the Jacobian's blocks (as System.state)
    gaps, g_mat, c_mat = terms[3], jac[n_q:c0, :n_q], -jac[:n_q, c0 : c0 + n_c].T
    a = np.concatenate([g_mat, c_mat[gaps < 1e-8]])
    if load.is_displacement_controlled:
        grad = np.zeros(n_q)
        chainterm.load_point(d, q0, grad, np.zeros((0, 0)), 0.0, False)
        a = np.concatenate([a, grad[None, :]])
    k = a.shape[0]
    mat = np.block([[m, a.T], [a, np.zeros((k, k))]])
    sol = np.linalg.lstsq(mat, np.concatenate([-r[:n_q], np.zeros(k)]), rcond=None)[0]
    force = -z0[-1] if load.is_displacement_controlled else float(load.force)
    return sol[:n_q], float(force)


def _load_at(ctl: np.ndarray, load_parameter: np.ndarray | float) -> Load:
    load_parameter = np.asarray(load_parameter, dtype=float)
    return Load(
        ctl[0] * load_parameter,
        ctl[1] * load_parameter,
        np.full_like(load_parameter, ctl[2]) if load_parameter.ndim else ctl[2],
    )
