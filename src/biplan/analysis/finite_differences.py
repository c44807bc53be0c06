"""Finite-difference baselines of the design sensitivities: full re-solves, not derivatives.

:func:`finite_differences` differences the observables of :func:`~biplan.analysis.
sensitivity.sensitivity` by re-solving the equilibrium for each perturbed design (central
differences, two Newton solves per parameter, each started from the base state);
:func:`limit_point_finite_differences` does the same for the located first instability
(:func:`~biplan.analysis.limit_point.locate_limit_point` again per perturbed design). Both
perturb through the same parameter map (:meth:`~biplan.analysis._parameters.ParameterSet.
model_at`). They are the checks of the implicit derivatives (tests) and the baseline of their
benchmark (``benchmarks/bench_sensitivity.py``).
"""

from __future__ import annotations

import numpy as np

from biplan._errors import ConvergenceError
from biplan.analysis._parameters import AngleParameter, design_parameters
from biplan.analysis.limit_point import LimitPoint, locate_limit_point
from biplan.analysis.sensitivity import (
    STATE_OBSERVABLES,
    Observable,
    Sensitivity,
    check_state,
    eigen_weights,
    observable,
)
from biplan.assembly import Model
from biplan.solvers.newton import Newton, Solution, solve_equilibrium

__all__ = ["finite_differences", "limit_point_finite_differences", "observe"]


def observe(model: Model, state: Solution, observables: tuple[Observable, ...]) -> np.ndarray:
    """The values of ``observables`` at ``state``, computed from the solution (not the
    kernel): what :func:`finite_differences` differences."""
    e = model.endpoint(state.q)
    found = eigen_weights(model, state) if Observable.MIN_EIGENVALUE in observables else None
    values = {
        Observable.U_Z: e.u_z,
        Observable.U_R: e.u_r,
        Observable.THETA: e.theta,
        Observable.FORCE: state.force,
        Observable.ENERGY: state.energy,
        Observable.DISPLACEMENT: state.displacement,
        Observable.MIN_EIGENVALUE: float("inf") if found is None else found[2],
    }
    return np.asarray([values[o] for o in observables])


def finite_differences(
    model: Model,
    state: Solution,
    observables: tuple[Observable | str, ...] | None = None,
    parameters: tuple[str, ...] | None = None,
    *,
    relative_step: float = 1e-5,
    solver: Newton | None = None,
    angle: AngleParameter | str = AngleParameter.HELICAL_ANGLE,
    per_fold: bool = False,
) -> Sensitivity:
    """The derivatives of :func:`sensitivity` by central finite differences of full re-solves
    (a check and a baseline; two Newton solves per parameter, each from ``state``).

    Parameters
    ----------
    relative_step : float
        Step h = relative_step · max(|p|, 1) [parameter unit].
    solver : Newton, optional
        Default ``Newton(atol=1e-13)``.

    Raises
    ------
    ConvergenceError
        If a re-solve fails (it names the parameter and value).
    """
    check_state(model, state)
    disp = state.load.is_displacement_controlled
    if observables is None:
        observables = tuple(o for o in STATE_OBSERVABLES if disp or o is not Observable.FORCE)
    obs = tuple(observable(o) for o in observables)
    pset = design_parameters(model, state.load, angle=AngleParameter(angle), per_fold=per_fold)
    names = pset.names if parameters is None else tuple(parameters)
    cols = [pset.index(n) for n in names]
    solver = solver or Newton(atol=1e-13)
    base = pset.values
    out = np.zeros((len(obs), len(cols)))
    for k, j in enumerate(cols):
        h = relative_step * max(abs(base[j]), 1.0)
        sides = []
        for sign in (1.0, -1.0):
            v = base.copy()
            v[j] += sign * h
            moved, load = pset.model_at(model, v)
            sol = solve_equilibrium(moved, solver, state.z, load)
            if not sol.converged:
                raise ConvergenceError(
                    f"finite-difference re-solve at {pset.names[j]} = {v[j]:.10g}: {sol.message}"
                )
            sides.append(observe(moved, sol, obs))
        out[:, k] = (sides[0] - sides[1]) / (2 * h)
    values = observe(model, state, obs)
    return Sensitivity(obs, tuple(pset.parameters[j] for j in cols), values, out, state)


def limit_point_finite_differences(
    model: Model,
    limit: LimitPoint,
    parameters: tuple[str, ...] | None = None,
    *,
    relative_step: float = 1e-5,
) -> Sensitivity:
    """dF*/dv and dU*/dv by central finite differences of limit points located again
    (:func:`locate_limit_point` from ``limit.state``) for each perturbed design: a check."""
    pset = design_parameters(model, limit.state.load)
    names = pset.names[:-1] if parameters is None else tuple(parameters)
    base = pset.values
    out = np.zeros((2, len(names)))
    for k, name in enumerate(names):
        j = pset.index(name)
        h = relative_step * max(abs(base[j]), 1.0)
        found = []
        for sign in (1.0, -1.0):
            v = base.copy()
            v[j] += sign * h
            moved, _ = pset.model_at(model, v)
            lp = locate_limit_point(moved, limit.state, tolerance=0.0)
            found.append((lp.force, lp.displacement))
        out[:, k] = (np.asarray(found[0]) - np.asarray(found[1])) / (2 * h)
    return Sensitivity(
        (Observable.LIMIT_FORCE, Observable.LIMIT_DISPLACEMENT),
        tuple(pset.parameters[pset.index(n)] for n in names),
        np.asarray([limit.force, limit.displacement]),
        out,
        limit.state,
    )
