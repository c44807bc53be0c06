"""The paper's claims, each assessed from computed results (``biplan reproduce``).

Every quantitative or qualitative claim of the paper that the model can speak to is a
:class:`Claim` of :data:`CLAIMS`: an id, the figure and section it belongs to, the paper's words
(paraphrased) and a function that reads the computed :class:`Results` and returns a
:class:`Finding` — our number or observation, a :class:`Verdict` and the reason.

Verdicts are never typed: every claim function derives its verdict with :func:`grade` (from a
list of computed pass/fail checks) or :func:`grade_distance` (from a computed distance to the
paper's value). A claim whose input stage failed or did not run is reported as ``not`` with
the stage's error (:func:`assess`). :func:`report_markdown` renders the report, one table per
figure, with links to the figure files.

Slopes Θ and deflections u_r are compared by magnitude: the model's sign convention for θ
and u_r (negative for the paper's positive bending) is a choice of axes, not physics.

The results are plain numbers and arrays (the ``*Facts`` dataclasses and two map datasets) so
that a claim can be checked against any input, including hand-made ones in the tests.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from biplan.analysis.response.summary import phase_one_end, softening_steps

__all__ = [
    "CLAIMS",
    "FIGURES",
    "Assessment",
    "CalibrationFacts",
    "Claim",
    "Finding",
    "MovieFacts",
    "Results",
    "SemiBistableFacts",
    "StateFacts",
    "ValidationFacts",
    "Verdict",
    "assess",
    "grade",
    "grade_distance",
    "report_markdown",
]

#: The paper's terminal force of the ramp and the transition [N].
RAMP_FORCE = 1.6
#: The paper's geometric ratio of the validated design (Fig. 3 A.3: b = 0.58).
PAPER_B = 0.58
#: The paper's number of stable states of the four-module fully bistable MFT (SI S11).
PAPER_N_STATES = 34
#: The paper's u_z/l0 of the iso-elongation sub-branch of 66 and 1B (main text, Fig. 4 B).
PAPER_SUB_BRANCH = 0.9
#: The paper's states named in the main text (Fig. 4 A–B).
PAPER_STATES = ("00", "2A", "1B", "66")
#: The paper's pathways (start, target).
PAPER_PATHWAYS = {"p1": ("2A", "66"), "p2": ("2A", "1B"), "p3": ("66", "00")}


class Verdict(enum.StrEnum):
    """How far a claim is reproduced."""

    REPRODUCED = "reproduced"
    PARTLY = "partly"
    NOT = "not"


def grade(checks: Sequence[bool]) -> Verdict:
    """All checks pass: reproduced; some: partly; none (or no checks): not."""
    passed = sum(bool(c) for c in checks)
    if checks and passed == len(checks):
        return Verdict.REPRODUCED
    return Verdict.PARTLY if passed else Verdict.NOT


def grade_distance(distance: float, exact: float, near: float) -> Verdict:
    """Reproduced when ``distance ≤ exact``, partly when ``≤ near``, else (or NaN) not."""
    d = float(distance)
    return grade([d <= exact, d <= near]) if np.isfinite(d) else grade([])


@dataclass(frozen=True)
class Finding:
    """What a claim function returns: our value, the verdict and why."""

    value: str
    verdict: Verdict
    reason: str


# --- the results the claims read -------------------------------------------------------------
@dataclass(frozen=True)
class SemiBistableFacts:
    """The validated semi-bistable design under displacement control (stable-branch sweep).

    Attributes
    ----------
    b, C : float
        Geometric and stiffness ratio of the design.
    initial_length : float
        l₀ [mm].
    displacement, force, u_z, u_r, theta : ndarray
        Per sweep step [mm, N, mm, mm, rad]; NaN where a step failed.
    stable, switched : ndarray of bool
        Stable equilibrium; the step left an unstable state for a stable one (a snap).
    spinodal : ndarray (step, circular fold), optional
        Fraction of each circular fold's length on its spinodal branch (NaN at failed steps).
    """

    b: float
    C: float
    initial_length: float
    displacement: np.ndarray
    force: np.ndarray
    u_z: np.ndarray
    u_r: np.ndarray
    theta: np.ndarray
    stable: np.ndarray
    switched: np.ndarray
    spinodal: np.ndarray | None = None

    #: A fold counts as transforming when more than this fraction of it is on the spinodal.
    ONSET_FRACTION = 0.05

    @property
    def onset_spread(self) -> int:
        """Circular folds partly on their spinodal branch at the last phase-1 step, just before
        the first snap (0 without ``spinodal`` data or a phase 1)."""
        last = self.phase_one.stop - 1
        if self.spinodal is None or last < 0:
            return 0
        return int(np.sum(np.asarray(self.spinodal)[last] > self.ONSET_FRACTION))

    @property
    def phase_one(self) -> slice:
        """Steps before the first irregular one: the first snap, failure, instability or fall
        of the force along stable states
        (:func:`biplan.analysis.response.summary.phase_one_end`)."""
        return slice(0, phase_one_end(self.force, self.stable, self.switched))

    @property
    def snaps(self) -> np.ndarray:
        """Indices of the steps that snapped."""
        return np.flatnonzero(self.switched)

    def snapshots(self) -> dict[str, int]:
        """Steps of the B panels: B.1 phase 1 (half the phase-1 peak force), B.2 the middle
        of the transformation (between the first and the last snap), B.3 phase 2 (last
        converged step); only those that exist."""
        out: dict[str, int] = {}
        p1 = np.arange(self.force.size)[self.phase_one]
        if p1.size:
            peak = float(np.max(self.force[p1]))
            out["B.1"] = int(p1[np.argmin(np.abs(self.force[p1] - 0.5 * peak))])
        snaps = self.snaps
        if snaps.size:
            out["B.2"] = int((snaps[0] + snaps[-1]) // 2)
            ok = np.flatnonzero(np.isfinite(self.force))
            if ok.size and ok[-1] > snaps[-1]:
                out["B.3"] = int(ok[-1])
        return out


@dataclass(frozen=True)
class ValidationFacts:
    """The predicted force–displacement curve against the measured band (Fig. 3 A.2)."""

    rms: float
    fraction_outside: float
    n_compared: int
    synthetic: bool
    source: str


@dataclass(frozen=True)
class StateFacts:
    """Stable states of the fully bistable MFT and their hierarchy (Fig. 4, SI S11–S12).

    Attributes
    ----------
    n_seeds : int
    labels : tuple of str
        Paper label of every state (two hex digits).
    u_z, u_r, Theta : ndarray
        Per state: u_z/l₀, u_r/l₀ and Θ = θ/max|θ|.
    n_open_helical, n_open_circular : ndarray of int
        Per state: the slope branch and the sub-branch.
    theta_bins, theta_counts, u_z_bins, u_z_counts, u_r_bins, u_r_counts : ndarray
        State-count distributions (bin centres, counts).
    branch_theta, branch_rms_u_z, branch_rms_u_r : ndarray
        Per slope branch (open helical folds ``branches``): mean Θ and RMS u_z/l₀, u_r/l₀.
    branches : ndarray of int
    pathways : dict
        Paper pathway name → the states along it, or None when it does not exist.
    """

    n_seeds: int
    labels: tuple[str, ...]
    u_z: np.ndarray
    u_r: np.ndarray
    Theta: np.ndarray
    n_open_helical: np.ndarray
    n_open_circular: np.ndarray
    theta_bins: np.ndarray
    theta_counts: np.ndarray
    u_z_bins: np.ndarray
    u_z_counts: np.ndarray
    u_r_bins: np.ndarray
    u_r_counts: np.ndarray
    branches: np.ndarray
    branch_theta: np.ndarray
    branch_rms_u_z: np.ndarray
    branch_rms_u_r: np.ndarray
    pathways: Mapping[str, tuple[str, ...] | None]

    def index(self, label: str) -> int | None:
        """Index of the (first) state with this label, or None."""
        return self.labels.index(label) if label in self.labels else None


@dataclass(frozen=True)
class CalibrationFacts:
    """A CFT calibration against the law that generated (or is expected for) the specimens.

    Attributes
    ----------
    kind : str
        ``trilinear`` or ``linear``.
    estimates : dict
        Parameter name → (value, low, high) (bootstrap interval; NaN bounds without).
    truth : dict
        Parameter name → the reference value (SI Table calib).
    rms, noise : float
        RMS fit residual and the specimens' force noise SD [N] (NaN if unknown).
    synthetic : bool
        The specimens were generated, not measured.
    """

    kind: str
    estimates: Mapping[str, tuple[float, float, float]]
    truth: Mapping[str, float]
    rms: float
    noise: float
    synthetic: bool


@dataclass(frozen=True)
class MovieFacts:
    """The Movie S1 analogue: frames written and what the animated history shows."""

    file: str
    n_frames: int
    lost_stability: bool
    final_force: float


@dataclass
class Results:
    """Everything the claims read; a stage that failed leaves its field None and its error."""

    semi: SemiBistableFacts | None = None
    design_map: Any = None
    instability_map: Any = None
    stability_map: Any = None
    validation: ValidationFacts | None = None
    states: StateFacts | None = None
    calibration: tuple[CalibrationFacts, ...] | None = None
    movie: MovieFacts | None = None
    errors: dict[str, str] = field(default_factory=dict)


# --- the claims ------------------------------------------------------------------------------
def _fmt(x: float, digits: int = 3) -> str:
    return f"{x:.{digits}g}" if np.isfinite(x) else "—"


def _design_ratios(r: Results) -> Finding:
    s = r.semi
    assert s is not None
    d = abs(s.b - PAPER_B)
    return Finding(
        f"b = {s.b:.3f}, C = {s.C:.3f}",
        grade_distance(d, 0.01, 0.05),
        f"|b − {PAPER_B}| = {d:.3f} (SI Table calib gives β = 60°, H and l; the paper rounds b"
        " to 0.58 and states no value of C, which follows from the table's laws)",
    )


def _two_phases(r: Results) -> Finding:
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


def _within_ramp(r: Results) -> Finding:
    s = r.semi
    assert s is not None
    p1 = np.arange(s.force.size)[s.phase_one]
    peak = float(np.max(s.force[p1])) if p1.size else float("nan")
    excess = peak - RAMP_FORCE
    return Finding(
        f"first loss of stability at F = {_fmt(peak, 4)} N",
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
        f"lowest F* = {_fmt(float(f[i, j]), 3)} N at b = {b[i]:.3g}, C = {c[j]:.3g}"
    )
    if inside.any():
        text += f" (all at C ≤ {c[np.flatnonzero(inside.any(axis=0)).max()]:.3g})"
    return text


def _distributed(r: Results) -> Finding:
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
        "in one passage, not fold by fold: " + "/".join("yes" if c else "no" for c in checks),
    )


def _eccentric_bending(r: Results) -> Finding:
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
        f"end of phase 1: |u_r|/l0 = {_fmt(last_ur)}, |θ| = {_fmt(last_th)} rad; "
        f"corr(F, |u_r|) = {_fmt(corr)}",
        grade(checks),
        "deflection, slope and their growth with F in phase 1: "
        + "/".join("yes" if c else "no" for c in checks),
    )


def _snapshot_modes(r: Results) -> Finding:
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
        f"|u_r|/u_z: B.1 {_fmt(b1)}, B.2 {_fmt(b2)}, B.3 {_fmt(b3)}",
        grade(checks),
        "bending dominant in the transformation (B.2 above B.1 and B.3), extension in phase 2, "
        f"all three snapshots found: {'/'.join('yes' if c else 'no' for c in checks)}",
    )


def _axis(ds: Any, var: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Values of ``var`` as (b, C) with the axes sorted ascending."""
    da = ds[var].transpose("b", "C").sortby("b").sortby("C")
    return np.asarray(da["b"]), np.asarray(da["C"]), np.asarray(da.values, dtype=float)


