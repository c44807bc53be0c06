"""Summaries of a force–displacement response (main "Application"; SI design maps).

:func:`summarize` reads the quantities the paper discusses for the semi-bistable MFT off a
path or trajectory:

* the phase-1 peak: the largest end force before the first loss of stability, the first snap
  or the first fall of the force, whichever comes first [N], and the load-point displacement
  there [mm] (NaN when the response never leaves phase 1: its largest force is no peak);
* the spinodal regime: the displacement span [mm] over which the recorded equilibria are
  unstable (λ_min(H_r) < 0) — first unstable to last unstable state;
* softening: the span [mm] over which the force falls with rising displacement along stable
  states of one branch — a fold's
  spinodal branch held by displacement control, i.e. a transformation without a snap (one
  fold on k₂ < 0 in series with n − 1 folds on k₁ is stable under displacement control when
  (n − 1)|k₂| < k₁ and the rest of the tube adds little compliance);
* the state at a given end force (default the paper's terminal 1.6 N): u_z/l₀, u_r/l₀ and θ,
  interpolated along the first stretch of the response that reaches that force.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["ResponseSummary", "phase_one_end", "softening_steps", "summarize"]

#: The paper's terminal force of the design-map ramp [N].
TERMINAL_FORCE = 1.6
#: A force falls from one state to the next when it drops by more than this times max |F|
#: (far above the solver's residual, far below any physical softening step).
FORCE_TOLERANCE = 1e-8


@dataclass(frozen=True)
class ResponseSummary:
    """Key numbers of a response (NaN where the response does not reach them).

    Attributes
    ----------
    peak_force, peak_displacement : float
        Phase-1 peak force [N] and load-point displacement there [mm].
    spinodal_start, spinodal_end : float
        Load-point displacement [mm] of the first and last unstable state.
    at_force : float
        The force [N] of the ``u_z_ratio`` … ``theta`` entries.
    u_z_ratio, u_r_ratio : float
        u_z/l₀ and u_r/l₀ at ``at_force``.
    theta : float
        End slope θ [rad] at ``at_force``.
    softening_start, softening_end : float
        Load-point displacement [mm] of the first and last stable state whose force is below
        the previous state's at a larger displacement (NaN when the force never falls so).
    largest_force : float
        The largest force of phase 1 [N] (equal to ``peak_force`` when phase 1 ends).
    peak_tolerance : float
        Tolerance [N] of a located peak (NaN: read off the recorded states).
    """

    peak_force: float
    peak_displacement: float
    spinodal_start: float
    spinodal_end: float
    at_force: float
    u_z_ratio: float
    u_r_ratio: float
    theta: float
    softening_start: float = float("nan")
    softening_end: float = float("nan")
    largest_force: float = float("nan")
    peak_tolerance: float = float("nan")

    @property
    def spinodal_span(self) -> float:
        """Width [mm] of the spinodal regime (0 when the response never loses stability)."""
        if not np.isfinite(self.spinodal_start):
            return 0.0
        return self.spinodal_end - self.spinodal_start

    def lines(self) -> list[str]:
        """Human-readable lines (for the CLI)."""
        if np.isfinite(self.peak_force) and np.isfinite(self.peak_tolerance):
            out = [
                f"phase-1 peak force {self.peak_force:.4f} ± {self.peak_tolerance:.1g} N at "
                f"z_p = {self.peak_displacement:.3f} mm (located first loss of stability under "
                "force control)"
            ]
        elif np.isfinite(self.peak_force):
            out = [
                f"phase-1 peak force {self.peak_force:.4f} N at z_p = "
                f"{self.peak_displacement:.3f} mm"
            ]
        else:
            out = [f"phase 1 not left (largest force {self.largest_force:.4f} N)"]
        if np.isfinite(self.spinodal_start):
            out.append(
                f"spinodal regime z_p = {self.spinodal_start:.3f} … {self.spinodal_end:.3f} mm "
                f"(span {self.spinodal_span:.3f} mm)"
            )
        else:
            out.append("no spinodal regime (every recorded state is stable)")
        if np.isfinite(self.softening_start):
            out.append(
                f"stable softening: the force falls over z_p = {self.softening_start:.3f} … "
                f"{self.softening_end:.3f} mm without a snap (a transformation held by "
                "displacement control)"
            )
        if np.isfinite(self.u_z_ratio):
            out.append(
                f"at F = {self.at_force:g} N: u_z/l0 = {self.u_z_ratio:.4f}, "
                f"u_r/l0 = {self.u_r_ratio:.4f}, theta = {self.theta:.4f} rad"
            )
        else:
            out.append(f"F = {self.at_force:g} N is not reached by the recorded response")
        return out


def softening_steps(
    force: np.ndarray,
    stable: np.ndarray,
    switched: np.ndarray | None = None,
    displacement: np.ndarray | None = None,
) -> np.ndarray:
    """Steps whose force fell from the previous step's along stable states on one branch
    (not a snap) while the displacement rose (when given): bool (n_steps,). A fall counts
    when it exceeds :data:`FORCE_TOLERANCE` times max |F|."""
    f = np.asarray(force, dtype=float)
    ok = np.isfinite(f)
    st = np.asarray(stable, dtype=bool)
    sw = np.zeros(f.size, bool) if switched is None else np.asarray(switched, dtype=bool)
    tol = FORCE_TOLERANCE * max(1.0, float(np.max(np.abs(f[ok])))) if ok.any() else 0.0
    out = np.zeros(f.size, dtype=bool)
    out[1:] = ok[1:] & ok[:-1] & st[1:] & st[:-1] & ~sw[1:] & (f[1:] < f[:-1] - tol)
    if displacement is not None:
        u = np.asarray(displacement, dtype=float)
        out[1:] &= u[1:] > u[:-1]
    return out


def phase_one_end(
    force: np.ndarray,
    stable: np.ndarray,
    switched: np.ndarray | None = None,
    displacement: np.ndarray | None = None,
) -> int:
    """End (exclusive) of phase 1: the first step that failed (NaN force), is unstable,
    snapped (``switched``) or whose force fell along stable states (:func:`softening_steps`);
    the number of steps if none did."""
    f = np.asarray(force, dtype=float)
    sw = np.zeros(f.size, bool) if switched is None else np.asarray(switched, dtype=bool)
    irregular = ~np.isfinite(f) | ~np.asarray(stable, dtype=bool) | sw
    irregular |= softening_steps(f, stable, switched, displacement)
    hits = np.flatnonzero(irregular)
    return int(hits[0]) if hits.size else int(f.size)


def summarize(
    result: Any,
    force: float = TERMINAL_FORCE,
    initial_length: float | None = None,
    peak: Any = None,
) -> ResponseSummary:
    """Summarize a Path, Trajectory or QuasiStaticPath (anything with the arrays ``force``,
    ``displacement``, ``u_z``, ``u_r``, ``theta``, ``stable``).

    Phase 1 runs up to the first failed or unstable state, the first fall of the force along
    stable states (a stable limit point under displacement control) or, on a stable-branch
    sweep (a ``switched`` array), its first snap (:func:`phase_one_end`); its peak is the
    largest force before that.

    Parameters
    ----------
    result : Path, Trajectory or QuasiStaticPath
    force : float
        End force [N] at which to report u_z/l₀, u_r/l₀ and θ.
    initial_length : float, optional
        l₀ [mm]; default ``result.model.tube.initial_length``.
    peak : Snap, optional
        The located phase-1 peak (:func:`biplan.analysis.response.loadcontrol.first_snap`): reported
        instead of the largest recorded force, with its tolerance, when the response leaves
        phase 1.
    """
    f = np.asarray(result.force, dtype=float)
    zp = np.asarray(result.displacement, dtype=float)
    stable = np.asarray(result.stable, dtype=bool)
    ok = np.isfinite(f)
    if initial_length is None:
        initial_length = float(result.model.tube.initial_length)
    nan = float("nan")
    unstable = np.flatnonzero(ok & ~stable)
    switched = getattr(result, "switched", None)
    softening = softening_steps(f, stable, switched, zp)
    end = phase_one_end(f, stable, switched, zp)
    phase1 = np.flatnonzero(ok[:end])
    peak_f = peak_u = largest = nan
    if phase1.size:
        k = int(phase1[np.argmax(f[phase1])])
        largest = float(f[k])
        if end < f.size:  # phase 1 ended: its largest force is the peak
            peak_f, peak_u = largest, float(zp[k])
    soft = np.flatnonzero(softening)
    soft0, soft1 = (float(zp[soft].min()), float(zp[soft].max())) if soft.size else (nan, nan)
    if unstable.size:
        s0, s1 = float(zp[unstable].min()), float(zp[unstable].max())
    else:
        s0 = s1 = nan
    # first stretch that reaches ``force``
    reach = np.flatnonzero(ok & (f >= force - 1e-9))
    if reach.size and reach[0] > 0:
        j = int(reach[0])
        i = j - 1
        w = (force - f[i]) / (f[j] - f[i]) if f[j] != f[i] else 1.0

        def at(x: np.ndarray) -> float:
            return float((1 - w) * x[i] + w * x[j])

        uz = at(np.asarray(result.u_z)) / initial_length
        ur = at(np.asarray(result.u_r)) / initial_length
        th = at(np.asarray(result.theta))
    elif reach.size:
        uz = float(result.u_z[0]) / initial_length
        ur = float(result.u_r[0]) / initial_length
        th = float(result.theta[0])
    else:
        uz = ur = th = nan
    tol = nan
    snapped = bool(getattr(result, "snaps", ()))
    if peak is not None and (np.isfinite(peak_f) or snapped) and np.isfinite(largest):
        peak_f, peak_u = float(peak.force), float(peak.displacement_before)
        tol = float(peak.tolerance) if np.isfinite(peak.tolerance) else 0.0
    return ResponseSummary(
        peak_f, peak_u, s0, s1, float(force), uz, ur, th, soft0, soft1, largest, tol
    )
