"""Finishing a force ramp through a snap with the equations of motion (design map reading
``after_snap = "dynamic"``; SI "Semi-Bistable MFT Design Maps": the maps are the *dynamic*
response to the ramp, evaluated at terminal time).

The design map follows the ramp quasi-statically (``design_map``). Past a limit point of the
force there is no nearby equilibrium: the load step fails and the tube, physically, snaps
through to another branch. From the last converged equilibrium (time t_k, force F_k = Ḟ t_k,
at rest) the remainder of the ramp F(t) = F_k + Ḟ (t − t_k), t_k ≤ t ≤ T, is integrated with
the generalized-α scheme (:func:`biplan.solvers.dynamics.integrate`; ρ∞ = 0 by default, so
that contact impacts during the snap end inelastically) and mass-proportional
Rayleigh damping that gives the first mode the damping ratio ζ at half the start force (the
paper states no damping; the default ζ = 5 % is the one of the fidelity study and Movie S1,
whose modes are taken at half the terminal force).
Where a step fails even at the smallest step (a cascade of contact impacts: on the
six-module design at 2.4 N the folds hit their contacts at ~5 m/s), the run is redone from
the same equilibrium with backward Euler, which ends every impact inelastically.
The snap lasts milliseconds against a ramp of seconds, so the state at T is the settled
post-snap equilibrium at F_f (tested: it solves the static equations to the integrator's
tolerance).
"""

from __future__ import annotations

import numpy as np

from biplan._errors import ConfigError
from biplan.analysis.modes import check_damping_ratio, rayleigh_at
from biplan.model.assembly import Load, Model
from biplan.solvers.control import ControlKind
from biplan.solvers.dynamics import BackwardEuler, GeneralizedAlpha, LoadHistory, integrate
from biplan.solvers.newton import Solution, Status, make_solution
from biplan.solvers.trajectory_results import Trajectory, TrajectoryStatus

__all__ = ["continue_ramp"]


def _rayleigh(model: Model, start: Solution, damping_ratio: float) -> float:
    """α_R = 2 ζ ω₁ with ω₁ the first natural frequency at half the start force
    (:func:`~biplan.analysis.modes.rayleigh_at`); 0 when that state is not a converged,
    stable equilibrium with a free mode."""
    check_damping_ratio(damping_ratio)
    try:
        return rayleigh_at(model, start, Load.of_force(0.5 * float(start.force)), damping_ratio)
    except ConfigError:
        return 0.0


def continue_ramp(
    model: Model,
    z: np.ndarray,
    t_start: float,
    *,
    rate: float,
    duration: float,
    damping_ratio: float,
    time_step: float,
    spectral_radius: float = 0.0,
) -> Trajectory:
    """Integrate the rest of the force ramp from the equilibrium ``z`` at ``t_start``.

    Parameters
    ----------
    model : Model
    z : ndarray
        Packed converged equilibrium [q, λ, λ_∂] at F = ``rate`` · ``t_start`` (at rest).
    t_start : float
        Ramp time t_k [s] of that equilibrium, 0 ≤ t_k < ``duration``.
    rate, duration : float
        Ḟ [N/s] and T [s] of the ramp.
    damping_ratio : float
        ζ of the first natural mode at half the start force, in (0, 1); sets the Rayleigh
        coefficient α_R = 2 ζ ω₁.
    time_step : float
        Nominal generalized-α step h [s] (halved automatically where a step fails).
    spectral_radius : float
        ρ∞ ∈ [0, 1] of the scheme; default 0, which damps out within a step the velocity
        jump that a contact impact leaves under position-level contact conditions (see
        ``ForceRamp.spectral_radius``).

    Returns
    -------
    Trajectory
        Over the local time τ = t − t_k ∈ [0, T − t_k]; check ``trajectory.status``. If a
        generalized-α step fails even at the smallest step (a cascade of contact impacts),
        the run is redone from ``z`` with :class:`~biplan.solvers.dynamics.BackwardEuler`
        (same h and α_R): first order and strongly dissipative, it ends every impact
        inelastically. ``trajectory.method`` names the scheme that produced the result.
    """
    f_start = rate * t_start
    start = make_solution(model, np.asarray(z), Load.of_force(f_start), Status.CONVERGED, 0.0, 0)
    alpha_r = _rayleigh(model, start, damping_ratio)
    rest = duration - t_start
    history = LoadHistory(ControlKind.FORCE, (0.0, rest), (f_start, rate * duration))
    scheme = GeneralizedAlpha(
        time_step=time_step, spectral_radius=spectral_radius, rayleigh=alpha_r
    )
    traj = integrate(model, scheme, start, t_end=rest, load=history)
    if traj.status is not TrajectoryStatus.STEP_FAILED:
        return traj
    # same traced settings, same compiled chunk: the fallback costs run time only
    fallback = BackwardEuler(time_step=time_step, rayleigh=alpha_r)
    return integrate(model, fallback, start, t_end=rest, load=history)
