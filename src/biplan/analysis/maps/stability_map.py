"""Displacement-controlled stability map (paper Fig. 3 A.3; SI design-map section).

At every grid point (prescribed normalised end displacement U/l₀ and design parameters, by
default C at b = 0.58) the distinct equilibria are searched for and classified:

1. **Seeds.** Newton (displacement control, U = value · l₀ [mm]) from a fixed set of starts
   (:func:`~biplan.analysis.maps.stability_seeds.seeds`): by default one per subset of the
   circular folds, the displacement shared equally by the open folds of the subset
   (``seeding = "subsets"``: 2^N_c starts, 64 for the semi-bistable design). The circular
   folds are in series and nearly equivalent, so every combination of k folds on their third
   branch is a stable equilibrium where U allows k open folds: C(N_c, k) of them (15 for two
   open folds of six). The 3 N_c − 2 patterns of earlier versions (all closed, shared by all,
   one per fold, the k lowest and the k highest folds; ``seeding = "patterns"``, used past
   ``max_subset_folds`` folds) found only the combinations next to the base or the free end.
   A point still without a stable equilibrium after step 2 (at a prescribed U the least
   energy is one) gets one more start: the state that the stable-branch sweep from the relaxed
   reference reaches at its U, one sweep per row
   (:func:`~biplan.analysis.maps.stability_seeds.reference_path_starts`).
   By default these fixed seeds run only at points at most ``seed_spacing`` = 0.04 apart in
   U/l₀ along a row (every fourth point of a grid with ΔU/l₀ = 0.01; every point of a coarser
   grid), the first and the last.
2. **Continuation along the displacement axis** (``continuation = "march"``). All stable
   equilibria of each point are continued to the next point of the row (Newton from them at
   the new displacement), forward through the whole row; then backward, from the stable
   equilibria that the forward sweep did not reach from the point before (branches that
   appear between two points, found by the fixed seeds further along). A branch found
   anywhere in a row is so followed wherever it exists. On the check grids (8 × 40 and
   6 × 40 points, docs/maps.md) this finds exactly the counts of seeding every point and
   continuing one step from both neighbours (``seed_spacing = 0``,
   ``continuation = "neighbours"``, the previous default), at 2.2× its speed.
3. **Distinct equilibria.** Converged solutions closer than ``distinct_tol`` in every
   coordinate are one equilibrium; each is classified with λ_min of the reduced Hessian
   (:func:`biplan.solvers.observation.observe`, the compiled batched form of
   :func:`biplan.analysis.stability.classify`): stable if λ_min > ``STABILITY_TOL``.
4. **Count.** ``n_stable`` = 1 monostable, 2 bistable, ≥ 3 multistable (``regime`` 1, 2, 3; 0
   when none was found). The **transition band** is the stretch of each row along the
   displacement axis between the first and the last change of regime, when the regime changes
   more than once (neighbouring points alternate), up to the point from which the final
   regime holds.

Every solve runs on the compiled System of its point
(:meth:`~biplan.model.assembly.Model.system`): the tasks of each point (seeds or continuation
starts) are solved in parallel by the compiled Newton
(:func:`biplan.solvers.batch.solve_tasks`, one compilation per install, whatever the layout or
chunk) and observed by :func:`biplan.solvers.observation.observe`
(:mod:`biplan.analysis.maps.stability_solve`). Only one solution per distinct equilibrium and
point is observed (Hessian, λ_min), the copies share its values. Continuation stays inside a
chunk, so rows should not straddle chunks (the CLI sizes the chunks to whole rows, at least
128 points: :func:`stability_chunk_size`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan.analysis.maps.stability_search import (
    Continuation,
    Solutions,
    StabilitySearch,
    same_equilibrium,
)
from biplan.analysis.maps.stability_seeds import pushing, reference_path_starts, seeds
from biplan.analysis.maps.stability_solve import CompiledTasks, solve_and_observe
from biplan.model.assembly import Model
from biplan.model.tube import Tube
from biplan.solvers.observation import STABILITY_TOL

__all__ = [
    "StabilityEvaluator",
    "stability_chunk_size",
    "transition_band",
]

#: Regime codes of ``regime``.
REGIMES = {"none": 0, "monostable": 1, "bistable": 2, "multistable": 3}


@dataclass(frozen=True)
class StabilityEvaluator:
    """Distinct equilibria and their stability at every grid point (see module docstring)."""

    search: StabilitySearch = StabilitySearch()  # noqa: RUF009 (a frozen dataclass)
    name: str = "stability_count"
    load_axes: tuple[str, ...] = ("displacement",)

    def dim_sizes(self, design: Tube) -> dict[str, int]:
        return {
            "equilibrium": self.search.max_equilibria,
            "coordinate": design.layout.n_coordinates,
        }

    def variables(self, design: Tube) -> dict[str, tuple[tuple[str, ...], str, str]]:
        e = ("equilibrium",)
        return {
            "n_stable": ((), "1", "number of distinct stable equilibria"),
            "n_equilibria": ((), "1", "number of distinct equilibria found"),
            "regime": ((), "1", "0 none, 1 monostable, 2 bistable, 3 multistable"),
            "energy": (e, "N*mm", "strain energy of each equilibrium (lowest first)"),
            "stable": (e, "1", "1 stable, 0 unstable or critical"),
            "min_eigenvalue": (e, "N*mm", "smallest reduced-Hessian eigenvalue"),
            "force": (e, "N", "end reaction force"),
            "u_z": (e, "1", "axial endpoint displacement u_z / l0"),
            "u_r": (e, "1", "radial endpoint displacement u_r / l0"),
            "q": (("equilibrium", "coordinate"), "mm|rad", "generalised coordinates"),
            "status": ((), "1", "0 ok; see flag_meanings"),
        }

    def describe(self) -> dict[str, Any]:
        s = self.search
        return {
            "solver": "multi-seed Newton under displacement control + neighbour continuation",
            "max_equilibria": s.max_equilibria,
            "distinct_tol": s.distinct_tol,
            "atol": s.atol,
            "max_steps": s.max_steps,
            "max_backtracks": s.max_backtracks,
            "continuation": s.continuation.value,
            "seed_spacing": s.seed_spacing,
            "seeding": s.seeding.value,
            "continuation_steps": s.continuation_steps,
            "stability_tol": STABILITY_TOL,
        }

    def finish(self, ds: Any) -> Any:
        if "displacement" in ds.dims:
            axis = list(ds["regime"].dims).index("displacement")
            band = transition_band(ds["regime"].values, axis)
            ds["transition"] = (ds["regime"].dims, band.astype(np.int8), {
                "units": "1", "long_name": "1 inside the transition band"})  # fmt: skip
        return ds

    def evaluate(
        self, tubes: Sequence[Tube], loads: Sequence[Mapping[str, float]], batch: int
    ) -> dict[str, np.ndarray]:
        """Equilibria of every point (tubes of one or several layouts; ``batch`` is not
        used: the tasks of each point are solved together, whatever the chunk)."""
        n = len(tubes)
        m_eq = self.search.max_equilibria
        nq_all = tubes[0].layout.n_coordinates
        out = {
            "n_stable": np.zeros(n),
            "n_equilibria": np.zeros(n),
            "regime": np.zeros(n),
            "status": np.zeros(n, dtype=np.int64),
            "q": np.full((n, m_eq, nq_all), np.nan),
        }
        for key in ("energy", "stable", "min_eigenvalue", "force", "u_z", "u_r"):
            out[key] = np.full((n, m_eq), np.nan)
        groups: dict[Any, list[int]] = {}
        for i, t in enumerate(tubes):
            groups.setdefault(t.layout, []).append(i)
        for layout, which in groups.items():
            found = self._search_group([tubes[i] for i in which], [loads[i] for i in which])
            for j, i in enumerate(which):
                self._store(out, i, found[j], tubes[i].initial_length, layout.n_coordinates)
        return out

    def _search_group(
        self, tubes: list[Tube], loads: list[Mapping[str, float]]
    ) -> list[dict[str, Any]]:
        """Seeds, then continuation, for the points of one layout (see module docstring)."""
        s = self.search
        models = [Model(t) for t in tubes]
        kind = s.seed_kind(tubes[0].n_circular)
        tasks = CompiledTasks.of(models)
        u = [
            float(ld["displacement"]) * t.initial_length for ld, t in zip(loads, tubes, strict=True)
        ]
        nq = models[0].n_coordinates
        acc = Solutions(len(models), nq, s.distinct_tol)

        def solve(rows: list[int], z0: list[np.ndarray], cont: bool) -> list[np.ndarray]:
            r = np.asarray(rows, dtype=int)
            sols = solve_and_observe(tasks, r, np.asarray(z0), np.asarray(u)[r], s.newton(cont),
                                     nq, s.distinct_tol)  # fmt: skip
            acc.add(r, sols)
            return sols

        # rows: runs of consecutive points of the same design (the displacement axis)
        rows_of: list[list[int]] = []
        for j in range(len(models)):
            if rows_of and tubes[rows_of[-1][-1]] == tubes[j]:
                rows_of[-1].append(j)
            else:
                rows_of.append([j])
        # 1. fixed seeds at the seeded points of every row
        disp = [float(ld["displacement"]) for ld in loads]
        seeded = [j for row in rows_of for j in self._seeded([disp[k] for k in row], row)]

        same_folds = len({t.circular_laws for t in tubes}) == 1
        pushes = pushing(tubes[0], np.asarray(u)) if same_folds else None

        def fixed_seeds(points: list[int], pressed_elsewhere: bool = False) -> None:
            rows, z0 = [], []
            for j in range(len(models)) if pressed_elsewhere else points:
                push = None if pushes is None else pushes[j]
                sd = seeds(models[j], u[j], kind, pressed_only=j not in points, pushes=push)
                rows += [j] * len(sd)
                z0 += list(sd)
            if rows:
                solve(rows, z0, False)

        def from_reference() -> None:
            """The points still without a stable equilibrium (at a prescribed U the tube's
            least energy is one): the states that the stable-branch sweep from the relaxed
            reference reaches at their U, one sweep per row, as one more start each (past the
            peak of identical folds in series the stable branch lies far from every fixed
            seed, and a row whose first points have none has nothing to continue from)."""
            empty, starts = [], []
            for row in rows_of:
                points = [j for j in row if not len(acc.stable(j))]
                if points:
                    empty += points
                    starts += reference_path_starts(models[points[0]], [u[j] for j in points])
            if empty:
                solve(empty, starts, False)

        # the pressed seeds run at every point: contact-locked states live in windows
        # narrower than the seed spacing, and continuation from a state in tension does not
        # enter them (its closing contacts start without multipliers)
        fixed_seeds(seeded, pressed_elsewhere=True)
        # 2. continuation along the displacement axis
        if s.continuation is Continuation.NEIGHBOURS:
            rows, z0 = [], []
            for row in rows_of:
                for pos, j in enumerate(row):
                    for nb in (pos - 1, pos + 1):
                        if 0 <= nb < len(row):
                            for zs in acc.stable(row[nb]):
                                rows.append(j)
                                z0.append(zs)
            if rows:
                solve(rows, z0, True)
            from_reference()
            return acc.collect()
        # march: forward through every row, then backward from the equilibria that the
        # forward pass did not reach from the point before (branches born in between)
        reached: list[list[np.ndarray]] = [[] for _ in models]
        longest = max(len(r) for r in rows_of)
        for pos in range(1, longest):
            rows, z0 = [], []
            for row in rows_of:
                if pos < len(row):
                    for zs in acc.stable(row[pos - 1]):
                        rows.append(row[pos])
                        z0.append(zs)
            if rows:
                sols = solve(rows, z0, True)
                for k, j in enumerate(rows):
                    if sols[1][k]:
                        reached[j].append(sols[0][k])
        for pos in range(longest - 2, -1, -1):
            rows, z0 = [], []
            for row in rows_of:
                if pos < len(row) - 1:
                    for zs in acc.stable(row[pos + 1]):
                        if not same_equilibrium(
                            reached[row[pos + 1]], zs, nq, s.distinct_tol
                        ).any():
                            rows.append(row[pos])
                            z0.append(zs)
            if rows:
                solve(rows, z0, True)
        # a point left without any equilibrium gets the fixed seeds after all
        fixed_seeds([j for j in range(len(models)) if j not in seeded and not acc.any(j)])
        from_reference()
        return acc.collect()

    def _seeded(self, disp: list[float], row: list[int]) -> list[int]:
        """The points of a row that get the fixed seeds: the first, the last, and enough in
        between that no two consecutive seeded points are more than ``seed_spacing`` apart
        in U/l₀ (every point when the grid is coarser than that)."""
        spacing = self.search.seed_spacing * (1.0 + 1e-9)
        out, last = [], 0
        for pos in range(len(row)):
            nxt = pos + 1
            if pos == 0 or nxt == len(row) or abs(disp[nxt] - disp[last]) > spacing:
                out.append(row[pos])
                last = pos
        return out

    def _store(self, out: dict[str, np.ndarray], i: int, f: dict, l0: float, nq: int) -> None:
        n_eq = len(f["energy"])
        n_st = int(np.sum(f["stable"]))
        out["n_equilibria"][i] = n_eq
        out["n_stable"][i] = n_st
        out["regime"][i] = min(n_st, 3)
        if n_eq == 0:
            out["status"][i] = 1
            out["n_stable"][i] = out["n_equilibria"][i] = out["regime"][i] = np.nan
            return
        k = min(n_eq, self.search.max_equilibria)
        out["energy"][i, :k] = f["energy"][:k]
        out["stable"][i, :k] = f["stable"][:k]
        out["min_eigenvalue"][i, :k] = f["min_eig"][:k]
        out["force"][i, :k] = f["force"][:k]
        out["u_z"][i, :k] = f["u_z"][:k] / l0
        out["u_r"][i, :k] = f["u_r"][:k] / l0
        w = min(nq, out["q"].shape[2])
        out["q"][i, :k, :w] = f["z"][:k, :w]


def stability_chunk_size(n_displacements: int, min_points: int = 128) -> int:
    """Points per chunk for a map with ``n_displacements`` values on its last axis: whole rows
    (continuation stays inside a chunk), at least ``min_points`` points, so that each
    continuation step of the march solves the rows of a chunk together."""
    rows = max(1, -(-min_points // max(n_displacements, 1)))
    return rows * n_displacements


def transition_band(regime: np.ndarray, axis: int = -1) -> np.ndarray:
    """Boolean mask of the transition band along ``axis`` (the displacement axis).

    In each row, when the regime changes more than once, the band runs from the first point
    whose regime differs from its predecessor up to (excluding) the last such point, from which
    the final regime holds; rows with at most one change have no band. NaN (failed) points are
    skipped.
    """
    r = np.moveaxis(np.asarray(regime, dtype=float), axis, -1)
    band = np.zeros(r.shape, dtype=bool)
    for idx in np.ndindex(r.shape[:-1]):
        row = r[idx]
        valid = np.flatnonzero(np.isfinite(row))
        if valid.size < 2:
            continue
        changes = valid[1:][np.diff(row[valid]) != 0]
        if changes.size >= 2:
            band[idx][changes[0] : changes[-1]] = True
    return np.moveaxis(band, -1, axis)
