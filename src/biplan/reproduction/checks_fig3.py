"""Checks of the claims of Fig. 3: the semi-bistable MFT (the validated design's sweep, its
snapshots, the design, first-instability and stability maps, the measured band).

Each function reads :class:`~biplan.reproduction.facts.Results` and returns a
:class:`~biplan.reproduction.grading.Finding`; :data:`biplan.reproduction.claims.CLAIMS` pairs
it with the paper's words. Slopes Θ and deflections u_r are compared by magnitude: the model's
sign convention for θ and u_r (negative for the paper's positive bending) is a choice of axes,
not physics.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from biplan.analysis.response.summary import softening_steps
from biplan.reproduction.facts import PAPER_B, RAMP_FORCE, Results
from biplan.reproduction.grading import Finding, fmt, grade, grade_distance, yes_no

__all__ = [
    "deflection_trend",
    "design_ratios",
    "distributed",
    "eccentric_bending",
    "extension_trend",
    "snapshot_modes",
    "stability_regimes",
    "star",
    "two_phases",
    "within_band",
    "within_ramp",
]


def design_ratios(r: Results) -> Finding:
    """``fig3.design``: b of the validated design within 0.01 (partly 0.05) of 0.58."""
    s = r.semi
    assert s is not None
    d = abs(s.b - PAPER_B)
    return Finding(
        f"b = {s.b:.3f}, C = {s.C:.3f}",
        grade_distance(d, 0.01, 0.05),
        f"|b − {PAPER_B}| = {d:.3f} (SI Table calib gives β = 60°, H and l; the paper rounds b"
        " to 0.58 and states no value of C, which follows from the table's laws)",
    )


def two_phases(r: Results) -> Finding:
    """``fig3.A2.phases``: a phase 1, a snap, and a stable phase 2 of rising force."""
    s = r.semi
    assert s is not None
    n1 = s.phase_one.stop
    snaps = s.snaps
    ok = np.flatnonzero(np.isfinite(s.force))
    after = ok[ok > snaps[-1]] if snaps.size else ok[:0]
    rising = after.size >= 2 and bool(np.all(np.diff(s.force[after]) > -1e-9))
    checks = [n1 > 0, snaps.size > 0, after.size >= 2 and rising and bool(s.stable[after].all())]
    return Finding(
        f"{n1} phase-1 steps, {snaps.size} snap(s), {after.size} stable phase-2 steps "
        f"(force rising: {rising})",
        grade(checks),
        "phase 1, loss of stability, phase 2 — "
        + ", ".join(
            f"{n}: {'yes' if c else 'no'}"
            for n, c in zip(("phase 1", "spinodal/snap", "phase 2"), checks, strict=True)
        ),
    )


def within_ramp(r: Results) -> Finding:
    """``fig3.A2.within_ramp``: the largest phase-1 force at most the 1.6 N ramp
    (partly within 0.2 N above), and where the first-instability map transforms within it."""
    s = r.semi
    assert s is not None
    p1 = np.arange(s.force.size)[s.phase_one]
    peak = float(np.max(s.force[p1])) if p1.size else float("nan")
    excess = peak - RAMP_FORCE
    return Finding(
        f"first loss of stability at F = {fmt(peak, 4)} N",
        grade_distance(max(excess, 0.0) if np.isfinite(excess) else excess, 0.0, 0.2),
        f"the transition starts {'within' if excess <= 0 else 'above'} the paper's 1.6 N ramp"
        + ("" if excess <= 0 else f" (by {excess:.2f} N; docs/fidelity.md)")
        + _instability_region(r.instability_map),
    )


def _instability_region(ds: Any) -> str:
    """Where on the first-instability map (b, C) the transition starts within the ramp
    (empty when the map was not run)."""
    if ds is None:
        return ""
    b, c, f = _axis(ds, "force")
    inside = np.isfinite(f) & (f <= RAMP_FORCE)
    if not np.any(np.isfinite(f)):
        return "; the first-instability map found no loss of stability"
    i, j = _corner(np.where(np.isfinite(f), f, np.inf), np.argmin)
    text = (
        f"; on the (b, C) map F* ≤ {RAMP_FORCE:g} N at {int(inside.sum())} of {f.size} designs, "
        f"lowest F* = {fmt(float(f[i, j]), 3)} N at b = {b[i]:.3g}, C = {c[j]:.3g}"
    )
    if inside.any():
        text += f" (all at C ≤ {c[np.flatnonzero(inside.any(axis=0)).max()]:.3g})"
    return text


def distributed(r: Results) -> Finding:
    """``fig3.distributed``: two or more circular folds partly on their spinodal branch
    before the first snap (a distributed onset), and at most one snap."""
    s = r.semi
    assert s is not None
    n, spread = int(s.snaps.size), s.onset_spread
    folds = "?" if s.spinodal is None else str(np.shape(s.spinodal)[1])
    value = (
        f"{n} snap(s) on the stable-branch displacement sweep; {spread} of {folds} circular "
        "folds partly on their spinodal branch just before the first"
    )
    softens = bool(softening_steps(s.force, s.stable, s.switched).any())
    if not (n or softens):  # a transformation either snaps or softens stably
        return Finding(value, grade([]), "no transformation found")
    checks = [spread >= 2, n <= 1]
    return Finding(
        value,
        grade(checks),
        "the transformation starts in several folds at once (distributed onset); it completes "
        "in one passage, not fold by fold: " + yes_no(checks),
    )


def eccentric_bending(r: Results) -> Finding:
    """``fig3.B1.eccentric``: |u_r|/l₀ and |θ| [rad] above 1e-3 at the end of phase 1,
    |u_r| correlated with F (above 0.9)."""
    s = r.semi
    assert s is not None
    p1 = s.phase_one
    f, ur, th = s.force[p1], np.abs(s.u_r[p1]), np.abs(s.theta[p1])
    if f.size >= 3:
        last_ur, last_th = float(ur[-1]) / s.initial_length, float(th[-1])
        corr = float(np.corrcoef(f, ur)[0, 1]) if np.ptp(ur) > 0 else 0.0
    else:
        last_ur = last_th = corr = float("nan")
    checks = [last_ur > 1e-3, last_th > 1e-3, corr > 0.9]
    return Finding(
        f"end of phase 1: |u_r|/l0 = {fmt(last_ur)}, |θ| = {fmt(last_th)} rad; "
        f"corr(F, |u_r|) = {fmt(corr)}",
        grade(checks),
        "deflection, slope and their growth with F in phase 1: " + yes_no(checks),
    )


def snapshot_modes(r: Results) -> Finding:
    """``fig3.B.modes``: |u_r|/u_z at B.2 above B.1 and B.3, all three snapshots found
    (:func:`~biplan.reproduction.facts.snapshot_steps`)."""
    s = r.semi
    assert s is not None
    snaps = s.snapshots()

    def bend(k: int | None) -> float:
        if k is None:
            return float("nan")
        return float(abs(s.u_r[k]) / max(abs(s.u_z[k]), 1e-12))

    b1, b2, b3 = (bend(snaps.get(k)) for k in ("B.1", "B.2", "B.3"))
    checks = [b2 > b1, b2 > b3, len(snaps) == 3]
    return Finding(
        f"|u_r|/u_z: B.1 {fmt(b1)}, B.2 {fmt(b2)}, B.3 {fmt(b3)}",
        grade(checks),
        "bending dominant in the transformation (B.2 above B.1 and B.3), extension in phase 2, "
        f"all three snapshots found: {yes_no(checks)}",
    )


def _axis(ds: Any, var: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Values of ``var`` as (b, C) with the axes sorted ascending."""
    da = ds[var].transpose("b", "C").sortby("b").sortby("C")
    return np.asarray(da["b"]), np.asarray(da["C"]), np.asarray(da.values, dtype=float)


