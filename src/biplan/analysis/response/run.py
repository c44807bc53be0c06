"""The response of a tube to one controlled load, as ``biplan respond`` runs it.

:func:`respond` runs one of four workflows, chosen by the control and the settings
(:mod:`biplan.analysis.response.settings`):

* ``QuasiStatic`` with ``Method.STABLE`` under force or pressure control — the
  load-controlled test (:func:`~biplan.analysis.response.loadcontrol.load_response`): the
  stable branch up to its first loss of stability, the snap there (located; the landing state
  found by a descent at the fixed load), the stable branch on from there, snap after snap, to
  ``stop`` (``stop_at_snap`` ends at the first);
* ``QuasiStatic`` with ``Method.STABLE`` under displacement control — the stable-branch sweep
  of a testing machine (:func:`~biplan.analysis.response.quasistatic.displacement_sweep`) in
  ⌈|stop| / step⌉ equal steps from the relaxed reference;
* ``QuasiStatic`` with ``Method.ARCLENGTH`` or ``Method.STEPPING`` — a numerical path
  (:func:`~biplan.solvers.continuation.trace_path`); pseudo-arclength follows the equilibrium
  path through unstable states and never runs back past its start (status ``RETURNED``),
  load stepping stops at the first limit point;
* ``Ramp`` — the equations of motion under Λ(t) = rate · t, then the hold, integrated with
  backward Euler and Rayleigh damping that gives the first natural mode at half the final
  load the damping ratio ζ (:func:`~biplan.analysis.modes.rayleigh_at`).

Every response is summarized (:func:`response_summary`) with the phase-1 peak force as the
located first loss of stability under force control
(:func:`~biplan.analysis.response.loadcontrol.first_snap`), with its tolerance.

Units: force N, displacement mm, pressure MPa, time s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan._errors import ConfigError
from biplan.analysis.modes import rayleigh_at
from biplan.analysis.response import quasistatic
from biplan.analysis.response.loadcontrol import PEAK_METHOD, first_snap, load_response
from biplan.analysis.response.quasistatic import QuasiStaticPath
from biplan.analysis.response.settings import Method, QuasiStatic, Ramp
from biplan.analysis.response.summary import ResponseSummary, summarize
from biplan.model.assembly import Model
from biplan.solvers.continuation import ArcLength, LoadStepping, trace_path
from biplan.solvers.control import Control, ControlKind
from biplan.solvers.dynamics import BackwardEuler, LoadHistory, integrate
from biplan.solvers.newton import relaxed_reference
from biplan.solvers.path_results import EquilibriumPath, Snap
from biplan.solvers.results import display_units
from biplan.solvers.trajectory_results import Trajectory

__all__ = ["Response", "ramp_response", "respond", "response_summary", "stable_sweep"]


@dataclass(frozen=True)
class Response:
    """A response and its summary.

    Attributes
    ----------
    result : QuasiStaticPath, EquilibriumPath or Trajectory
        The stable-branch sweep, the path or the trajectory.
    summary : ResponseSummary
        Its key numbers (:func:`response_summary`).
    settings : QuasiStatic or Ramp
        What was run.
    """

    result: QuasiStaticPath | EquilibriumPath | Trajectory
    summary: ResponseSummary
    settings: QuasiStatic | Ramp

    @property
    def failed_steps(self) -> int:
        """Steps of a sweep that failed to converge (0 for a path or trajectory)."""
        if not isinstance(self.result, QuasiStaticPath):
            return 0
        return sum(not s.converged for s in self.result.solutions)

    @property
    def complete(self) -> bool:
        """Whether the response reached its stop (a sweep: every step converged)."""
        if isinstance(self.result, QuasiStaticPath):
            return self.failed_steps == 0
        return bool(self.result.completed)

    @property
    def message(self) -> str:
        """How the response ended: the path's or trajectory's message; for a sweep, its
        failed steps and where and why the first failed (the solver's message)."""
        r = self.result
        if isinstance(r, QuasiStaticPath):
            text = f"{self.failed_steps} of {r.n_steps} steps failed"
            for u, sol in zip(r.displacement, r.solutions, strict=True):
                if not sol.converged:
                    return f"{text}; the first at U = {u:g} mm: {sol.message}"
            return text
        return r.message

    @property
    def short(self) -> bool:
        """Whether a ``Method.STABLE`` run ended short of its stop: a sweep whose every step
        failed, or a load-controlled test that ended before ``stop`` without being asked to
        stop at its first snap."""
        if isinstance(self.result, QuasiStaticPath):
            return self.failed_steps == self.result.n_steps
        s = self.settings
        return (
            isinstance(s, QuasiStatic)
            and s.method is Method.STABLE
            and not s.stop_at_snap
            and not self.result.completed
        )

    @property
    def headline(self) -> str:
        """What was run and how it ended, in one line."""
        r = self.result
        if isinstance(r, QuasiStaticPath):
            stop = getattr(self.settings, "stop", float(r.displacement[-1]))
            return (
                f"stable-branch sweep to U = {stop:g} mm: {r.n_steps} steps, "
                f"{int(r.switched.sum())} snaps to a stable branch, {self.failed_steps} failed"
            )
        what = ""
        if getattr(r, "segment", None) is not None:
            what = "stable response (what a load-controlled test does): "
        elif r.method == "ArcLength":
            what = (
                "equilibrium path (pseudo-arclength, a numerical method: unstable states "
                "included, not what a load-controlled test does): "
            )
        return f"{what}{self.message}"

    def snap_lines(self) -> list[str]:
        """One indented line per snap of a load-controlled test (load in display units:
        pressure in kPa)."""
        snaps: tuple[Snap, ...] = getattr(self.result, "snaps", ())
        if not snaps:
            return []
        scale, unit = display_units(self.result.control)  # type: ignore[union-attr]
        return ["  " + snap.describe(unit, scale) for snap in snaps]


def respond(model: Model, control: ControlKind | str, settings: QuasiStatic | Ramp) -> Response:
    """The response of ``model`` under ``control`` (see the module docstring).

    Parameters
    ----------
    model : Model
    control : ControlKind or str
        The controlled quantity: force, displacement or pressure.
    settings : QuasiStatic or Ramp
        A quasi-static response and its method, or a dynamic ramp (values in N, mm or MPa).

    Returns
    -------
    Response
        The result (a :class:`~biplan.analysis.response.quasistatic.QuasiStaticPath` for the
        stable displacement sweep, a :class:`~biplan.solvers.path_results.EquilibriumPath` for every
        other quasi-static response, a :class:`~biplan.solvers.trajectory_results.Trajectory`
        for a ramp) and its summary. Check ``complete`` and ``short``.

    Raises
    ------
    ConfigError
        ``stop_at_snap`` other than with ``Method.STABLE`` under force or pressure control; a
        stable sweep of more than ``max_steps`` steps.
    """
    kind = ControlKind(control)
    result: QuasiStaticPath | EquilibriumPath | Trajectory
    if isinstance(settings, Ramp):
        result = ramp_response(model, kind, settings)
    elif settings.stop_at_snap and (
        settings.method is not Method.STABLE or kind is ControlKind.DISPLACEMENT
    ):
        raise ConfigError(
            "stop_at_snap", True, "used with Method.STABLE under force or pressure control"
        )
    elif settings.method is Method.STABLE and kind is ControlKind.DISPLACEMENT:
        result = stable_sweep(model, settings)
    else:
        result = _quasi_static(model, kind, settings)
    return Response(result, response_summary(model, result), settings)


def stable_sweep(model: Model, settings: QuasiStatic) -> QuasiStaticPath:
    """The stable-branch displacement sweep to ``settings.stop`` [mm] in
    ``settings.sweep_steps`` equal steps from the relaxed reference."""
    n = settings.sweep_steps
    if n > settings.max_steps:
        fewest = abs(settings.stop) / settings.max_steps
        raise ConfigError("step", settings.step, f"≥ |stop| / max_steps = {fewest:g} mm")
    stop = settings.stop
    ref = relaxed_reference(model, throw=True)
    return quasistatic.displacement_sweep(model, np.linspace(stop / n, stop, n), start=ref)


def _quasi_static(model: Model, kind: ControlKind, settings: QuasiStatic) -> EquilibriumPath:
    """A load-controlled test (``Method.STABLE``) or a numerical path."""
    ctl = Control(kind, settings.stop)
    steps: dict[str, Any] = {
        "initial_step": settings.step,
        "max_step": settings.max_step,
        "max_steps": settings.max_steps,
    }
    if settings.method is Method.STABLE:
        return load_response(model, ctl, ArcLength(**steps), stop_at_snap=settings.stop_at_snap)
    cls = ArcLength if settings.method is Method.ARCLENGTH else LoadStepping
    return trace_path(model, cls(**steps), None, ctl)


def ramp_response(model: Model, kind: ControlKind, ramp: Ramp) -> Trajectory:
    """The trajectory under the load ramp (backward Euler; Rayleigh damping that gives the
    first mode the damping ratio ζ at half the final load, from the relaxed reference)."""
    history = LoadHistory(kind, ramp.times, ramp.values)
    rayleigh = 0.0
    if ramp.damping_ratio > 0:
        ref = relaxed_reference(model, throw=True)
        half = 0.5 * ramp.top
        probe = Control(kind, half).load(model, half)
        rayleigh = rayleigh_at(model, ref, probe, ramp.damping_ratio)
    scheme = BackwardEuler(time_step=ramp.time_step, rayleigh=rayleigh)
    return integrate(model, scheme, t_end=ramp.times[-1], load=history)


def response_summary(
    model: Model, result: QuasiStaticPath | EquilibriumPath | Trajectory
) -> ResponseSummary:
    """The response's summary; its phase-1 peak the located one when the response leaves
    phase 1: the response's first snap under force control, else
    :func:`~biplan.analysis.response.loadcontrol.first_snap` (a ramp that never leaves phase
    1 reports no peak)."""
    l0 = model.tube.initial_length
    plain = summarize(result, initial_length=l0)
    snaps: tuple[Snap, ...] = getattr(result, "snaps", ())
    if not (np.isfinite(plain.peak_force) or snaps):
        return plain
    control = getattr(result, "control", None)
    if snaps and control is not None and control.kind is ControlKind.FORCE:
        peak: Snap | None = snaps[0]
    else:
        peak = first_snap(model, method=PEAK_METHOD)
    return summarize(result, initial_length=l0, peak=peak)
