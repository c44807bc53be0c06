"""Batched solves on the compiled :class:`~biplan.model.system.System` (Numba; MODEL §11).

The compiled counterparts of the JAX map kernels, for one tube (its
:class:`~biplan.model.system.SystemData`) at a time: the points of a map differ in geometry
and laws, so a map groups its tasks by point (:mod:`biplan.analysis.maps`).

* :func:`solve_tasks` — many (start, load) tasks of one tube, each solved by the one compiled
  globalised Newton (:func:`biplan.solvers.iteration.newton`), in parallel blocks of tasks
  (:mod:`biplan.solvers.lanes`): the stability map's seeds and continuation steps;
* :func:`chord` — chord (modified Newton) iterates with a fixed Jacobian
  (the tests compare it with their JAX oracle);
* :func:`ramp` — the design map's quasi-static force ramp of one design: per load step a
  chord start with the previous equilibrium's Jacobian, finished by the Newton and observed
  (:func:`biplan.solvers.observation.observe_state`) from the Jacobian the Newton ends with
  (the JAX kernel ``design_lanes`` of :mod:`biplan.analysis.maps.design_map`).

The kernels release the GIL (``nogil``), so the chunks of a map run in parallel on the
threads of :func:`biplan.analysis.scaleout.thread_runner`, and the blocks of tasks on the
lanes' threads. They take run-time arrays and flags
only (no default arguments), so each compiles once per install (``cache=True``).
"""

from __future__ import annotations

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system import assemble
from biplan.model.system.tables import SystemData
from biplan.solvers import lanes
from biplan.solvers.iteration import NewtonSettings, newton
from biplan.solvers.observation import observe_state
from biplan.solvers.status import Status

__all__ = ["chord", "ramp", "solve_tasks"]

_CONVERGED = Status.CONVERGED.value


@kernel(nogil=True)
def _solve_rows(
    d: SystemData,
    z0: np.ndarray,
    loads: np.ndarray,
    settings: NewtonSettings,
    z: np.ndarray,
    status: np.ndarray,
    steps: np.ndarray,
    lo: int,
    hi: int,
) -> None:
    """The tasks lo … hi − 1 of :func:`solve_tasks` into rows lo:hi of its outputs."""
    for t in range(lo, hi):
        out = newton(d, loads[t], z0[t], settings, np.zeros(0), 0.0, np.zeros(0))
        z[t] = out[0]
        steps[t] = out[4]
        status[t] = out[5]