def _corner(a: np.ndarray, pick: Callable[[np.ndarray], Any]) -> tuple[int, int]:
    i, j = np.unravel_index(int(pick(a)), a.shape)
    return int(i), int(j)


def extension_trend(r: Results) -> Finding:
    """``fig3.A1.extension``: u_z/l₀ largest at the lowest b and C, falling along both."""
    b, c, uz = _axis(r.design_map, "u_z")
    i, j = _corner(uz, np.nanargmax)
    d_b = float(np.nanmean(np.diff(uz, axis=0))) if b.size > 1 else float("nan")
    d_c = float(np.nanmean(np.diff(uz, axis=1))) if c.size > 1 else float("nan")
    checks = [i == 0 and j == 0, d_b < 0, d_c < 0]
    return Finding(
        f"max u_z/l0 = {fmt(float(uz[i, j]))} at b = {b[i]:.3g}, C = {c[j]:.3g}; mean step "
        f"along b {fmt(d_b)}, along C {fmt(d_c)}",
        grade(checks),
        "maximum at the lowest b and C; decreasing in both b and C (oblique contours): "
        + yes_no(checks),
    )


def deflection_trend(r: Results) -> Finding:
    """``fig3.A1.deflection``: |u_r|/l₀ largest at the lowest b and C, smallest at
    the highest C and an inner b."""
    b, c, ur = _axis(r.design_map, "u_r")
    mag = np.abs(ur)
    i, j = _corner(mag, np.nanargmax)
    k, m = _corner(mag, np.nanargmin)
    checks = [i == 0 and j == 0, m == c.size - 1, 0 < k < b.size - 1]
    return Finding(
        f"max |u_r|/l0 = {fmt(float(mag[i, j]))} at b = {b[i]:.3g}, C = {c[j]:.3g}; "
        f"min {fmt(float(mag[k, m]))} at b = {b[k]:.3g}, C = {c[m]:.3g}",
        grade(checks),
        "maximum at the lowest b and C; minimum at the highest C and an intermediate b: "
        + yes_no(checks),
    )