def _corner(a: np.ndarray, pick: Callable[[np.ndarray], Any]) -> tuple[int, int]:
    i, j = np.unravel_index(int(pick(a)), a.shape)
    return int(i), int(j)


def _extension_trend(r: Results) -> Finding:
    b, c, uz = _axis(r.design_map, "u_z")
    i, j = _corner(uz, np.nanargmax)
    d_b = float(np.nanmean(np.diff(uz, axis=0))) if b.size > 1 else float("nan")
    d_c = float(np.nanmean(np.diff(uz, axis=1))) if c.size > 1 else float("nan")
    checks = [i == 0 and j == 0, d_b < 0, d_c < 0]
    return Finding(
        f"max u_z/l0 = {_fmt(float(uz[i, j]))} at b = {b[i]:.3g}, C = {c[j]:.3g}; mean step "
        f"along b {_fmt(d_b)}, along C {_fmt(d_c)}",
        grade(checks),
        "maximum at the lowest b and C; decreasing in both b and C (oblique contours): "
        + "/".join("yes" if x else "no" for x in checks),
    )


def _deflection_trend(r: Results) -> Finding:
    b, c, ur = _axis(r.design_map, "u_r")
    mag = np.abs(ur)
    i, j = _corner(mag, np.nanargmax)
    k, m = _corner(mag, np.nanargmin)
    checks = [i == 0 and j == 0, m == c.size - 1, 0 < k < b.size - 1]
    return Finding(
        f"max |u_r|/l0 = {_fmt(float(mag[i, j]))} at b = {b[i]:.3g}, C = {c[j]:.3g}; "
        f"min {_fmt(float(mag[k, m]))} at b = {b[k]:.3g}, C = {c[m]:.3g}",
        grade(checks),
        "maximum at the lowest b and C; minimum at the highest C and an intermediate b: "
        + "/".join("yes" if x else "no" for x in checks),
    )


