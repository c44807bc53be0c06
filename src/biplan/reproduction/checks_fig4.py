"""Checks of the claims of Fig. 4: the fully bistable MFT (its stable states, the states the
paper names, their pathways and the hierarchy of slope branches).

Each function reads :class:`~biplan.reproduction.facts.Results` (its ``states``) and returns a
:class:`~biplan.reproduction.grading.Finding`; :data:`biplan.reproduction.claims.CLAIMS` pairs
it with the paper's words.
"""

from __future__ import annotations

import numpy as np

from biplan.reproduction.facts import (
    PAPER_N_STATES,
    PAPER_PATHWAYS,
    PAPER_STATES,
    PAPER_SUB_BRANCH,
    Results,
)
from biplan.reproduction.grading import Finding, grade, grade_distance, yes_no

__all__ = ["hierarchy", "named_states", "pathways", "shared_branch", "state_count"]


def state_count(r: Results) -> Finding:
    """``fig4.count``: the stable states against the paper's 34 from 128 seeds (partly
    within 7)."""
    s = r.states
    assert s is not None
    n = len(s.labels)
    return Finding(
        f"{n} stable states from {s.n_seeds} seeds",
        grade_distance(abs(n - PAPER_N_STATES) + abs(s.n_seeds - 128), 0, 7),
        f"paper: {PAPER_N_STATES} of 128; the fully bistable laws are not given in the paper "
        "(inferred from Fig. 4 under the run's TPC sign; docs/fidelity.md)",
    )


def named_states(r: Results) -> Finding:
    """``fig4.A.named``: the states 00, 2A, 1B and 66 are stable."""
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


def shared_branch(r: Results) -> Finding:
    """``fig4.B.shared_branch``: 66 and 1B at |Θ| ≈ 2/3 on one sub-branch at u_z/l₀ ≈ 0.9,
    1B deflecting more."""
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
        "1B deflecting more: " + yes_no(checks),
    )


def pathways(r: Results) -> Finding:
    """``fig4.A.pathways``: the paper's pathways p1–p3 exist in the transition graph."""
    s = r.states
    assert s is not None
    found = {k: s.pathways.get(k) for k in PAPER_PATHWAYS}
    return Finding(
        "; ".join(f"{k}: {' → '.join(p) if p else 'none'}" for k, p in found.items()),
        grade([p is not None for p in found.values()]),
        "a pathway exists when both end states are stable and connected by single-fold "
        "transitions between stable states",
    )


def hierarchy(r: Results) -> Finding:
    """``fig4.C.hierarchy``: slope branches at k/3; branchwise RMS u_z/l₀ and u_r/l₀
    rising with |Θ| (correlation above 0.8)."""
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
        + yes_no(checks),
    )
