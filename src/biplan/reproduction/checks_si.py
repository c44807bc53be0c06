"""Checks of the supplement's claims: the state distributions (SI S12), the CFT calibration
(SI S10) and Movie S1.

Each function reads :class:`~biplan.reproduction.facts.Results` and returns a
:class:`~biplan.reproduction.grading.Finding`; :data:`biplan.reproduction.claims.CLAIMS` pairs
it with the paper's words.
"""

from __future__ import annotations

import numpy as np

from biplan.analysis.states.hierarchy import count_peaks
from biplan.reproduction.facts import Results
from biplan.reproduction.grading import Finding, fmt, grade, grade_distance, yes_no

__all__ = ["calibration", "deflection_peaks", "elongation_bimodal", "movie", "slope_peak"]


def slope_peak(r: Results) -> Finding:
    """``si.dist.slope``: the slope distribution peaks within 0.1 (partly 0.2) of Θ = 1/3."""
    s = r.states
    assert s is not None
    if s.theta_counts.size == 0 or s.theta_counts.max() == 0:
        return Finding("no states", grade([]), "no slope distribution")
    peak = abs(float(s.theta_bins[int(np.argmax(s.theta_counts))]))
    return Finding(
        f"slope distribution peaks at Θ = {peak:.2f} "
        f"({int(s.theta_counts.max())} of {int(s.theta_counts.sum())} states)",
        grade_distance(abs(peak - 1 / 3), 0.1, 0.2),
        f"|Θ_peak − 1/3| = {abs(peak - 1 / 3):.2f}",
    )


def elongation_bimodal(r: Results) -> Finding:
    """``si.dist.elongation``: two peaks in the u_z/l₀ distribution (partly one or
    three)."""
    s = r.states
    assert s is not None
    n = count_peaks(s.u_z_counts)
    return Finding(
        f"{n} peak(s) in the u_z/l0 distribution ({len(s.labels)} states)",
        grade_distance(abs(n - 2), 0, 1),
        "paper: bimodal (two iso-elongation groups)",
    )


def deflection_peaks(r: Results) -> Finding:
    """``si.dist.deflection``: the u_r/l₀ distribution's mode near zero, and a peak in
    [1/8, 5/8]."""
    s = r.states
    assert s is not None
    c, x = s.u_r_counts, s.u_r_bins
    if c.size == 0 or c.max() == 0:
        return Finding("no states", grade([]), "no deflection distribution")
    width = float(np.median(np.diff(x))) if x.size > 1 else 1.0
    mode = float(x[int(np.argmax(c))])
    in_band = (np.abs(s.u_r) >= 1 / 8) & (np.abs(s.u_r) <= 5 / 8)
    bins_in = (np.abs(x) >= 1 / 8 - width / 2) & (np.abs(x) <= 5 / 8 + width / 2)
    secondary = bool(in_band.any()) and count_peaks(np.where(bins_in, c, 0)) >= 1
    checks = [abs(mode) <= max(width, 1 / 16), secondary]
    return Finding(
        f"mode at u_r/l0 = {mode:.3f}; {int(in_band.sum())} states with u_r/l0 in [1/8, 5/8]",
        grade(checks),
        "dominant peak near zero; secondary band in [1/8, 5/8]: " + yes_no(checks),
    )


def calibration(r: Results) -> Finding:
    """``si.cft``: every fitted parameter within 10 % of the table's (or inside its
    bootstrap interval), residuals at most three times the noise [N], measured specimens."""
    cal = r.calibration
    assert cal is not None
    parts, checks = [], []
    for c in cal:
        errs = []
        for name, true in c.truth.items():
            value, lo, hi = c.estimates[name]
            rel = abs(value - true) / abs(true) if true else abs(value)
            errs.append(rel)
            checks.append(rel < 0.1 or (np.isfinite(lo) and lo <= true <= hi))
        noisy = not np.isfinite(c.noise) or c.rms <= 3 * c.noise
        checks.append(noisy)
        parts.append(f"{c.kind}: max rel. error {max(errs):.1%}, RMS {c.rms:.3g} N")
    synthetic = any(c.synthetic for c in cal)
    checks.append(not synthetic)
    return Finding(
        "; ".join(parts),
        grade(checks),
        "the fits recover the SI Table calib laws within 10 % (or their bootstrap interval) "
        "with residuals at the noise level"
        + (
            "; the specimens are synthetic (from the table's laws), so this checks the "
            "procedure, not the paper's data"
            if synthetic
            else ""
        ),
    )


def movie(r: Results) -> Finding:
    """``si.movie``: at least 10 frames, and the animated ramp loses stability."""
    m = r.movie
    assert m is not None
    checks = [m.n_frames >= 10, m.lost_stability]
    return Finding(
        f"{m.n_frames} frames ({m.file}), to F = {fmt(m.final_force)} N",
        grade(checks),
        "development and cylinder animated; the animated force ramp "
        + ("passes through" if m.lost_stability else "does not reach")
        + " the transition (the paper's movie shows the full transformation); no experimental "
        "panel",
    )