def star(r: Results) -> Finding:
    """``fig3.A1.star``: the validated design's (b, C) inside the design map."""
    assert r.semi is not None
    b, c, _ = _axis(r.design_map, "u_z")
    sb, sc = round(r.semi.b, 3), round(r.semi.C, 3)
    checks = [b[0] <= sb <= b[-1], c[0] <= sc <= c[-1]]
    return Finding(
        f"star at b = {sb}, C = {sc}; map b ∈ [{b[0]:.3g}, {b[-1]:.3g}], "
        f"C ∈ [{c[0]:.3g}, {c[-1]:.3g}]",
        grade(checks),
        "the validated design lies inside the mapped plane (b, C): " + yes_no(checks),
    )


def stability_regimes(r: Results) -> Finding:
    """``fig3.A3.regimes``: monostable at high C and small U, multistable at low C
    and large U, a transition band or bistable points between."""
    ds = r.stability_map
    da = ds["regime"].transpose("C", "displacement").sortby("C").sortby("displacement")
    reg = np.asarray(da.values, dtype=float)
    band = (
        np.asarray(ds["transition"].values, dtype=bool)
        if "transition" in ds
        else np.zeros(reg.shape, dtype=bool)
    )
    corner_mono, corner_multi = reg[-1, 0], reg[0, -1]
    mixed = bool(band.any()) or bool(np.any(reg == 2))
    checks = [corner_mono == 1, corner_multi >= 3, mixed]
    names = {0: "none", 1: "mono", 2: "bi", 3: "multi"}

    def name(x: float) -> str:
        return names.get(int(x), "?") if np.isfinite(x) else "failed"

    return Finding(
        f"high C, small U/l0: {name(corner_mono)}; low C, large U/l0: {name(corner_multi)}; "
        f"{int(band.sum())} transition-band and {int(np.sum(reg == 2))} bistable points of "
        f"{reg.size}",
        grade(checks),
        "monostable at small displacement and high C, multistable at large displacement and "
        "low C, a transition region between: " + yes_no(checks),
    )


def within_band(r: Results) -> Finding:
    """``fig3.A2.band``: at most 25 % of the band points outside the median ± 1 SD band,
    and the band measured."""
    v = r.validation
    assert v is not None
    checks = [v.fraction_outside <= 0.25, not v.synthetic]
    return Finding(
        f"RMS {fmt(v.rms)} N; {v.fraction_outside:.0%} of {v.n_compared} band points outside "
        f"the median ± 1 SD band ({v.source})",
        grade(checks),
        "within the band over most of the range: "
        + ("yes" if checks[0] else "no")
        + (
            "; the band is synthetic (made from this model's own prediction with scatter), "
            "so it checks consistency, not the paper's measurements"
            if v.synthetic
            else "; measured specimens"
        ),
    )