def solve_tasks(
    d: SystemData, z0: np.ndarray, loads: np.ndarray, settings: NewtonSettings
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve r(z) = 0 of one tube from many starts and loads by
    :func:`biplan.solvers.iteration.newton`, in parallel blocks of tasks
    (:mod:`biplan.solvers.lanes`).

    Parameters
    ----------
    d : SystemData
        The tube as arrays.
    z0 : ndarray (T, n_z)
        Start of each task, packed [q, λ, λ_∂, μ].
    loads : ndarray (T, 3)
        (F [N], U [mm], d) of each task: end force, prescribed load-point displacement and
        1.0 under displacement control.
    settings : NewtonSettings
        The Newton's settings (:func:`biplan.solvers.iteration.newton_settings`).

    Returns
    -------
    tuple of ndarray
        Final iterates z (T, n_z), statuses (T,) (:class:`~biplan.solvers.Status` values)
        and accepted Newton steps (T,): each task's result equals one
        :func:`~biplan.solvers.iteration.newton` call.
    """
    z0 = np.ascontiguousarray(z0, dtype=float)
    loads = np.ascontiguousarray(loads, dtype=float)
    k, n = z0.shape
    z = np.empty((k, n))
    status = np.empty(k, dtype=np.int64)
    steps = np.empty(k, dtype=np.int64)
    lanes.run_rows(_solve_rows, k, d, z0, loads, settings, z, status, steps)
    return z, status, steps


@kernel
def _residual_norm(r: np.ndarray) -> float:
    """‖r‖∞, +∞ when r is not finite."""
    if np.all(np.isfinite(r)):
        return float(np.max(np.abs(r)))
    return np.inf


@kernel
def chord(
    d: SystemData,
    z: np.ndarray,
    jac: np.ndarray,
    load: np.ndarray,
    atol: float,
    iterations: int,
) -> np.ndarray:
    """Chord (modified Newton) iterates z ← z − J⁻¹ r(z) with the fixed Jacobian ``jac``
    until ‖r‖∞ < atol or ``iterations`` steps; the iterate of smallest ‖r‖∞ (z itself when
    every step made it worse or non-finite), as the JAX chord of the tests'
    oracle. Each step solves with LAPACK's LU of ``jac``
    (refactored per step, a few µs at these sizes; the same iterates to round-off).

    Parameters
    ----------
    d : SystemData
        The tube as arrays.
    z : ndarray (n_z,)
        Start, packed [q, λ, λ_∂, μ].
    jac : ndarray (n_z, n_z)
        The fixed Jacobian (e.g. the KKT Jacobian of the previous equilibrium).
    load : ndarray (3,)
        (F [N], U [mm], d) of the residual r(z).
    atol : float
        Stop once ‖r‖∞ < atol (residual units N, mm).
    iterations : int
        Most chord steps.
    """
    r = assemble.evaluate(d, z, load, False)[0]
    best, best_norm = z, _residual_norm(r)
    last_norm = best_norm
    zc = z
    k = 0
    while k < iterations and best_norm >= atol and np.isfinite(last_norm):
        try:
            dz = np.linalg.solve(jac, -r)
        except Exception:  # singular: no step (as a non-finite solve in JAX)
            dz = np.full(r.shape[0], np.nan)
        zn = zc + dz if np.all(np.isfinite(dz)) else zc
        r = assemble.evaluate(d, zn, load, False)[0]
        last_norm = _residual_norm(r)
        if last_norm < best_norm:
            best, best_norm = zn, last_norm
        zc = zn
        k += 1
    return best


@kernel(nogil=True)
def ramp(
    d: SystemData,
    z0: np.ndarray,
    forces: np.ndarray,
    settings: NewtonSettings,
    chord_iterations: int,
    weak_contacts: bool,
) -> tuple:  # type: ignore[type-arg]
    """Quasi-static load stepping of one tube through the end forces ``forces`` [N] from z0.

    Each step starts with :func:`chord` at the new force with the Jacobian of the previous
    equilibrium (at most ``chord_iterations`` steps; the Jacobian at z0 for the first) and is
    finished by :func:`biplan.solvers.iteration.newton`; the converged state is observed
    from the Jacobian the Newton ends with. The ramp ends at the first step that does not
    converge to a finite state (later steps are not converged).

    Returns
    -------
    tuple
        (z of the last converged step (z0 when none) (n_z,), and per step (S,): converged,
        the failing status (−1 elsewhere), u_z [mm], u_r [mm], load-point displacement z_p
        [mm], λ_min of the reduced Hessian [N/mm]; NaN past the failed step).
    """
    n_steps = forces.shape[0]
    ok = np.zeros(n_steps, dtype=np.bool_)
    first_bad = np.full(n_steps, -1, dtype=np.int64)
    u_z = np.full(n_steps, np.nan)
    u_r = np.full(n_steps, np.nan)
    zp = np.full(n_steps, np.nan)
    min_eig = np.full(n_steps, np.nan)
    z = z0.copy()
    load = np.array([forces[0], 0.0, 0.0])
    jac = assemble.evaluate(d, z, load, True)[1]
    for k in range(n_steps):
        load = np.array([forces[k], 0.0, 0.0])
        start = chord(d, z, jac, load, settings.atol, chord_iterations)
        out = newton(d, load, start, settings, np.zeros(0), 0.0, np.zeros(0))
        if out[5] != _CONVERGED or not np.all(np.isfinite(out[0])):
            first_bad[k] = out[5]
            break
        z, jac = out[0], out[3]
        o = observe_state(d, z, load, jac, weak_contacts)
        ok[k] = True
        zp[k], u_z[k], u_r[k], min_eig[k] = o[1], o[2], o[3], o[8]
    return z, ok, first_bad, u_z, u_r, zp, min_eig
