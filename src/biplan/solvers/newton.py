"""Equilibrium solves of the KKT system of a constrained, contact-regularised tube (MODEL §11).

``solve_equilibrium(model, Newton(...), start, load)`` solves r(z) = 0 for z = [q, λ, λ_∂, μ]
with the one compiled Newton (:func:`biplan.solvers.iteration.newton`: Armijo backtracking on
½‖r‖², a Levenberg–Marquardt fallback, the watchdog) on the model's
:class:`~biplan.model.system.System`. :class:`Newton` configures it; its tolerances and limits
are data, so one compiled kernel serves every tube and every :class:`Newton`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from biplan._errors import ConfigError, ConvergenceError, check_integer, check_range
from biplan.model.assembly import Load, Model
from biplan.model.lagrangian import StateData
from biplan.model.system import System
from biplan.solvers import iteration
from biplan.solvers.iteration import NewtonSettings, newton_settings
from biplan.solvers.status import Status

__all__ = ["Newton", "Solution", "Status", "relaxed_reference", "solve_equilibrium"]


@dataclass(frozen=True)
class Newton:
    """Configured Newton solver.

    Parameters
    ----------
    atol : float
        Convergence when ‖r‖∞ < atol (residual units N, mm), > 0.
    max_steps : int
        Newton iterations, ≥ 1.
    max_backtracks : int
        Step halvings in the Armijo line search, ≥ 1.
    armijo : float
        Sufficient-decrease constant c in (0, 0.5).
    free_steps : int
        Watchdog (Chamberlain et al. 1982): the first ``free_steps`` Newton steps of a solve
        are taken whenever the trial point is finite, without the line-search test; the
        iterate of smallest merit is kept, and a solve that has not converged when they run
        out continues from it with the line search. 0 (default) is the plain globalised
        iteration. Near contact switches the merit ½‖r‖² of the smoothed Fischer–Burmeister
        rows is so curved (ε = 1e-6) that the line search rejects full Newton steps that
        would converge in a few iterations (docs/maps.md); ≥ 0 (steps past ``max_steps``
        never happen).
    contact_restart : bool
        A solve that fails from a start with non-zero contact multipliers λ_∂ (a warm start
        from a Solution) is tried once more from the same q, λ and μ with λ_∂ = 0 (default
        True; :attr:`Solution.restarts` counts it). The contact multipliers of a converged
        state can be artefacts of the smoothing (λ_∂·w_∂ = ε²/2 at gaps ~1e-9 mm): at that
        corner of the Fischer–Burmeister function the Jacobian is near-singular, and with
        ``ModelOptions.contact_compliance = 0`` Newton drifts into penetration and stalls
        when a new load presses the contacts shut. With the default compliance this is a
        safety net (docs/model.md, "Degenerate contacts").
    """

    atol: float = 1e-9
    max_steps: int = 60
    max_backtracks: int = 30
    armijo: float = 1e-4
    free_steps: int = 0
    contact_restart: bool = True

    def __post_init__(self) -> None:
        check_range("Newton.atol", self.atol, low=0.0)
        check_range("Newton.armijo", self.armijo, low=0.0, high=0.5)
        for name in ("max_steps", "max_backtracks"):
            object.__setattr__(
                self, name, check_integer(f"Newton.{name}", getattr(self, name), low=1)
            )
        object.__setattr__(
            self, "free_steps", check_integer("Newton.free_steps", self.free_steps, low=0)
        )
        if not isinstance(self.contact_restart, bool):
            raise ConfigError("Newton.contact_restart", self.contact_restart, "True or False")

    def loop_settings(self) -> NewtonSettings:
        """These settings as the compiled Newton takes them
        (:func:`biplan.solvers.iteration.newton_settings`; ``contact_restart`` is the driver's)."""
        return newton_settings(
            self.atol, self.max_steps, self.max_backtracks, self.armijo, self.free_steps
        )


@dataclass(frozen=True)
class Solution:
    """A (possibly failed) equilibrium solve.

    Attributes
    ----------
    q : ndarray
        Generalised coordinates (n_q,).
    multipliers : ndarray
        Guide multipliers λ [N] (2N,).
    contact_multipliers : ndarray
        Contact multipliers λ_∂ [N] (n_c,).
    force : float
        End force [N]: the applied F, or the reaction −μ under displacement control.
    displacement : float
        Axial displacement z_p [mm] of the load point.
    load : Load
        The load solved for.
    status : Status
    residual_norm : float
        ‖r‖∞ at the returned point.
    iterations : int
        Newton steps, summed over the attempts.
    energy : float
        Π(q) [N·mm].
    restarts : int
        Restarts from zero contact multipliers tried (0 or 1; :attr:`Newton.contact_restart`).
    """

    q: np.ndarray
    multipliers: np.ndarray
    contact_multipliers: np.ndarray
    force: float
    displacement: float
    load: Load
    status: Status
    residual_norm: float
    iterations: int
    energy: float
    z: np.ndarray = field(repr=False)
    data: StateData = field(repr=False, compare=False)
    restarts: int = 0

    @property
    def converged(self) -> bool:
        return self.status is Status.CONVERGED

    @property
    def message(self) -> str:
        text = (
            f"{self.status.message} after {self.iterations} iterations "
            f"(‖r‖∞ = {self.residual_norm:.3e})"
        )
        if self.restarts:
            text += (
                ", restarted from zero contact multipliers"
                if self.converged
                else "; a restart from zero contact multipliers failed too"
            )
        return text


def _start_vector(model: Model, start: Any) -> np.ndarray:
    if isinstance(start, Solution):
        z = np.asarray(start.z, dtype=float)
        if z.shape != (model.n_unknowns,):
            raise ConfigError(
                "start", z.shape, f"a Solution of this model ({model.n_unknowns} unknowns)"
            )
        return z
    arr = np.asarray(start, dtype=float)
    if arr.shape == (model.n_unknowns,):
        z = arr.copy()
    elif arr.shape == (model.n_coordinates,):
        z = model.pack(arr)
    else:
        raise ConfigError(
            "start",
            arr.shape,
            f"q of shape ({model.n_coordinates},), z of shape ({model.n_unknowns},) or a Solution",
        )
    if not np.all(np.isfinite(z)):
        raise ConfigError("start", "non-finite entries", "finite coordinates")
    return z


def _numpy(data: Any) -> Any:
    """A (nested) NamedTuple of arrays with every leaf a NumPy array."""
    if isinstance(data, tuple):
        return type(data)(*(_numpy(v) for v in data))
    return np.asarray(data)


def make_solution(
    model: Model,
    z: np.ndarray,
    load: Load,
    status: Status,
    rnorm: float,
    it: int,
    data: StateData | None = None,
) -> Solution:
    """Wrap a packed solution vector into a :class:`Solution` (``data``: its
    :class:`StateData` when the solver returned it; else evaluated here)."""
    q, lam, lam_c, mu = model.split(z)
    data = model.state(z, load) if data is None else _numpy(data)
    zp = float(data.load_displacement)
    force = -mu if load.is_displacement_controlled else float(load.force)
    return Solution(
        q=q,
        multipliers=lam,
        contact_multipliers=lam_c,
        force=float(force),
        displacement=zp,
        load=load,
        status=status,
        residual_norm=float(rnorm),
        iterations=int(it),
        energy=float(data.energy),
        z=np.asarray(z),
        data=data,
    )


def solve_equilibrium(
    model: Model,
    method: Newton | None = None,
    start: Any = None,
    load: Load | None = None,
    *,
    throw: bool = False,
) -> Solution:
    """Solve the KKT equilibrium system for one load.

    Parameters
    ----------
    model : Model
    method : Newton, optional
        Defaults to ``Newton()``.
    start : array_like or Solution, optional
        q (n_q,), a packed z, or a previous Solution (warm start with its multipliers).
        Defaults to q = 0.
    load : Load, optional
        Defaults to zero end force.
    throw : bool
        Raise :class:`~biplan.ConvergenceError` instead of returning a failed Solution
        (default ``False``, as for every driver).

    Returns
    -------
    Solution
        Check ``solution.status``; a non-converged solution is never marked converged.
    """
    method = method or Newton()
    load = load or Load.of_force(0.0)
    if not isinstance(load, Load):
        raise ConfigError("load", load, "a biplan Load (Load.of_force / Load.of_displacement)")
    z0 = _start_vector(model, model.zeros() if start is None else start)
    return _solve_compiled(model, model.system(load), method, z0, load, throw)


def _solve_compiled(
    model: Model, system: System, method: Newton, z0: np.ndarray, load: Load, throw: bool
) -> Solution:
    """:func:`solve_equilibrium` by the compiled Newton on the model's System."""
    settings = method.loop_settings()
    z, r, f, jac, steps, status = iteration.solve_system(system, z0, settings)
    restarts = 0
    q0, lam0, lam_c0, mu0 = model.split(z0)
    if method.contact_restart and status != Status.CONVERGED.value and np.any(lam_c0):
        # the start's contact multipliers can be smoothing artefacts (Newton.contact_restart)
        cold = model.pack(q0, lam0, None, mu0)
        retry = iteration.solve_system(system, cold, settings)
        restarts, steps = 1, steps + retry[4]
        if retry[5] == Status.CONVERGED.value:
            z, r, f, jac, _, status = retry
    # the Jacobian is at z once a pass was accepted (finite merit); else evaluated afresh
    data = system.state(z, jac if np.isfinite(f) else None)
    rnorm = float(np.max(np.abs(r)))
    sol = make_solution(model, z, load, Status(int(status)), rnorm, int(steps), data)
    sol = replace(sol, restarts=restarts) if restarts else sol
    if throw and not sol.converged:
        raise ConvergenceError(f"equilibrium solve for {load}: {sol.message}")
    return sol


def relaxed_reference(
    model: Model, method: Newton | None = None, *, throw: bool = False
) -> Solution:
    """The relaxed reference configuration q_ref: clamped base only, no load (SI "Numerical
    solver"). Starts from q = 0, which is an equilibrium up to the contact regularisation.
    ``throw`` as for :func:`solve_equilibrium`."""
    return solve_equilibrium(model, method, model.zeros(), Load.of_force(0.0), throw=throw)
