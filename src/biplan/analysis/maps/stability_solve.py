"""The equilibrium solves of the stability map's search
(:mod:`biplan.analysis.maps.stability_map`): many (point, start) tasks under displacement
control, and the observation of the distinct equilibria they converge to.

Two interchangeable solvers (:func:`task_solver` picks one per group of points):

* :class:`CompiledTasks` — on the compiled :class:`~biplan.model.system.System` of each point
  (the default chain readings): the tasks of a point are solved in parallel by
  :func:`biplan.solvers.batch.solve_tasks` (the compiled Newton, one compilation per install)
  and observed by :func:`biplan.solvers.observation.observe`;
* :class:`PoolTasks` — the JAX kernels, for the readings the System does not cover: the tasks
  of a chunk on a lane-refilling Newton pool (:func:`biplan.solvers.pool.newton_pool`), which
  runs the same iteration per task, observed on :data:`OBSERVE_LANES` lanes.

:func:`solve_and_observe` runs a solver and observes one solution per distinct equilibrium
and point (the copies share its values).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from biplan._compile.kernel import kernel
from biplan._compile.setup import jax, jnp
from biplan.analysis.maps.stability_search import same_equilibrium
from biplan.geometry.layout import TubeLayout
from biplan.model.assembly import Load, Model
from biplan.model.system import System
from biplan.solvers import batch
from biplan.solvers.iteration import settings_array
from biplan.solvers.newton import Newton, Status
from biplan.solvers.observation import observe as observe_compiled
from biplan.solvers.observe import observe
from biplan.solvers.pool import newton_pool

__all__ = [
    "OBSERVE_LANES",
    "CompiledTasks",
    "PoolTasks",
    "TaskSolver",
    "solve_and_observe",
    "task_solver",
]

Array = Any

#: Lanes of the JAX observation kernel: fixed, so that the march (``march_lanes``) and the
#: seed pool (``solve_batch``) share one compiled observation.
OBSERVE_LANES = 8


@kernel("stability_observe", in_axes=(0, 0, 0))
def _observe(layout: TubeLayout, p: Any, z: Array, u: Array) -> tuple:
    load = Load(jnp.asarray(0.0), u, jnp.asarray(1.0))
    ob = observe(layout, p, z, load, layout.options.weak_contacts_active)
    return ob.energy, ob.min_eigenvalue, ob.u_z, ob.u_r, ob.force


class TaskSolver(Protocol):
    """Solves and observes tasks of the points of one group (tubes of one layout)."""

    def solve(
        self, rows: np.ndarray, z0: np.ndarray, u: np.ndarray, lanes: int, newton: Newton
    ) -> tuple[np.ndarray, np.ndarray]:
        """(z (n, n_z), Status values (n,)) of the tasks: point ``rows`` (n,), start ``z0``
        (n, n_z), prescribed load-point displacement ``u`` [mm] (n,); ``lanes``: solves in
        flight of the JAX pool."""
        ...

    def observe(self, rows: np.ndarray, z: np.ndarray, u: np.ndarray) -> list[np.ndarray]:
        """Energy [N·mm], λ_min [N/mm], u_z [mm], u_r [mm] and end force [N] of states z
        (k, n_z) of points ``rows`` at displacements ``u`` [mm]."""
        ...


def _displacement_loads(u: np.ndarray) -> np.ndarray:
    """(F, U, d) rows (k, 3) of displacement control at U = u [mm]."""
    u = np.asarray(u, dtype=float)
    return np.ascontiguousarray(np.stack([np.zeros_like(u), u, np.ones_like(u)], axis=1))


@dataclass(frozen=True)
class CompiledTasks:
    """:class:`TaskSolver` on the compiled System of every point (module docstring).

    Parameters
    ----------
    systems : list of System
        The System of each point (row).
    weak_contacts : bool
        The layout's S1 reading ``weak_contacts_active`` (the stability test's active set).
    """

    systems: list[System]
    weak_contacts: bool

    def solve(
        self, rows: np.ndarray, z0: np.ndarray, u: np.ndarray, lanes: int, newton: Newton
    ) -> tuple[np.ndarray, np.ndarray]:
        s = settings_array(
            newton.atol, newton.max_steps, newton.max_backtracks, newton.armijo, newton.free_steps
        )
        z = np.array(z0, dtype=float)
        status = np.empty(len(rows), dtype=np.int64)
        for j in np.unique(rows):
            sel = np.flatnonzero(rows == j)
            start = np.ascontiguousarray(z0[sel], dtype=float)
            out = batch.solve_tasks(self.systems[j].data, start, _displacement_loads(u[sel]), s)
            z[sel], status[sel] = out[0], out[1]
        return z, status

    def observe(self, rows: np.ndarray, z: np.ndarray, u: np.ndarray) -> list[np.ndarray]:
        out = [np.empty(len(rows)) for _ in range(5)]
        for j in np.unique(rows):
            sel = np.flatnonzero(rows == j)
            ob = observe_compiled(
                self.systems[j].data, z[sel], _displacement_loads(u[sel]), self.weak_contacts
            )
            for o, v in zip(out, (ob.energy, ob.min_eigenvalue, ob.u_z, ob.u_r, ob.force),
                            strict=True):  # fmt: skip
                o[sel] = v
        return out


@dataclass(frozen=True)
class PoolTasks:
    """:class:`TaskSolver` on the JAX kernels of a layout (module docstring).

    Parameters
    ----------
    layout : TubeLayout
    params : ModelParams
        The points' parameters stacked along a leading axis (padded to the kernel size).
    capacity : int
        Tasks of the compiled pool (a call with more tasks compiles its own).
    """

    layout: TubeLayout
    params: Any
    capacity: int

    def solve(
        self, rows: np.ndarray, z0: np.ndarray, u: np.ndarray, lanes: int, newton: Newton
    ) -> tuple[np.ndarray, np.ndarray]:
        n = len(rows)
        cap = max(self.capacity, n)
        pad = cap - n
        point = np.r_[rows, np.zeros(pad, dtype=int)].astype(np.int32)
        zz = np.concatenate([z0, np.repeat(z0[-1:], pad, axis=0)])
        uu = np.r_[u, np.zeros(pad)]
        loads = Load(jnp.zeros(cap), jnp.asarray(uu), jnp.ones(cap))
        res = newton_pool.compiled(self.layout, lanes)(
            self.params, jnp.asarray(point), jnp.asarray(zz), loads, jnp.asarray(n),
            newton.settings(),
        )  # fmt: skip
        return np.asarray(res.z)[:n], np.asarray(res.status)[:n]

    def observe(self, rows: np.ndarray, z: np.ndarray, u: np.ndarray) -> list[np.ndarray]:
        out = [np.empty(len(rows)) for _ in range(5)]
        fn = _observe.compiled(self.layout)
        for lo in range(0, len(rows), OBSERVE_LANES):
            part = np.arange(lo, min(lo + OBSERVE_LANES, len(rows)))
            full = np.r_[part, np.full(OBSERVE_LANES - part.size, part[-1])]
            p = jax.tree_util.tree_map(lambda a, r=rows[full]: a[r], self.params)
            res = fn(p, jnp.asarray(z[full]), jnp.asarray(u[full]))
            for o, v in zip(out, res, strict=True):
                o[part] = np.asarray(v)[: part.size]
        return out


def task_solver(layout: TubeLayout, models: list[Model], size: int, capacity: int) -> TaskSolver:
    """The solver of the points ``models`` (one layout): :class:`CompiledTasks` where every
    model has a compiled System, else :class:`PoolTasks` with the parameters stacked and
    padded to ``size`` points and a pool of ``capacity`` tasks."""
    systems = [m.system() for m in models]
    if all(s is not None for s in systems):
        weak = layout.options.weak_contacts_active
        return CompiledTasks([s for s in systems if s is not None], bool(weak))
    from biplan.analysis.maps.design_kernels import stack_params

    return PoolTasks(layout, stack_params(models, size), capacity)


def solve_and_observe(
    solver: TaskSolver,
    rows: np.ndarray,
    z0: np.ndarray,
    u: np.ndarray,
    lanes: int,
    newton: Newton,
    nq: int,
    distinct_tol: float,
) -> list[np.ndarray]:
    """Solve every (point row, start) task, then observe the converged ones: one solution per
    distinct equilibrium (:func:`same_equilibrium`, ``distinct_tol`` [mm, rad] over the
    ``nq`` coordinates) and point, the copies sharing its values.

    Returns
    -------
    list of ndarray
        z (n, n_z), converged (n,), and energy, λ_min, u_z, u_r, force (n,) (NaN where not
        converged).
    """
    n = len(rows)
    z, status = solver.solve(rows, z0, u, lanes, newton)
    ok = (status == Status.CONVERGED.value) & np.all(np.isfinite(z), 1)
    obs = [np.full(n, np.nan) for _ in range(5)]
    rep = np.arange(n)
    for j in np.unique(rows[ok]):
        sel = np.flatnonzero(ok & (rows == j))
        for a, i in enumerate(sel):
            near = same_equilibrium(z[sel[:a]], z[i], nq, distinct_tol)
            if near.any():
                rep[i] = rep[sel[:a][near][0]]
    idx = np.flatnonzero(ok & (rep == np.arange(n)))
    if idx.size:
        for o, v in zip(obs, solver.observe(rows[idx], z[idx], u[idx]), strict=True):
            o[idx] = v
    copies = np.flatnonzero(ok & (rep != np.arange(n)))
    for o in obs:
        o[copies] = o[rep[copies]]
    return [z, ok, *obs]
