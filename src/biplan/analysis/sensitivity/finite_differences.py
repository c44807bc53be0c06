"""Finite-difference baselines of the design sensitivities: full re-solves, not derivatives.

:func:`finite_differences` differences the observables of :func:`~biplan.analysis.
sensitivity.sensitivity` by re-solving the equilibrium for each perturbed design (central
differences, two Newton solves per parameter, each started from the base state);
:func:`limit_point_finite_differences` does the same for the located first instability
(:func:`~biplan.analysis.sensitivity.limit_point.locate_limit_point` again per perturbed design).
Both
perturb through the same parameter map (:meth:`~biplan.analysis.sensitivity.parameters.ParameterSet.
model_at`). They are the checks of the implicit derivatives (tests) and the baseline of their
benchmark (``benchmarks/bench_sensitivity.py``).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from biplan._errors import ConvergenceError
from biplan.analysis.sensitivity.equilibrium import (
    Observable,
    Sensitivity,
    eigen_weights,
    request,
)
from biplan.analysis.sensitivity.limit_point import LimitPoint, locate_limit_point
from biplan.analysis.sensitivity.parameters import AngleParameter, ParameterSet, design_parameters
from biplan.model.assembly import Model
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
    relative_step: float = 1e-4,
    method: Newton | None = None,
    angle: AngleParameter | str = AngleParameter.HELICAL_ANGLE,
    per_fold: bool = False,
) -> Sensitivity:
    """The derivatives of :func:`sensitivity` by central finite differences of full re-solves
    (a check and a baseline; two Newton solves per parameter, each from ``state``).

    Parameters
    ----------
    relative_step : float
        Step h = relative_step · max(|p|, 1) [parameter unit]. The default balances the
        truncation error (∝ h²) against the re-solves' rounding (∝ 1/h): on the test designs
        it gives the implicit derivatives to ~1e-6 relative, against ~1e-5 at 1e-5 or 1e-3.
    method : Newton, optional
        Default ``Newton(atol=1e-13)``.

    Raises
    ------
    ConvergenceError
        If a re-solve fails (it names the parameter and value).
    """
    obs, pset, cols = request(model, state, observables, parameters, angle, per_fold)
    method = method or Newton(atol=1e-13)

    def resolve(v: np.ndarray) -> np.ndarray:
        moved, load = pset.model_at(model, v)
        sol = solve_equilibrium(moved, method, state.z, load)
        if not sol.converged:
            raise ConvergenceError(
                f"finite-difference re-solve at {_where(pset, v)}: {sol.message}"
            )
        return observe(moved, sol, obs)

    out = _central(pset.values, cols, relative_step, resolve)
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
    cols = [pset.index(n) for n in names]

    def relocate(v: np.ndarray) -> np.ndarray:
        lp = locate_limit_point(pset.model_at(model, v)[0], limit.state, tolerance=0.0)
        return np.asarray([lp.force, lp.displacement])

    out = _central(pset.values, cols, relative_step, relocate)
    return Sensitivity(
        (Observable.LIMIT_FORCE, Observable.LIMIT_DISPLACEMENT),
        tuple(pset.parameters[j] for j in cols),
        np.asarray([limit.force, limit.displacement]),
        out,
        limit.state,
    )


def _central(
    base: np.ndarray,
    cols: list[int],
    relative_step: float,
    evaluate: Callable[[np.ndarray], np.ndarray],
) -> np.ndarray:
    """Central differences (n_out, len(cols)) of ``evaluate`` at ``base`` along each column,
    step h = relative_step · max(|v_j|, 1)."""
    columns = []
    for j in cols:
        h = relative_step * max(abs(base[j]), 1.0)
        sides = []
        for sign in (1.0, -1.0):
            v = base.copy()
            v[j] += sign * h
            sides.append(evaluate(v))
        columns.append((sides[0] - sides[1]) / (2 * h))
    return np.stack(columns, axis=1)


def _where(pset: ParameterSet, v: np.ndarray) -> str:
    """The parameters that differ from the base design, as ``name = value``."""
    moved = np.flatnonzero(v != pset.values)
    return ", ".join(f"{pset.names[j]} = {v[j]:.10g}" for j in moved) or "the base design"
