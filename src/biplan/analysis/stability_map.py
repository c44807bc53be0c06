"""Displacement-controlled stability map (paper Fig. 3 A.3; SI design-map section).

At every grid point (prescribed normalised end displacement U/l₀ and design parameters, by
default C at b = 0.58) the distinct equilibria are searched for and classified:

1. **Seeds.** Newton (displacement control, U = value · l₀ [mm]) from a fixed set of starts:
   all folds closed, the displacement shared by all circular folds, put on a single circular
   fold (one seed per fold), and shared by the k lowest and by the k highest folds
   (2 ≤ k < N_c): 3 N_c − 2 seeds, 16 for the semi-bistable design.
2. **Continuation from neighbours.** The stable equilibria found at the neighbouring
   displacements of the same design (previous and next point of the chunk along the last grid
   axis) are used as further seeds at this point.
3. **Distinct equilibria.** Converged solutions closer than ``distinct_tol`` in every
   coordinate are one equilibrium; each is classified with λ_min of the reduced Hessian
   (:func:`biplan.solvers.observe.min_reduced_eigenvalue`, the batched form of
   :func:`biplan.analysis.stability.classify`): stable if λ_min > ``STABILITY_TOL``.
4. **Count.** ``n_stable`` = 1 monostable, 2 bistable, ≥ 3 multistable (``regime`` 1, 2, 3; 0
   when none was found). The **transition band** is the stretch of each row along the
   displacement axis between the first and the last change of regime, when the regime changes
   more than once (neighbouring points alternate), up to the point from which the final
   regime holds.

All solves of a chunk, (points × seeds), run as one task queue on a lane-refilling Newton pool
(:func:`biplan.solvers.pool.newton_pool`, ``solve_batch`` lanes, one compiled kernel per layout
and chunk size): a lane whose seed has converged or failed takes the next seed, so a slow seed
no longer holds up a whole batch. Neighbour continuation stays inside a chunk, so rows should
not straddle chunks (the CLI sizes the chunks to whole rows).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan._errors import ConfigError, check_range
from biplan._jax import jax, jnp
from biplan.analysis.design_map import stack_params
from biplan.assembly import Load, Model, TubeLayout
from biplan.geometry import Tube
from biplan.solvers.newton import Newton, Status
from biplan.solvers.observe import STABILITY_TOL, observe
from biplan.solvers.pool import pool_kernel

__all__ = ["StabilityEvaluator", "StabilitySearch", "transition_band"]

Array = Any

#: Regime codes of ``regime``.
REGIMES = {"none": 0, "monostable": 1, "bistable": 2, "multistable": 3}


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
    solve_batch : int
        Lanes of the solve pool (:func:`biplan.solvers.pool.newton_pool`: solves in flight,
        a finished lane takes the next seed), ≥ 1.
    """

    max_equilibria: int = 8
    distinct_tol: float = 1e-4
    atol: float = 1e-9
    max_steps: int = 15
    max_backtracks: int = 4
    solve_batch: int = 16

    def __post_init__(self) -> None:
        for name in ("max_equilibria", "solve_batch", "max_steps", "max_backtracks"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ConfigError(f"search.{name}", v, "an integer ≥ 1")
        check_range("search.distinct_tol", self.distinct_tol, low=0.0)
        self.newton()

    def newton(self) -> Newton:
        return Newton(atol=self.atol, max_steps=self.max_steps, max_backtracks=self.max_backtracks)


def _observe(layout: TubeLayout, p: Any, z: Array, u: Array) -> tuple:
    load = Load(jnp.asarray(0.0), u, jnp.asarray(1.0))
    ob = observe(layout, p, z, load, layout.options.weak_contacts_active)
    return ob.energy, ob.min_eigenvalue, ob.u_z, ob.u_r, ob.force


@functools.lru_cache(maxsize=16)
def _observe_kernel(layout: TubeLayout) -> Any:
    return jax.jit(jax.vmap(functools.partial(_observe, layout)))


def seeds(model: Model, u: float) -> np.ndarray:
    """Packed starting vectors (n_seeds, n_z) for prescribed displacement ``u`` [mm]."""
    nq = model.n_coordinates
    n_circ = model.tube.n_circular
    first = nq - n_circ
    patterns: list[np.ndarray] = [np.zeros(n_circ), np.ones(n_circ)]
    patterns += [np.eye(n_circ)[i] for i in range(n_circ)]
    for k in range(2, n_circ):
        patterns += [np.r_[np.ones(k), np.zeros(n_circ - k)]]
        patterns += [np.r_[np.zeros(n_circ - k), np.ones(k)]]
    out = []
    for pat in patterns:
        q = np.zeros(nq)
        if pat.sum() > 0:
            q[first:] = pat * u / pat.sum()
        out.append(model.pack(q))
    return np.asarray(out)


def _distinct(z: np.ndarray, energy: np.ndarray, nq: int, tol: float) -> list[int]:
    """Indices of distinct solutions (lowest energy first)."""
    keep: list[int] = []
    for i in np.argsort(energy, kind="stable"):
        if all(np.max(np.abs(z[i, :nq] - z[j, :nq])) > tol for j in keep):
            keep.append(int(i))
    return keep


@dataclass(frozen=True)
class StabilityEvaluator:
    """Distinct equilibria and their stability at every grid point (see module docstring)."""

    search: StabilitySearch = StabilitySearch()
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
            "stability_tol": STABILITY_TOL,
        }

    def finish(self, ds: Any) -> Any:
        if "displacement" in ds.dims:
            axis = list(ds["regime"].dims).index("displacement")
            band = transition_band(ds["regime"].values, axis)
            ds["transition"] = (ds["regime"].dims, band.astype(np.int8), {
                "units": "1", "long_name": "1 inside the transition band"})  # fmt: skip
        return ds

    def _solve_all(
        self,
        layout: TubeLayout,
        params: Any,
        rows: np.ndarray,
        z0: np.ndarray,
        u: np.ndarray,
        capacity: int,
    ) -> list[np.ndarray]:
        """Solve every (point row, seed) task on a lane-refilling pool
        (:func:`biplan.solvers.pool.newton_pool`), then observe the converged ones."""
        lanes = self.search.solve_batch
        n = len(rows)
        cap = max(capacity, n)
        pad = cap - n
        point = np.r_[rows, np.zeros(pad, dtype=int)].astype(np.int32)
        zz = np.concatenate([z0, np.repeat(z0[-1:], pad, axis=0)])
        uu = np.r_[u, np.zeros(pad)]
        loads = Load(jnp.zeros(cap), jnp.asarray(uu), jnp.ones(cap))
        res = pool_kernel(layout, lanes)(
            params, jnp.asarray(point), jnp.asarray(zz), loads, jnp.asarray(n),
            self.search.newton().settings(),
        )  # fmt: skip
        z = np.asarray(res.z)[:n]
        ok = (np.asarray(res.status)[:n] == Status.CONVERGED.value) & np.all(np.isfinite(z), 1)
        obs = [np.full(n, np.nan) for _ in range(5)]
        idx = np.flatnonzero(ok)
        fn = _observe_kernel(layout)
        for lo in range(0, idx.size, lanes):
            part = idx[lo : lo + lanes]
            full = np.r_[part, np.full(lanes - part.size, part[-1])]
            p = jax.tree_util.tree_map(lambda a, r=rows[full]: a[r], params)
            out = fn(p, jnp.asarray(z[full]), jnp.asarray(u[full]))
            for o, v in zip(obs, out, strict=True):
                o[part] = np.asarray(v)[: part.size]
        return [z, ok, *obs]

    def evaluate(
        self, tubes: Sequence[Tube], loads: Sequence[Mapping[str, float]], batch: int
    ) -> dict[str, np.ndarray]:
        """Equilibria of every point (tubes of one or several layouts)."""
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
            models = [Model(t) for t in (tubes[i] for i in which)]
            params = stack_params(models, max(batch, len(models)))
            n_seeds = len(seeds(models[0], 0.0))
            capacity = max(batch, len(models)) * max(n_seeds, 2 * self.search.max_equilibria)
            u = [float(loads[i]["displacement"]) * tubes[i].initial_length for i in which]
            nq = models[0].n_coordinates
            # pass 1: fixed seeds
            rows, z0, uu = [], [], []
            for j, m in enumerate(models):
                s = seeds(m, u[j])
                rows += [j] * len(s)
                z0.append(s)
                uu += [u[j]] * len(s)
            sols = self._solve_all(
                layout, params, np.asarray(rows), np.concatenate(z0), np.asarray(uu), capacity
            )
            found = self._collect(np.asarray(rows), sols, len(models), nq)
            # pass 2: continuation from the neighbours along the last axis (same design)
            rows2, z02, uu2 = [], [], []
            for j in range(len(models)):
                for nb in (j - 1, j + 1):
                    if 0 <= nb < len(models) and tubes[which[nb]] == tubes[which[j]]:
                        for zs in found[nb]["z_stable"]:
                            rows2.append(j)
                            z02.append(zs)
                            uu2.append(u[j])
            if rows2:
                r2 = np.asarray(rows2)
                sols2 = self._solve_all(
                    layout, params, r2, np.asarray(z02), np.asarray(uu2), capacity
                )
                rows_all = np.r_[np.asarray(rows), r2]
                sols = [np.concatenate([a, b], axis=0) for a, b in zip(sols, sols2, strict=True)]
                found = self._collect(rows_all, sols, len(models), nq)
            for j, i in enumerate(which):
                self._store(out, i, found[j], tubes[i].initial_length, nq)
        return out

    def _collect(
        self, rows: np.ndarray, sols: list[np.ndarray], n_points: int, nq: int
    ) -> list[dict[str, Any]]:
        z, ok, energy, lam, uz, ur, force = sols
        res = []
        for j in range(n_points):
            sel = np.flatnonzero((rows == j) & ok)
            keep = sel[_distinct(z[sel], energy[sel], nq, self.search.distinct_tol)]
            stable = lam[keep] > STABILITY_TOL
            res.append({
                "z": z[keep], "energy": energy[keep], "lam": lam[keep], "u_z": uz[keep],
                "u_r": ur[keep], "force": force[keep], "stable": stable,
                "z_stable": z[keep][stable][: self.search.max_equilibria],
                "any_seed": bool(np.any(rows == j)),
            })  # fmt: skip
        return res

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
        out["min_eigenvalue"][i, :k] = f["lam"][:k]
        out["force"][i, :k] = f["force"][:k]
        out["u_z"][i, :k] = f["u_z"][:k] / l0
        out["u_r"][i, :k] = f["u_r"][:k] / l0
        w = min(nq, out["q"].shape[2])
        out["q"][i, :k, :w] = f["z"][:k, :w]


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
