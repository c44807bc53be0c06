"""The settings of the stability map's equilibrium search and its bookkeeping.

:class:`StabilitySearch` holds the settings of the search at one map point (Newton, seeding,
continuation; :mod:`biplan.analysis.maps.stability_map` describes the search). The converged
solutions found at the points of a group are collected by :class:`Solutions`, which keeps
their distinct equilibria (lowest energy first) by the one closeness test
:func:`same_equilibrium`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan._errors import ConfigError, check_integer, check_range
from biplan.analysis.maps.stability_seeds import MAX_SUBSET_FOLDS, Seeding
from biplan.solvers.newton import Newton
from biplan.solvers.observation import STABILITY_TOL

__all__ = [
    "MAX_SUBSET_FOLDS",
    "Continuation",
    "Solutions",
    "StabilitySearch",
    "same_equilibrium",
]


class Continuation(enum.StrEnum):
    """How :class:`StabilitySearch` carries equilibria between the points of a row."""

    MARCH = "march"  #: point by point along the displacement axis, forward then backward
    NEIGHBOURS = "neighbours"  #: one pass from the two neighbouring points


@dataclass(frozen=True)
class StabilitySearch:
    """Settings of the equilibrium search at one map point.

    Parameters
    ----------
    max_equilibria : int
        Length of the padded ``equilibrium`` dimension (the lowest-energy distinct equilibria
        are kept; the counts include all), ≥ 1.
    distinct_tol : float
        Two solutions are the same equilibrium when no coordinate differs by more [mm, rad].
    atol : float
        Newton tolerance on ‖r‖∞ (N, mm).
    max_steps : int
        Newton iterations per seed.
    max_backtracks : int
        Line-search halvings per Newton step. A seed costs at most
        max_steps · (max_backtracks + 1) residual evaluations; most converge in 6–8, the rest
        are seeds far from any equilibrium, which should fail fast.
    continuation : Continuation
        ``MARCH`` (default): the stable equilibria are continued point by point along the
        displacement axis, forward through each row and then backward from the equilibria
        that the forward sweep did not reach; ``NEIGHBOURS``: one continuation pass from the
        stable equilibria of the two neighbouring points (the previous default, with
        the fixed seeds at every point).
    seed_spacing : float
        Largest distance in U/l₀ between two points of a row that get the fixed seeds (the
        first and last point always do; the march carries the branches to the points in
        between; a grid coarser than this seeds every point, and so does 0). Default 0.04:
        every fourth point of a grid with ΔU/l₀ = 0.01. With ``NEIGHBOURS`` use 0 (points
        without seeds would see only their neighbours' states). A point where nothing
        converged gets the fixed seeds after the march.
    continuation_steps : int
        Newton iterations per continuation solve (measured on an 8 × 40 check grid: 6 lose
        equilibria at 30 of the 320 points, 10 at 13, 15 at none).
    seeding : Seeding
        The fixed seeds (:func:`~biplan.analysis.maps.stability_seeds.seeds`). ``SUBSETS``
        (default): one per subset of the circular folds, 2^N_c, for tubes with at most
        ``max_subset_folds`` circular folds (more use ``PATTERNS``); ``PATTERNS``: the 3 N_c − 2
        patterns of earlier versions, which find only the combinations of open folds next to
        the base or the free end.
    max_subset_folds : int
        Most circular folds for which ``SUBSETS`` seeds every subset (2^8 = 256 seeds), from 1
        to :data:`MAX_SUBSET_FOLDS` = 12.
    """

    max_equilibria: int = 8
    distinct_tol: float = 1e-4
    atol: float = 1e-9
    max_steps: int = 15
    max_backtracks: int = 4
    continuation: Continuation = Continuation.MARCH
    seed_spacing: float = 0.04
    continuation_steps: int = 15
    seeding: Seeding = Seeding.SUBSETS
    max_subset_folds: int = 8

    def __post_init__(self) -> None:
        names = ("max_equilibria", "max_steps", "max_backtracks", "continuation_steps",
                 "max_subset_folds")  # fmt: skip
        for name in names:
            object.__setattr__(
                self, name, check_integer(f"search.{name}", getattr(self, name), low=1)
            )
        for name, choice in (("continuation", Continuation), ("seeding", Seeding)):
            value = getattr(self, name)
            if value not in set(choice):
                valid = "one of " + ", ".join(c.value for c in choice)
                raise ConfigError(f"search.{name}", value, valid)
            object.__setattr__(self, name, choice(value))
        if self.max_subset_folds > MAX_SUBSET_FOLDS:
            valid = f"an integer from 1 to {MAX_SUBSET_FOLDS} (2^N seeds per point)"
            raise ConfigError("search.max_subset_folds", self.max_subset_folds, valid)
        check_range("search.distinct_tol", self.distinct_tol, low=0.0)
        check_range("search.seed_spacing", self.seed_spacing, low=0.0, low_open=False)
        self.newton()

    def seed_kind(self, n_circular: int) -> Seeding:
        """The seeding used for a tube with ``n_circular`` circular folds."""
        if self.seeding is Seeding.SUBSETS and n_circular <= self.max_subset_folds:
            return Seeding.SUBSETS
        return Seeding.PATTERNS

    def newton(self, continuation: bool = False) -> Newton:
        """Newton settings of the fixed seeds, or of the continuation seeds."""
        steps = self.continuation_steps if continuation else self.max_steps
        return Newton(atol=self.atol, max_steps=steps, max_backtracks=self.max_backtracks)


def same_equilibrium(others: Any, z: np.ndarray, nq: int, tol: float) -> np.ndarray:
    """Whether each of ``others`` (k, n_z; may be empty) is the equilibrium ``z``: closer than
    ``tol`` in every coordinate q (multipliers are not compared). The one closeness test of
    the search (distinct equilibria, shared observations, the backward sweep)."""
    rows = np.asarray(others, dtype=float).reshape(-1, z.shape[-1])
    return np.max(np.abs(rows[:, :nq] - z[:nq]), axis=1) <= tol


def _distinct(z: np.ndarray, energy: np.ndarray, nq: int, tol: float) -> list[int]:
    """Indices of distinct solutions (lowest energy first)."""
    keep: list[int] = []
    for i in np.argsort(energy, kind="stable"):
        if not same_equilibrium(z[keep], z[i], nq, tol).any():
            keep.append(int(i))
    return keep


class Solutions:
    """The converged solutions found so far at every point of a group, and their distinct
    equilibria (lowest energy first)."""

    def __init__(self, n_points: int, nq: int, tol: float) -> None:
        self.n_points, self.nq, self.tol = n_points, nq, tol
        self.rows: list[np.ndarray] = []
        self.sols: list[list[np.ndarray]] = []
        self._cache: dict[int, dict[str, Any]] = {}

    def add(self, rows: np.ndarray, sols: list[np.ndarray]) -> None:
        self.rows.append(rows)
        self.sols.append(sols)
        self._cache.clear()

    def point(self, j: int) -> dict[str, Any]:
        if j not in self._cache:
            sel = [
                np.flatnonzero((r == j) & s[1]) for r, s in zip(self.rows, self.sols, strict=True)
            ]
            z, energy, min_eig, uz, ur, force = (
                np.concatenate([s[k][i] for s, i in zip(self.sols, sel, strict=True)])
                for k in (0, 2, 3, 4, 5, 6)
            )
            keep = _distinct(z, energy, self.nq, self.tol)
            stable = min_eig[keep] > STABILITY_TOL
            self._cache[j] = {
                "z": z[keep], "energy": energy[keep], "min_eig": min_eig[keep], "u_z": uz[keep],
                "u_r": ur[keep], "force": force[keep], "stable": stable,
                "z_stable": z[keep][stable],
            }  # fmt: skip
        return self._cache[j]

    def any(self, j: int) -> bool:
        """Whether any solve converged at point ``j``."""
        return len(self.point(j)["energy"]) > 0

    def stable(self, j: int) -> np.ndarray:
        return self.point(j)["z_stable"]

    def collect(self) -> list[dict[str, Any]]:
        return [self.point(j) for j in range(self.n_points)]
