"""The equilibrium solves of the stability map's search
(:mod:`biplan.analysis.maps.stability_map`): many (point, start) tasks under displacement
control, and the observation of the distinct equilibria they converge to.

:class:`CompiledTasks` holds the compiled :class:`~biplan.model.system.System` of each point:
the tasks of a point are solved in parallel by :func:`biplan.solvers.batch.solve_tasks` (the
compiled Newton, one compilation per install) and observed by
:func:`biplan.solvers.observation.observe`. :func:`solve_and_observe` solves the tasks and
observes one solution per distinct equilibrium and point (the copies share its values).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from biplan.analysis.maps.stability_search import same_equilibrium
from biplan.model.assembly import Model
from biplan.model.system import System
from biplan.solvers import batch
from biplan.solvers.newton import Newton, Status
from biplan.solvers.observation import observe

__all__ = ["CompiledTasks", "solve_and_observe"]


def _displacement_loads(u: np.ndarray) -> np.ndarray:
    """(F, U, d) rows (k, 3) of displacement control at U = u [mm]."""
    u = np.asarray(u, dtype=float)
    return np.ascontiguousarray(np.stack([np.zeros_like(u), u, np.ones_like(u)], axis=1))


@dataclass(frozen=True)
class CompiledTasks:
    """The tasks of the points of one group on the compiled System of every point (module
    docstring).

    Parameters
    ----------
    systems : list of System
        The System of each point (row).
    weak_contacts : bool
        The layout's S1 reading ``weak_contacts_active`` (the stability test's active set).
    """

    systems: list[System]
    weak_contacts: bool

    @classmethod
    def of(cls, models: Sequence[Model]) -> CompiledTasks:
        """The tasks of the points ``models`` (one layout)."""
        weak = bool(models[0].layout.options.weak_contacts_active)
        return cls([m.system() for m in models], weak)

    def solve(
        self, rows: np.ndarray, z0: np.ndarray, u: np.ndarray, newton: Newton
    ) -> tuple[np.ndarray, np.ndarray]:
        """(z (n, n_z), Status values (n,)) of the tasks: point ``rows`` (n,), start ``z0``
        (n, n_z), prescribed load-point displacement ``u`` [mm] (n,); each task's result is
        one :func:`biplan.solvers.iteration.newton` solve."""
        s = newton.loop_settings()
        z = np.array(z0, dtype=float)
        status = np.empty(len(rows), dtype=np.int64)
        for j in np.unique(rows):
            sel = np.flatnonzero(rows == j)
            start = np.ascontiguousarray(z0[sel], dtype=float)
            out = batch.solve_tasks(self.systems[j].data, start, _displacement_loads(u[sel]), s)
            z[sel], status[sel] = out[0], out[1]
        return z, status

    def observe(self, rows: np.ndarray, z: np.ndarray, u: np.ndarray) -> list[np.ndarray]:
        """Energy [N·mm], λ_min [N/mm], u_z [mm], u_r [mm] and end force [N] of states z
        (k, n_z) of points ``rows`` at displacements ``u`` [mm]."""
        out = [np.empty(len(rows)) for _ in range(5)]
        for j in np.unique(rows):
            sel = np.flatnonzero(rows == j)
            ob = observe(
                self.systems[j].data, z[sel], _displacement_loads(u[sel]), self.weak_contacts
            )
            for o, v in zip(out, (ob.energy, ob.min_eigenvalue, ob.u_z, ob.u_r, ob.force),
                            strict=True):  # fmt: skip
                o[sel] = v
        return out


def solve_and_observe(
    tasks: CompiledTasks,
    rows: np.ndarray,
    z0: np.ndarray,
    u: np.ndarray,
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
    z, status = tasks.solve(rows, z0, u, newton)
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
        for o, v in zip(obs, tasks.observe(rows[idx], z[idx], u[idx]), strict=True):
            o[idx] = v
    copies = np.flatnonzero(ok & (rep != np.arange(n)))
    for o in obs:
        o[copies] = o[rep[copies]]
    return [z, ok, *obs]