def _star(r: Results) -> Finding:
    assert r.semi is not None
    b, c, _ = _axis(r.design_map, "u_z")
    sb, sc = round(r.semi.b, 3), round(r.semi.C, 3)
    checks = [b[0] <= sb <= b[-1], c[0] <= sc <= c[-1]]
    return Finding(
        f"star at b = {sb}, C = {sc}; map b ∈ [{b[0]:.3g}, {b[-1]:.3g}], "
        f"C ∈ [{c[0]:.3g}, {c[-1]:.3g}]",
        grade(checks),
        "the validated design lies inside the mapped plane (b, C): "
        + "/".join("yes" if x else "no" for x in checks),
    )


def _stability_regimes(r: Results) -> Finding:
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
        "low C, a transition region between: " + "/".join("yes" if x else "no" for x in checks),
    )


def _within_band(r: Results) -> Finding:
    v = r.validation
    assert v is not None
    checks = [v.fraction_outside <= 0.25, not v.synthetic]
    return Finding(
        f"RMS {_fmt(v.rms)} N; {v.fraction_outside:.0%} of {v.n_compared} band points outside "
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


def _state_count(r: Results) -> Finding:
    s = r.states
    assert s is not None
    n = len(s.labels)
    return Finding(
        f"{n} stable states from {s.n_seeds} seeds",
        grade_distance(abs(n - PAPER_N_STATES) + abs(s.n_seeds - 128), 0, 7),
        f"paper: {PAPER_N_STATES} of 128; the fully bistable laws are not given in the paper "
        "(inferred from its u_z/l0 of 66 and 1B; docs/fidelity.md)",
    )


def _named_states(r: Results) -> Finding:
    s = r.states
    assert s is not None
    present = [lab in s.labels for lab in PAPER_STATES]
    return Finding(
        "stable: "
        + ", ".join(
            f"{lab} {'yes' if p else 'no'}" for lab, p in zip(PAPER_STATES, present, strict=True)
        ),
        grade(present),
        f"{sum(present)} of the paper's {len(PAPER_STATES)} named states are stable",
    )


def _shared_branch(r: Results) -> Finding:
    s = r.states
    assert s is not None
    i, j = s.index("66"), s.index("1B")
    if i is None or j is None:
        missing = [lab for lab, k in (("66", i), ("1B", j)) if k is None]
        return Finding(
            f"{' and '.join(missing)} not stable", grade([]), "the states to compare are missing"
        )
    checks = [
        abs(abs(s.Theta[i]) - 2 / 3) < 0.1,
        abs(abs(s.Theta[j]) - 2 / 3) < 0.1,
        s.n_open_circular[i] == s.n_open_circular[j] and abs(s.u_z[i] - s.u_z[j]) < 0.05,
        abs(s.u_z[i] - PAPER_SUB_BRANCH) < 0.05 and abs(s.u_z[j] - PAPER_SUB_BRANCH) < 0.05,
        abs(s.u_r[j]) > abs(s.u_r[i]),
    ]
    return Finding(
        f"66: Θ = {s.Theta[i]:.2f}, u_z/l0 = {s.u_z[i]:.3f}, u_r/l0 = {s.u_r[i]:.3f}; "
        f"1B: Θ = {s.Theta[j]:.2f}, u_z/l0 = {s.u_z[j]:.3f}, u_r/l0 = {s.u_r[j]:.3f}",
        grade(checks),
        "66 and 1B at Θ ≈ 0.67, one iso-elongation sub-branch, at u_z/l0 = 0.9 (± 0.05), "
        "1B deflecting more: " + "/".join("yes" if c else "no" for c in checks),
    )


def _slope_peak(r: Results) -> Finding:
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


def _n_peaks(counts: np.ndarray) -> int:
    """Local maxima of a histogram (a plateau counts once; zero bins are no peak)."""
    c = np.asarray(counts, dtype=float)
    keep = np.r_[True, np.diff(c) != 0]  # collapse plateaus
    v = c[keep]
    padded = np.r_[-1.0, v, -1.0]
    return int(np.sum((v > padded[:-2]) & (v > padded[2:]) & (v > 0)))


def _elongation_bimodal(r: Results) -> Finding:
    s = r.states
    assert s is not None
    n = _n_peaks(s.u_z_counts)
    return Finding(
        f"{n} peak(s) in the u_z/l0 distribution ({len(s.labels)} states)",
        grade_distance(abs(n - 2), 0, 1),
        "paper: bimodal (two iso-elongation groups)",
    )


def _deflection_peaks(r: Results) -> Finding:
    s = r.states
    assert s is not None
    c, x = s.u_r_counts, s.u_r_bins
    if c.size == 0 or c.max() == 0:
        return Finding("no states", grade([]), "no deflection distribution")
    width = float(np.median(np.diff(x))) if x.size > 1 else 1.0
    mode = float(x[int(np.argmax(c))])
    in_band = (np.abs(s.u_r) >= 1 / 8) & (np.abs(s.u_r) <= 5 / 8)
    bins_in = (np.abs(x) >= 1 / 8 - width / 2) & (np.abs(x) <= 5 / 8 + width / 2)
    secondary = bool(in_band.any()) and _n_peaks(np.where(bins_in, c, 0)) >= 1
    checks = [abs(mode) <= max(width, 1 / 16), secondary]
    return Finding(
        f"mode at u_r/l0 = {mode:.3f}; {int(in_band.sum())} states with u_r/l0 in [1/8, 5/8]",
        grade(checks),
        "dominant peak near zero; secondary band in [1/8, 5/8]: "
        + "/".join("yes" if c else "no" for c in checks),
    )


def _pathways(r: Results) -> Finding:
    s = r.states
    assert s is not None
    found = {k: s.pathways.get(k) for k in PAPER_PATHWAYS}
    return Finding(
        "; ".join(f"{k}: {' → '.join(p) if p else 'none'}" for k, p in found.items()),
        grade([p is not None for p in found.values()]),
        "a pathway exists when both end states are stable and connected by single-fold "
        "transitions between stable states",
    )


def _hierarchy(r: Results) -> Finding:
    s = r.states
    assert s is not None
    k, th = np.asarray(s.branches, dtype=float), np.abs(np.asarray(s.branch_theta, dtype=float))
    on_thirds = k.size > 1 and bool(np.all(np.abs(th[k > 0] - k[k > 0] / 3) < 0.1))

    def rising(y: np.ndarray) -> bool:
        if k.size < 3 or not np.all(np.isfinite(y)) or np.ptp(y) == 0:
            return False
        return bool(np.corrcoef(th, y)[0, 1] > 0.8)

    checks = [on_thirds, rising(np.asarray(s.branch_rms_u_z)), rising(np.asarray(s.branch_rms_u_r))]
    levels = ", ".join(f"{int(a)}: {b:.2f}" for a, b in zip(k, th, strict=True))
    return Finding(
        f"slope branch (open helical folds: mean Θ) {levels or 'none'}",
        grade(checks),
        "slope levels at k/3; branchwise RMS elongation and deflection rising with slope: "
        + "/".join("yes" if c else "no" for c in checks),
    )


def _calibration(r: Results) -> Finding:
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


def _movie(r: Results) -> Finding:
    m = r.movie
    assert m is not None
    checks = [m.n_frames >= 10, m.lost_stability]
    return Finding(
        f"{m.n_frames} frames ({m.file}), to F = {_fmt(m.final_force)} N",
        grade(checks),
        "development and cylinder animated; the animated force ramp "
        + ("passes through" if m.lost_stability else "does not reach")
        + " the transition (the paper's movie shows the full transformation); no experimental "
        "panel",
    )


@dataclass(frozen=True)
class Claim:
    """One claim of the paper.

    Attributes
    ----------
    id : str
        Short identifier (``fig3.A1.extension``).
    figure : str
        Key of :data:`FIGURES` whose table lists it.
    section : str
        Where the paper says it.
    paper : str
        The paper's words, paraphrased.
    needs : tuple of str
        The :class:`Results` fields it reads.
    check : callable
        ``Results -> Finding``.
    """

    id: str
    figure: str
    section: str
    paper: str
    needs: tuple[str, ...]
    check: Callable[[Results], Finding]


#: Figure keys → title of the table in the report.
FIGURES = {
    "fig3": "Fig. 3 — semi-bistable MFT (validated design, design and stability maps)",
    "fig4": "Fig. 4 — fully bistable MFT (states, transitions, hierarchy)",
    "si": "Supplement — distributions, CFT calibration, Movie S1",
}

_MAIN3 = "Main, Semi-bistable MFT"
_MAIN4 = "Main, Hierarchical state space"
CLAIMS: tuple[Claim, ...] = (
    Claim("fig3.design", "fig3", "Main Fig. 3; SI Table calib",
          "The validated semi-bistable design has b ≈ 0.58 (stability map at b = 0.58) and "
          "the stiffness ratio C of Table calib.", ("semi",), _design_ratios),
    Claim("fig3.A2.phases", "fig3", _MAIN3 + " (Fig. 3 A.2)",
          "The response is a transition between two stable phases through an intermediate "
          "spinodal regime with loss of tangent stiffness.", ("semi",), _two_phases),
    Claim("fig3.A2.within_ramp", "fig3", _MAIN3 + "; SI Design maps",
          "The phase transformation happens within the 0.8 N/s × 2 s force ramp (1.6 N).",
          ("semi",), _within_ramp),
    Claim("fig3.distributed", "fig3", _MAIN3 + " (closing paragraph)",
          "Coupling to the monostable helical folds distributes the phase transformation "
          "along the tube (compliant, not fold by fold).", ("semi",), _distributed),
    Claim("fig3.B1.eccentric", "fig3", _MAIN3 + " (Fig. 3 B.1)",
          "In phase 1 the circular folds extend non-uniformly around the circumference, "
          "driving global eccentric bending.", ("semi",), _eccentric_bending),
    Claim("fig3.B.modes", "fig3", _MAIN3 + " (Fig. 3 B.1–B.3)",
          "Bending dominates in the spinodal regime (B.2); phase 2 restores dominant "
          "extension (B.3).", ("semi",), _snapshot_modes),
    Claim("fig3.A1.extension", "fig3", _MAIN3 + " (Fig. 3 A.1 top)",
          "Extension is largest at low b and low C; the contours are oblique.",
          ("design_map",), _extension_trend),
    Claim("fig3.A1.deflection", "fig3", _MAIN3 + " (Fig. 3 A.1 bottom)",
          "Radial deflection is largest at low b and C and smallest at high C and "
          "intermediate b.", ("design_map",), _deflection_trend),
    Claim("fig3.A1.star", "fig3", _MAIN3 + " (Fig. 3 A.1)",
          "A star marks the experimentally validated design on the maps.",
          ("design_map", "semi"), _star),
    Claim("fig3.A3.regimes", "fig3", _MAIN3 + " (Fig. 3 A.3)",
          "At b = 0.58: monostable at small displacement and high C, multistable at large "
          "displacement and low C, separated by a transition region.",
          ("stability_map",), _stability_regimes),
    Claim("fig3.A2.band", "fig3", _MAIN3 + " (Fig. 3 A.2)",
          "The predicted force–displacement curve stays within the measured ± 1 SD band over "
          "most of the range.", ("validation",), _within_band),
    Claim("fig4.count", "fig4", "SI S11 (transition diagram)",
          "The 128 seeds of the four-module tube yield 34 stable equilibria.",
          ("states",), _state_count),
    Claim("fig4.A.named", "fig4", _MAIN4 + " (Fig. 4 A)",
          "States 00, 2A, 1B and 66 are stable.", ("states",), _named_states),
    Claim("fig4.B.shared_branch", "fig4", _MAIN4 + " (Fig. 4 B)",
          "66 and 1B lie on the Θ ≈ 0.67 slope branch, in one iso-elongation sub-branch "
          "(u_z/l0 = 0.9), with 1B deflecting more.", ("states",), _shared_branch),
    Claim("fig4.A.pathways", "fig4", _MAIN4 + " (Fig. 4 A, D)",
          "Pathways p1 (2A → 66), p2 (2A → 1B) and p3 (→ 00) exist in the transition graph.",
          ("states",), _pathways),
    Claim("fig4.C.hierarchy", "fig4", _MAIN4 + " (Fig. 4 B–C)",
          "Open helical folds set equally spaced slope branches; branchwise RMS elongation "
          "and deflection increase about linearly with slope.", ("states",), _hierarchy),
    Claim("si.dist.slope", "si", "SI S12 (distributions)",
          "The slope distribution is unimodal and peaks near Θ = 1/3.",
          ("states",), _slope_peak),
    Claim("si.dist.elongation", "si", "SI S12 (distributions)",
          "The elongation distribution is bimodal.", ("states",), _elongation_bimodal),
    Claim("si.dist.deflection", "si", "SI S12 (distributions)",
          "The deflection distribution has a dominant peak near zero and a smaller secondary "
          "peak over u_r/l0 ∈ [1/8, 5/8].", ("states",), _deflection_peaks),
    Claim("si.cft", "si", "SI S10 (Experimental calibration)",
          "Linear least-squares fits of the median CFT responses give the trilinear circular "
          "and linear helical laws of Table calib.", ("calibration",), _calibration),
    Claim("si.movie", "si", "SI Movie S1",
          "The modelled response of the semi-bistable MFT under actuation, in the planar "
          "development and the reconstructed cylinder.", ("movie",), _movie),
)  # fmt: skip


# --- assessment and report -------------------------------------------------------------------
@dataclass(frozen=True)
class Assessment:
    """A claim with its finding."""

    claim: Claim
    finding: Finding


def assess(results: Results, claims: Sequence[Claim] = CLAIMS) -> list[Assessment]:
    """Run every claim on ``results``.

    A claim whose input is missing (its stage failed or did not run) is ``not`` reproduced,
    with the stage's error as the reason; a claim function that raises is reported likewise.
    """
    out = []
    for c in claims:
        missing = [n for n in c.needs if getattr(results, n) is None]
        if missing:
            why = "; ".join(f"{n}: {results.errors.get(n, 'not run')}" for n in missing)
            finding = Finding("not computed", grade([]), f"stage failed — {why}")
        else:
            try:
                finding = c.check(results)
            except Exception as err:  # a broken claim must not stop the report
                finding = Finding("error", grade([]), f"{type(err).__name__}: {err}")
        out.append(Assessment(c, finding))
    return out


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def report_markdown(
    assessments: Sequence[Assessment],
    figures: Mapping[str, Sequence[str]],
    *,
    command: str,
    errors: Mapping[str, str],
    timings: Mapping[str, float],
    notes: Sequence[str] = (),
) -> str:
    """The text of ``REPRODUCTION.md``.

    Parameters
    ----------
    assessments : sequence of Assessment
    figures : mapping
        Figure key of :data:`FIGURES` → file names (relative to the report) to link.
    command : str
        The command line that produced the results.
    errors, timings : mapping
        Stage → error message; stage → seconds.
    notes : sequence of str
        Extra lines for the header (settings of the run).
    """
    counts = {v: sum(a.finding.verdict is v for a in assessments) for v in Verdict}
    lines = [
        "# Reproduction of the paper's claims",
        "",
        f"Generated by `{command}`. Every verdict below is computed from the results of this "
        "run by the claim's function in `biplan.reproduction.claims` (never typed).",
        "",
        f"**Summary:** {len(assessments)} claims — "
        + ", ".join(f"{counts[v]} {v.value}" for v in Verdict)
        + ".",
        "",
        *notes,
    ]
    if notes:
        lines.append("")
    for key, title in FIGURES.items():
        rows = [a for a in assessments if a.claim.figure == key]
        lines += [f"## {title}", ""]
        files = figures.get(key, ())
        if files:
            lines += ["Figures: " + ", ".join(f"[{f}]({f})" for f in files), ""]
        lines += [
            "| id | section | paper (paraphrased) | ours | verdict | reason |",
            "|---|---|---|---|---|---|",
        ]
        for a in rows:
            c, f = a.claim, a.finding
            lines.append(
                f"| `{c.id}` | {_cell(c.section)} | {_cell(c.paper)} | {_cell(f.value)} | "
                f"**{f.verdict.value}** | {_cell(f.reason)} |"
            )
        lines.append("")
    lines += ["## Stages", "", "| stage | seconds | outcome |", "|---|---|---|"]
    for stage, seconds in timings.items():
        outcome = f"failed: {_cell(errors[stage])}" if stage in errors else "ok"
        lines.append(f"| {stage} | {seconds:.1f} | {outcome} |")
    lines.append("")
    return "\n".join(lines)
