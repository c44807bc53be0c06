"""Solvers: equilibrium (Newton/KKT), path following, dynamics."""

from biplan.solvers.newton import Newton as Newton
from biplan.solvers.newton import Solution as Solution
from biplan.solvers.newton import Status as Status
from biplan.solvers.newton import relaxed_reference as relaxed_reference
from biplan.solvers.newton import solve_equilibrium as solve_equilibrium

__all__ = ["Newton", "Solution", "Status", "relaxed_reference", "solve_equilibrium"]
