"""The first instability under force control, located exactly, and its design sensitivities.

Under force control a stable branch ends where λ_min of the reduced Hessian (MODEL §12,
without the end-displacement constraint) reaches zero: at a limit point of the load F* the
force-controlled KKT Jacobian is singular, so the branch is parametrised by the load-point
displacement U instead, where the displacement-controlled system (MODEL §11, d = 1) stays
regular. On that branch, with z(U, v) the displacement-controlled equilibrium and v the design
parameters (:mod:`biplan.analysis.sensitivity.parameters`)::

    g(U, v) = λ_min^F(z(U, v), v) = 0                       (defines U*(v))
    dU*/dv  = −(dg/dv) / (dg/dU)
    dF*/dv  = dF/dv + (dF/dU) dU*/dv,       F = −μ (the reaction)

with the total derivatives dg/dv, dg/dU, dF/dv, dF/dU of
:func:`biplan.analysis.sensitivity.equilibrium.
total_derivatives` (implicit differentiation through z; dλ_min by the derivative of a simple
eigenvalue). At a limit point of the load dF/dU = 0, so dF*/dv is the derivative at fixed U*.

:func:`locate_limit_point` finds U* by Newton's method on g(U) from the first snap of the
load-controlled response (:func:`~biplan.analysis.response.loadcontrol.load_response`, located
there to
the continuation's event tolerance), to |g| below ``tolerance``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from biplan._errors import ConfigError, ConvergenceError
from biplan.analysis.response.loadcontrol import PEAK_SEARCH_FORCE, load_response
from biplan.analysis.sensitivity.equilibrium import (
    Observable,
    Sensitivity,
    eigen_weights,
    total_derivatives,
)
from biplan.analysis.sensitivity.parameters import AngleParameter, design_parameters
from biplan.model.assembly import Load, Model
from biplan.solvers.control import Control
from biplan.solvers.newton import Newton, Solution, solve_equilibrium

__all__ = ["LimitPoint", "limit_point_sensitivity", "locate_limit_point"]

#: Newton steps of :func:`locate_limit_point`.
MAX_ITERATIONS = 40
#: Halvings of a Newton step on U whose equilibrium solve fails (the step went past the
#: displacement-controlled branch's own turn, where no equilibrium exists).
MAX_HALVINGS = 12
#: A Newton step on U below this (relative to max(|U|, 1 mm)) ends the search: U* is found
#: to rounding.
STEP_TOLERANCE = 1e-13
_ROWS = (Observable.MIN_EIGENVALUE, Observable.FORCE, Observable.DISPLACEMENT)


@dataclass(frozen=True)
class LimitPoint:
    """The located first instability under force control.

    Attributes
    ----------
    force : float
        F* [N], the end force there.
    displacement : float
        U* [mm], the load-point displacement there.
    min_eigenvalue : float
        λ_min^F at the returned state (|·| below the tolerance).
    iterations : int
        Newton steps on U.
    state : Solution
        The displacement-controlled equilibrium at U*.
    """

    force: float
    displacement: float
    min_eigenvalue: float
    iterations: int
    state: Solution = field(repr=False)


def _eigen_derivative(model: Model, state: Solution) -> tuple[np.ndarray, np.ndarray]:
    """(y, dy/dv) of λ_min^F, F and z_p at a displacement-controlled state."""
    found = eigen_weights(model, state, load_constraint=False)
    if found is None:
        raise ConvergenceError(
            f"limit point: the state at U = {state.displacement:.6g} mm is contact-locked "
            "(no free direction, no λ_min)"
        )
    pset = design_parameters(model, state.load)
    return total_derivatives(model, state, pset, found[:2], rows=_ROWS)


def _start(model: Model, up_to: float) -> Solution:
    """The last stable state before the first snap under force control, as a
    displacement-controlled solution."""
    path = load_response(model, Control.force(up_to), stop_at_snap=True)
    if not path.snaps:
        raise ConvergenceError(f"limit point: no loss of stability under force up to {up_to} N")
    k = path.snaps[0].step
    z = np.array(path.z[k], dtype=float)
    z[-1] = -float(path.force[k])  # μ = −F
    return solve_equilibrium(
        model, Newton(atol=1e-12), z, Load.of_displacement(float(path.displacement[k]))
    )


def locate_limit_point(
    model: Model,
    start: Solution | None = None,
    *,
    up_to: float = PEAK_SEARCH_FORCE,
    tolerance: float = 1e-10,
    method: Newton | None = None,
) -> LimitPoint:
    """The first loss of stability under force control, located by Newton's method on
    λ_min^F(z(U)) = 0 along the displacement-controlled branch (module docstring).

    Parameters
    ----------
    model : Model
    start : Solution, optional
        A displacement-controlled equilibrium near the limit point (e.g. the ``state`` of a
        :class:`LimitPoint` of a nearby design). Default: from the first snap of the
        force-controlled response up to ``up_to`` [N].
    tolerance : float
        |λ_min^F| at which the search stops [H_r units] (it stops too when the Newton step
        on U falls below :data:`STEP_TOLERANCE` relative).
    method : Newton, optional
        Default ``Newton(atol=1e-13)``.

    Returns
    -------
    LimitPoint

    Raises
    ------
    ConvergenceError
        No snap below ``up_to``; a solve on the branch failed; the state is contact-locked;
        or λ_min^F does not reach zero smoothly (a kink or contact change ends the branch).
    """
    method = method or Newton(atol=1e-13)
    if start is not None and not start.load.is_displacement_controlled:
        raise ConfigError("start", "force control", "a displacement-controlled Solution")
    state = _start(model, up_to) if start is None else start
    z, u = state.z, float(state.load.displacement)
    u_good, step, halvings = u, 0.0, 0
    for it in range(MAX_ITERATIONS + 1):
        trial = solve_equilibrium(model, method, z, Load.of_displacement(u))
        if not trial.converged:
            # past the branch's own turn in U (a snap-back): no equilibrium there; shorter
            # steps from the last converged state (the limit point of F comes before it)
            if it == 0 or halvings == MAX_HALVINGS:
                raise ConvergenceError(
                    f"limit point: solve at U = {u:.10g} mm ({halvings} step halvings from "
                    f"U = {u_good:.10g} mm): {trial.message}"
                )
            step, halvings = 0.5 * step, halvings + 1
            u = u_good + step
            continue
        state, u_good, halvings = trial, u, 0
        y, dy = _eigen_derivative(model, state)
        slope = dy[0, -1]
        step = -y[0] / slope if slope != 0 else np.inf
        if abs(y[0]) < tolerance or abs(step) < STEP_TOLERANCE * max(abs(u), 1.0):
            return LimitPoint(float(y[1]), float(y[2]), float(y[0]), it, state)
        if not np.isfinite(step) or abs(step) > 0.5:
            break
        z, u = state.z, u + step
    raise ConvergenceError(
        f"limit point: λ_min^F did not reach zero smoothly near U = {u:.6g} mm "
        f"(λ_min^F = {y[0]:.3g}; the branch may end at a contact change or kink)"
    )


def limit_point_sensitivity(
    model: Model,
    limit: LimitPoint | None = None,
    parameters: tuple[str, ...] | None = None,
    *,
    angle: AngleParameter | str = AngleParameter.HELICAL_ANGLE,
    per_fold: bool = False,
) -> Sensitivity:
    """dF*/dv and dU*/dv of the first instability under force control (module docstring).

    Parameters
    ----------
    model : Model
    limit : LimitPoint, optional
        Default :func:`locate_limit_point` of ``model``.
    parameters : tuple of str, optional
        Design parameter names (default all; the load is not a parameter here).

    Returns
    -------
    Sensitivity
        Observables ``limit_force`` [N] and ``limit_displacement`` [mm].
    """
    limit = locate_limit_point(model) if limit is None else limit
    state = limit.state
    found = eigen_weights(model, state, load_constraint=False)
    if found is None:  # pragma: no cover - locate_limit_point refuses these
        raise ConvergenceError("limit point: contact-locked state")
    pset = design_parameters(model, state.load, angle=AngleParameter(angle), per_fold=per_fold)
    y, dy = total_derivatives(model, state, pset, found[:2], rows=_ROWS)
    g_u = dy[0, -1]
    du = -dy[0, :-1] / g_u
    df = dy[1, :-1] + dy[1, -1] * du
    names = pset.names[:-1] if parameters is None else tuple(parameters)
    cols = [pset.index(n) for n in names]
    if len(pset.parameters) - 1 in cols:
        raise ConfigError("parameters", "load.displacement", "design parameters (not the load)")
    return Sensitivity(
        (Observable.LIMIT_FORCE, Observable.LIMIT_DISPLACEMENT),
        tuple(pset.parameters[j] for j in cols),
        np.asarray([y[1], y[2]]),
        np.stack([df[cols], du[cols]]),
        state,
    )
