"""Objectives of a fold-law search against the paper's Fig. 4, their order and Pareto front.

Every law set of a search (:class:`~biplan.analysis.states.law_records.LawRecords`) gets five
objectives, all minimised, in the issue's order of importance:

1. ``named_missing`` — how many of 00, 2A, 1B, 66 are not stable (paper: none);
2. ``count_miss`` — |n − 34|, n the stable states (SI S11: 34 of 128 seeds);
3. ``target_miss`` — how far 66 and 1B are from the paper's sub-branch, in units of the
   reproduction's tolerances: max over both states of |u_z/l₀ − 0.9| / 0.05 and
   ||Θ| − 2/3| / 0.1 (≤ 1: both within the ``fig4.B.shared_branch`` check; ∞ when either
   is not stable);
4. ``thirds_miss`` — max over slope branches k ≥ 1 of ||mean Θ| − k/3| / 0.1 (≤ 1: levels in
   thirds as the ``fig4.C.hierarchy`` check reads them);
5. ``peaks_miss`` — |peaks of the u_z/l₀ distribution − 2| (SI S12: bimodal).

:func:`lexicographic` orders law sets by them in that order; :func:`pareto_front` keeps the
sets no other set beats in every objective (ordered lexicographically); :func:`parents` picks
the centres of a local refinement; :func:`influence` says which coefficients move an outcome
most (the correlation ratio η² of binned means). Rows whose search did not run get ∞.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from biplan._errors import check_integer
from biplan.analysis.states.law_records import PAPER_N_STATES, PAPER_SUB_BRANCH, LawRecords

__all__ = [
    "OBJECTIVES",
    "Fig4Targets",
    "influence",
    "lexicographic",
    "objectives",
    "parents",
    "pareto_front",
]

#: Names of the columns of :func:`objectives`, most important first.
OBJECTIVES = ("named_missing", "count_miss", "target_miss", "thirds_miss", "peaks_miss")


@dataclass(frozen=True)
class Fig4Targets:
    """The paper's numbers and the reproduction's tolerances the objectives measure against.

    Attributes
    ----------
    n_states : int
        Stable states (SI S11).
    sub_branch : float
        u_z/l₀ of 66 and 1B (main text, Fig. 4 B).
    slope : float
        |Θ| of 66 and 1B (the Θ = 0.67 branch).
    elongation_peaks : int
        Peaks of the elongation distribution (SI S12).
    u_z_tolerance, slope_tolerance : float
        The tolerances of the claim checks (u_z/l₀ ± 0.05; Θ and the thirds ± 0.1).
    """

    n_states: int = PAPER_N_STATES
    sub_branch: float = PAPER_SUB_BRANCH
    slope: float = 2 / 3
    elongation_peaks: int = 2
    u_z_tolerance: float = 0.05
    slope_tolerance: float = 0.1


def objectives(records: LawRecords, targets: Fig4Targets | None = None) -> np.ndarray:
    """The five objectives (n, 5) of :data:`OBJECTIVES` (module docstring); ∞ where a law set
    was not searched or a quantity is missing."""
    t = targets or Fig4Targets()
    n = len(records)
    out = np.full((n, len(OBJECTIVES)), np.inf)
    ok = records.ok
    with np.errstate(invalid="ignore"):
        out[:, 0] = np.where(ok, records.named.shape[1] - records.named.sum(axis=1), np.inf)
        out[:, 1] = np.where(ok, np.abs(records.n_states - t.n_states), np.inf)
        uz = np.abs(records.u_z_rel - t.sub_branch) / t.u_z_tolerance
        th = np.abs(np.abs(records.Theta) - t.slope) / t.slope_tolerance
        miss = np.concatenate([uz, th], axis=1).max(axis=1)
        out[:, 2] = np.where(ok & np.isfinite(miss), miss, np.inf)
        thirds = records.thirds_error / t.slope_tolerance
        out[:, 3] = np.where(ok & np.isfinite(thirds), thirds, np.inf)
        out[:, 4] = np.where(ok, np.abs(records.n_u_z_peaks - t.elongation_peaks), np.inf)
    return out


def lexicographic(obj: np.ndarray) -> np.ndarray:
    """Row indices sorted by the objectives in column order (ties: lower index first)."""
    obj = np.asarray(obj, dtype=float)
    keys = (np.arange(len(obj)), *(obj[:, j] for j in reversed(range(obj.shape[1]))))
    return np.lexsort(keys)


def pareto_front(obj: np.ndarray, finite: bool = True) -> np.ndarray:
    """Indices of the rows no other row dominates (≤ in every objective, < in one), in
    lexicographic order; ``finite``: only rows whose first two objectives are finite (searched).

    A row can only be dominated by one before it in lexicographic order, so one pass over that
    order finds the front."""
    obj = np.asarray(obj, dtype=float)
    front: list[int] = []
    for i in lexicographic(obj):
        x = obj[i]
        if finite and not np.all(np.isfinite(x[:2])):
            continue
        if front:
            f = obj[front]
            if np.any(np.all(f <= x, axis=1) & np.any(f < x, axis=1)):
                continue
        front.append(int(i))
    return np.asarray(front, dtype=int)


def parents(obj: np.ndarray, k: int) -> np.ndarray:
    """Centres of a local refinement: for every objective after the first, the lexicographically
    best row among those best in the first (all named states stable, if any), then the front in
    lexicographic order, until ``k`` distinct rows."""
    check_integer("parents", k, low=1)
    obj = np.asarray(obj, dtype=float)
    front = pareto_front(obj)
    if front.size == 0:
        return front
    best_first = obj[front, 0].min()
    pool = front[obj[front, 0] == best_first]
    chosen: list[int] = []
    for j in range(1, obj.shape[1]):
        order = pool[lexicographic(np.column_stack([obj[pool, j], obj[pool]]))]
        if order.size and int(order[0]) not in chosen:
            chosen.append(int(order[0]))
    for i in front:
        if len(chosen) >= k:
            break
        if int(i) not in chosen:
            chosen.append(int(i))
    return np.asarray(chosen[:k], dtype=int)


def influence(unit: np.ndarray, y: np.ndarray, bins: int = 8) -> np.ndarray:
    """How much of the variance of ``y`` each input explains alone: the correlation ratio
    η²_i = Var(E[y | bin of x_i]) / Var(y) over ``bins`` equal bins of the unit-cube
    coordinate x_i (a first-order sensitivity index of a space-filling design). Rows where
    ``y`` is not finite are left out; 0 where ``y`` does not vary.

    Parameters
    ----------
    unit : ndarray (n, d)
        Inputs in [0, 1].
    y : ndarray (n,)
    bins : int

    Returns
    -------
    ndarray (d,)
    """
    check_integer("bins", bins, low=2)
    keep = np.isfinite(y)
    u, y = np.asarray(unit, dtype=float)[keep], np.asarray(y, dtype=float)[keep]
    total = float(np.var(y)) if y.size else 0.0
    out = np.zeros(u.shape[1])
    if total == 0.0:
        return out
    for j in range(u.shape[1]):
        b = np.clip((u[:, j] * bins).astype(int), 0, bins - 1)
        counts = np.bincount(b, minlength=bins)
        sums = np.bincount(b, weights=y, minlength=bins)
        used = counts > 0
        means = sums[used] / counts[used]
        out[j] = float(np.sum(counts[used] * (means - y.mean()) ** 2) / y.size / total)
    return out
