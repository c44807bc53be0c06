"""The computations of ``biplan demo``: a tube stretched under displacement control, and
loaded with the paper's force ramp.

* :func:`demo_sweep` — the stable-branch sweep of the end displacement U from 0 (exclusive)
  to :data:`MAX_DISPLACEMENT` in equal steps
  (:func:`~biplan.analysis.response.quasistatic.displacement_sweep`), and
  :func:`sweep_summary`, its summary line (the located phase-1 peak of
  :func:`~biplan.analysis.response.loadcontrol.first_snap`, snaps, failures, run time);
* :func:`ramp_and_path` — the trajectory under the paper's ramp F(t) = 0.8 N/s · t,
  0 ≤ t ≤ 2 s (generalized-α, h = 10 ms, ρ∞ = 0.8, Rayleigh damping giving the first mode at
  0.8 N the damping ratio ζ = 5 %), the displacement-controlled equilibrium path to
  :data:`MAX_DISPLACEMENT` (pseudo-arclength), and their summary lines: the phase-1 peak
  force, the spinodal span and u_z/l₀, u_r/l₀ at the end of the ramp.

Units: force N, displacement mm, time s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from biplan.analysis.modes import rayleigh_at
from biplan.analysis.response import quasistatic
from biplan.analysis.response.quasistatic import QuasiStaticPath
from biplan.analysis.response.summary import phase_one_end, summarize
from biplan.model.assembly import Load, Model
from biplan.solvers.continuation import ArcLength, trace_path
from biplan.solvers.control import Control
from biplan.solvers.dynamics import GeneralizedAlpha, LoadHistory, integrate
from biplan.solvers.newton import Solution, relaxed_reference
from biplan.solvers.path_results import EquilibriumPath, Snap
from biplan.solvers.trajectory_results import Trajectory

__all__ = [
    "MAX_DISPLACEMENT",
    "RampAndPath",
    "demo_sweep",
    "phase_one",
    "ramp_and_path",
    "sweep_summary",
]

#: Final prescribed end displacement of the sweep and of the equilibrium path [mm].
MAX_DISPLACEMENT = 9.0
#: The paper's force ramp: rate [N/s] and duration [s].
RAMP_RATE = 0.8
RAMP_DURATION = 2.0
#: Time step [s] of the ramp and the first-mode damping ratio ζ of its Rayleigh damping.
TIME_STEP = 0.01
DAMPING_RATIO = 0.05
#: Continuation settings of the equilibrium path.
PATH_METHOD = ArcLength(initial_step=0.05, max_step=0.1)


def demo_sweep(
    model: Model,
    steps: int,
    start: Solution,
    progress: Callable[[int, int], object] | None = None,
) -> QuasiStaticPath:
    """The stable-branch sweep U = M/n, 2M/n, …, M with M = :data:`MAX_DISPLACEMENT` [mm].

    Parameters
    ----------
    model : Model
    steps : int
        n, the number of steps.
    start : Solution
        The relaxed reference.
    progress : callable, optional
        Called after every step (see
        :func:`~biplan.analysis.response.quasistatic.displacement_sweep`).
    """
    targets = np.linspace(MAX_DISPLACEMENT / steps, MAX_DISPLACEMENT, steps)
    return quasistatic.displacement_sweep(model, targets, start=start, progress=progress)


def phase_one(path: QuasiStaticPath) -> slice:
    """Steps of phase 1: from the start up to (excluding) the first step that failed, is
    unstable, switched branch (the first snap) or whose force fell along stable states
    (:func:`biplan.analysis.response.summary.phase_one_end`)."""
    return slice(0, phase_one_end(path.force, path.stable, path.switched))


def sweep_summary(path: QuasiStaticPath, seconds: float, peak: Snap | None) -> str:
    """The sweep's summary line: the located phase-1 peak ``peak`` (else the largest force of
    phase 1), the number of snaps and failed steps, and ``seconds`` [s] of run time."""
    first = phase_one(path)
    n_failed = int(np.sum(~np.isfinite(path.force)))
    n_snaps = int(np.sum(path.switched))
    if first.stop == 0:
        head = "No regular phase 1 (the first step snapped, failed or is unstable)"
    elif peak is None:
        k = int(np.argmax(path.force[first]))
        head = (
            f"Phase 1: largest force {path.force[k]:.4f} N at U = {path.displacement[k]:.3f} mm "
            "(no loss of stability under force control found)"
        )
    else:
        head = (
            f"Phase 1 peak force {peak.force:.4f} ± {peak.tolerance:.1g} N at z_p = "
            f"{peak.displacement_before:.3f} mm (located first loss of stability)"
        )
    tail = f"{n_snaps} snaps, {n_failed} failed of {len(path.force)} steps, {seconds:.1f} s"
    return f"{head} ({tail})"


@dataclass(frozen=True)
class RampAndPath:
    """The paper's force ramp and the displacement-controlled equilibrium path.

    Attributes
    ----------
    ramp : Trajectory
        Under F(t) = 0.8 N/s · t, 0 ≤ t ≤ 2 s.
    path : EquilibriumPath
        The equilibrium path to U = :data:`MAX_DISPLACEMENT` [mm].
    rayleigh : float
        The ramp's Rayleigh coefficient α_R [1/s].
    lines : tuple of str
        The summary: the ramp, the phase-1 peak, the spinodal regime, the state at the end of
        the ramp.
    """

    ramp: Trajectory
    path: EquilibriumPath
    rayleigh: float
    lines: tuple[str, ...]


def ramp_and_path(
    model: Model, start: Solution | None = None, *, peak: Snap | None = None
) -> RampAndPath:
    """Integrate the ramp and trace the path from ``start`` (default the relaxed reference).

    ``peak``: the located phase-1 peak (:func:`~biplan.analysis.response.loadcontrol.first_snap`),
    reported instead of the largest force recorded on the path."""
    ref = relaxed_reference(model, throw=True) if start is None else start
    top = RAMP_RATE * RAMP_DURATION
    alpha = rayleigh_at(model, ref, Load.of_force(0.5 * top), DAMPING_RATIO)
    scheme = GeneralizedAlpha(time_step=TIME_STEP, rayleigh=alpha)
    load = LoadHistory.ramp(RAMP_RATE, RAMP_DURATION)
    ramp = integrate(model, scheme, ref, load, t_end=RAMP_DURATION)
    path = trace_path(model, PATH_METHOD, ref, Control.displacement(MAX_DISPLACEMENT))
    s_path = summarize(path, peak=peak)
    s_ramp = summarize(ramp)
    l0 = model.tube.initial_length
    lines = (
        f"ramp {RAMP_RATE:g} N/s × {RAMP_DURATION:g} s ({ramp.message}); first-mode damping "
        f"ζ = {DAMPING_RATIO:g} (α_R = {alpha:.0f} 1/s)",
        s_path.lines()[0],
        (
            f"spinodal regime (unstable equilibria, displacement control): z_p = "
            f"{s_path.spinodal_start:.3f} … {s_path.spinodal_end:.3f} mm "
            f"(span {s_path.spinodal_span:.3f} mm)"
        ),
        (
            f"at {top:g} N (end of the ramp): u_z/l0 = {ramp.u_z[-1] / l0:.4f}, "
            f"u_r/l0 = {ramp.u_r[-1] / l0:.4f}"
            + ("" if s_ramp.spinodal_span == 0 else " (after a loss of stability)")
        ),
    )
    return RampAndPath(ramp, path, alpha, lines)
