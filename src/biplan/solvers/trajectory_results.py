"""The result of time integration: :class:`Trajectory` with its :class:`TrajectoryStatus` and
:class:`TrajectoryStats`.

A trajectory converts to an ``xarray.Dataset`` (dim ``time``) with
:meth:`Trajectory.to_dataset` (:mod:`biplan.solvers.results`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from biplan._errors import ResultStatus
from biplan.model.assembly import Model
from biplan.solvers.control import Control
from biplan.solvers.results import ENERGY_BALANCE, OBSERVABLES, Labelled, LabelledResult

__all__ = ["Trajectory", "TrajectoryStats", "TrajectoryStatus"]


class TrajectoryStatus(ResultStatus):
    """Why a time integration ended."""

    COMPLETED = 0, "reached t_end", True
    STEP_FAILED = 1, "a time step did not converge even at the smallest step"
    NONFINITE = 2, "the state became non-finite"


@dataclass(frozen=True)
class TrajectoryStats:
    """Work done by a time integration."""

    n_steps: int
    n_rejected: int
    newton_iterations: int
    smallest_step: float
    largest_step: float
    max_constraint_residual: float  # [mm]


@dataclass(frozen=True)
class Trajectory(LabelledResult):
    """A time history (one entry per saved time).

    Attributes
    ----------
    time : ndarray [s]
    force, displacement, u_z, u_r, theta, energy, … : as for
        :class:`~biplan.solvers.path_results.EquilibriumPath`
    kinetic_energy, external_work, dissipated_energy : ndarray [N·mm]
    total_energy : ndarray [N·mm]
        Kinetic + strain − external work + dissipated (conserved by an exact integrator).
    q, velocity : ndarray (time, n_q)
    status : TrajectoryStatus
    stats : TrajectoryStats
    """

    model: Model = field(repr=False)
    control: Control
    method: str
    time: np.ndarray
    load_parameter: np.ndarray
    force: np.ndarray
    displacement: np.ndarray
    u_z: np.ndarray
    u_r: np.ndarray
    theta: np.ndarray
    energy: np.ndarray
    helical_energy: np.ndarray
    circular_energy: np.ndarray
    fold_energy: np.ndarray
    phase_fraction: np.ndarray
    min_eigenvalue: np.ndarray
    stable: np.ndarray
    constraint_residual: np.ndarray
    kinetic_energy: np.ndarray
    external_work: np.ndarray
    dissipated_energy: np.ndarray
    total_energy: np.ndarray
    q: np.ndarray = field(repr=False)
    velocity: np.ndarray = field(repr=False)
    z: np.ndarray = field(repr=False)
    status: TrajectoryStatus = TrajectoryStatus.COMPLETED
    stats: TrajectoryStats | None = None
    _dim: str = field(default="time", repr=False)

    @property
    def completed(self) -> bool:
        return self.status is TrajectoryStatus.COMPLETED

    @property
    def message(self) -> str:
        s = self.stats
        extra = f"; {s.n_steps} steps, {s.n_rejected} rejected" if s else ""
        return f"{self.status.message}{extra}"

    def _variables(self) -> dict[str, np.ndarray]:
        names = (*OBSERVABLES, *ENERGY_BALANCE, "q", "velocity")
        return {n: getattr(self, n) for n in names}

    def _attrs(self) -> dict[str, Any]:
        return {"method": self.method, "status": self.status.name, "message": self.message}

    def labelled(self) -> Labelled:
        out = super().labelled()
        time = ("time", np.asarray(self.time), {"units": "s"})
        return replace(out, coords={**out.coords, "time": time})
