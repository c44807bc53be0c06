"""Solvers: equilibrium (Newton/KKT), path following, dynamics."""

from biplan.solvers.continuation import ArcLength as ArcLength
from biplan.solvers.continuation import LoadStepping as LoadStepping
from biplan.solvers.continuation import trace_path as trace_path
from biplan.solvers.control import Control as Control
from biplan.solvers.control import ControlKind as ControlKind
from biplan.solvers.dynamics import BackwardEuler as BackwardEuler
from biplan.solvers.dynamics import GeneralizedAlpha as GeneralizedAlpha
from biplan.solvers.dynamics import LoadHistory as LoadHistory
from biplan.solvers.dynamics import integrate as integrate
from biplan.solvers.newton import Newton as Newton
from biplan.solvers.newton import Solution as Solution
from biplan.solvers.newton import Status as Status
from biplan.solvers.newton import relaxed_reference as relaxed_reference
from biplan.solvers.newton import solve_equilibrium as solve_equilibrium
from biplan.solvers.path_results import Critical as Critical
from biplan.solvers.path_results import EquilibriumPath as EquilibriumPath
from biplan.solvers.path_results import Event as Event
from biplan.solvers.path_results import PathStatus as PathStatus
from biplan.solvers.trajectory_results import Trajectory as Trajectory
from biplan.solvers.trajectory_results import TrajectoryStatus as TrajectoryStatus

__all__ = [
    "ArcLength",
    "BackwardEuler",
    "Control",
    "ControlKind",
    "Critical",
    "EquilibriumPath",
    "Event",
    "GeneralizedAlpha",
    "LoadHistory",
    "LoadStepping",
    "Newton",
    "PathStatus",
    "Solution",
    "Status",
    "Trajectory",
    "TrajectoryStatus",
    "integrate",
    "relaxed_reference",
    "solve_equilibrium",
    "trace_path",
]
