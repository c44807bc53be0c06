"""The equilibrium a quasi-static test reaches at a given load, from the relaxed reference.

Under force control it is the last state of the force-controlled response
(:func:`~biplan.analysis.response.loadcontrol.load_response`: stable branches, snaps located and
landed); under displacement control the last state of the stable-branch displacement sweep
(:func:`~biplan.analysis.response.quasistatic.displacement_sweep`, steps of :data:`SWEEP_STEP` mm).
Either is re-solved at the load to ‖r‖∞ < :data:`ATOL`, the precision the design sensitivities
(:mod:`biplan.analysis.sensitivity.equilibrium`) are computed at.
"""

from __future__ import annotations

import math

import numpy as np

from biplan._errors import ConvergenceError
from biplan.analysis.response.loadcontrol import load_response
from biplan.analysis.response.quasistatic import displacement_sweep
from biplan.model.assembly import Load, Model
from biplan.solvers.control import Control
from biplan.solvers.newton import Newton, Solution, relaxed_reference, solve_equilibrium

__all__ = ["ATOL", "SWEEP_STEP", "reached_state"]

#: Step [mm] of the displacement sweep.
SWEEP_STEP = 0.05
#: Residual tolerance of the returned state.
ATOL = 1e-12


def reached_state(model: Model, load: Load) -> Solution:
    """The state a quasi-static test reaches at ``load`` from the relaxed reference.

    Parameters
    ----------
    model : Model
    load : Load
        End force F [N] or load-point displacement U [mm].

    Returns
    -------
    Solution
        Converged to ‖r‖∞ < :data:`ATOL`.

    Raises
    ------
    ConvergenceError
        The response ended short of F (it says where and why), a sweep step failed, or the
        final re-solve failed.
    """
    solver = Newton(atol=ATOL)
    if load.is_displacement_controlled:
        u = float(load.displacement)
        n = max(math.ceil(abs(u) / SWEEP_STEP), 1)
        path = displacement_sweep(
            model, np.linspace(u / n, u, n), start=relaxed_reference(model, throw=True)
        )
        last = path.solutions[-1]
        if not last.converged:
            raise ConvergenceError(f"the displacement sweep failed at U = {u:g} mm: {last.message}")
        z = last.z
    else:
        f = float(load.force)
        if f == 0.0:
            return relaxed_reference(model, solver, throw=True)
        response = load_response(model, Control.force(f))
        if not response.completed:
            raise ConvergenceError(
                f"the force-controlled response ended at F = {response.force[-1]:.6g} N, short "
                f"of {f:g} N: {response.message}"
            )
        z = response.z[-1]
    sol = solve_equilibrium(model, solver, z, load)
    if not sol.converged:
        raise ConvergenceError(f"re-solve of the state reached at {load}: {sol.message}")
    return sol
