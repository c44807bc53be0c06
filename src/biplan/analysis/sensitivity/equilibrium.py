"""Sensitivities of an equilibrium to the design, by implicit differentiation of the KKT system.

At a converged state z = [q, λ, λ_∂, μ] the residual vanishes, r(z, v) = 0 (MODEL §11,
:func:`biplan.model.lagrangian.residual`), for the design parameters v (:mod:`._parameters`: R, l, β
or b, every law coefficient and transition, the load). The implicit function theorem gives
the change of the state with the design and, for an observable y(z, v), its total derivative::

    J dz/dv = −∂r/∂v,        dy/dv = ∂y/∂v + ∂y/∂z · dz/dv = ∂y/∂v − ψᵀ ∂r/∂v,   Jᵀ ψ = ∂y/∂zᵀ

with J = ∂r/∂z the KKT Jacobian (:func:`biplan.model.lagrangian.kkt_jacobian`). ∂r/∂v, ∂y/∂z and
∂y/∂v come from JAX autodiff through the traced model parameters; the adjoint form (one solve
with Jᵀ per observable) is used when there are fewer observables than parameters, the direct
form (one solve with J per parameter) otherwise. The contact rows are the smoothed
Fischer–Burmeister function (SI Eq. sfb), so r is differentiable with contacts active; the
derivatives are those of the regularised system the solver converged.

Observables (:class:`Observable`): the endpoint u_z, u_r [mm] and θ [rad] (MODEL R2), the end
force [N] (the applied F, or the reaction F = −μ under displacement control), the strain
energy Π [N·mm], the load-point displacement z_p [mm], and λ_min of the reduced Hessian
H_r = Nᵀ K N (MODEL §12; mixed units of K). λ_min is a simple eigenvalue of the constrained
problem min xᵀ K x subject to A x = 0, ‖x‖ = 1 (A: the active constraint rows), so with its
unit eigenvector x and the multipliers η of Aᵀ η = K x − λ_min x::

    dλ_min = xᵀ dK x − 2 ηᵀ dA x

(the derivative of the Lagrangian of that problem), evaluated as the total derivative of
y(z, v) = xᵀ K(z, v) x − 2 ηᵀ A(z, v) x with x and η held: the same adjoint then carries
K's change through dz/dv. The active set is the stability analysis's (MODEL CHOICE S1) and
is held fixed.

The first-instability (limit-point) force and displacement:
:mod:`biplan.analysis.sensitivity.limit_point`.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from biplan._compile.setup import jax, jnp
from biplan._compile.traced import traced
from biplan._errors import ConfigError
from biplan.analysis.sensitivity.observables import (
    ROWS,
    SIMPLE_GAP,
    Mode,
    Observable,
    Sensitivity,
    observable,
)
from biplan.analysis.sensitivity.parameters import (
    AngleParameter,
    Maps,
    Parameter,
    ParameterSet,
    apply,
    design_parameters,
)
from biplan.analysis.stability import active_contacts, null_space
from biplan.geometry.chain import endpoint
from biplan.geometry.layout import TubeLayout
from biplan.model.assembly import Model
from biplan.model.lagrangian import curvature, kkt_jacobian, residual
from biplan.model.potential import energy, load_height
from biplan.solvers.newton import Solution

__all__ = [
    "AngleParameter",
    "Mode",
    "Observable",
    "Parameter",
    "ParameterSet",
    "Sensitivity",
    "design_parameters",
    "eigen_weights",
    "sensitivity",
    "total_derivatives",
]

Array = Any


# --- the kernels -------------------------------------------------------------------------------
#: Rows of the first-order kernel (every row of :data:`ROWS` but λ_min).
_FIRST_ORDER = ROWS[:-1]


def _observables(layout: TubeLayout, p: Any, z: Array, load: Any) -> Array:
    """The first-order observables (the rows of :data:`_FIRST_ORDER`) at z."""
    q = z[: layout.n_coordinates]
    e = endpoint(layout, p.geometry, q)
    d = load.displacement_control
    force = (1.0 - d) * load.force - d * z[-1]
    return jnp.stack(
        [e.u_z, e.u_r, e.theta, force, energy(layout, p, q), load_height(layout, p, q)]
    )


@traced("sensitivity", statics=3)
def _first_order(
    layout: TubeLayout,
    angle: AngleParameter,
    displacement_control: bool,
    maps: Maps,
    v: Array,
    z: Array,
) -> tuple:
    """(y, ∂y/∂z, ∂y/∂v, J, ∂r/∂v) at (v, z) of the first-order observables, compiled once per
    layout and parameter map (forward mode: cheaper to compile than reverse here)."""

    def observe(v: Array, z: Array, maps: Maps) -> Array:
        p, load = apply(maps, angle, displacement_control, v)
        return _observables(layout, p, z, load)

    def res(v: Array, z: Array, maps: Maps) -> Array:
        p, load = apply(maps, angle, displacement_control, v)
        return residual(layout, p, z, load)

    p, load = apply(maps, angle, displacement_control, v)
    y_v, y_z = jax.jacfwd(observe, argnums=(0, 1))(v, z, maps)
    r_v = jax.jacfwd(res)(v, z, maps)
    return observe(v, z, maps), y_z, y_v, kkt_jacobian(layout, p, z, load), r_v


@traced("min_eigenvalue_sensitivity", statics=3)
def _eigen(
    layout: TubeLayout,
    angle: AngleParameter,
    displacement_control: bool,
    maps: Maps,
    v: Array,
    z: Array,
    x: Array,
    eta: Array,
) -> tuple:
    """(y, ∂y/∂z, ∂y/∂v) of y = xᵀ K x − 2 ηᵀ A x (the λ_min row; module docstring), compiled
    only when λ_min is asked for (third derivatives of the energy: the costliest kernel)."""

    def observe(v: Array, z: Array, maps: Maps, x: Array, eta: Array) -> Array:
        p, load = apply(maps, angle, displacement_control, v)
        return curvature(layout, p, z, load, x, eta)

    y_v, y_z = jax.jacfwd(observe, argnums=(0, 1))(v, z, maps, x, eta)
    return observe(v, z, maps, x, eta), y_z, y_v


def eigen_weights(
    model: Model, state: Solution, *, load_constraint: bool | None = None
) -> tuple[np.ndarray, np.ndarray, float, float] | None:
    """(x, η, λ_min, gap) of the reduced Hessian at ``state`` (None when contact-locked).

    x (n_q,) is the unit eigenvector of λ_min in q, η (n_g + n_c + 1,) the multipliers of the
    constraint rows [g; w_∂; z_p] (zero on inactive rows) with Aᵀ η = K x − λ_min x, and gap
    the distance to the next eigenvalue (λ_min is simple when it is clearly > 0).

    Parameters
    ----------
    load_constraint : bool, optional
        Include the prescribed end displacement in the active set (default: under displacement
        control, as :func:`~biplan.analysis.stability.classify`). ``False`` at a
        displacement-controlled state gives the force-control stability of the same state.
    """
    if load_constraint is None:
        load_constraint = state.load.is_displacement_controlled
    k = state.data.lagrangian_hessian
    jc = state.data.constraint_jacobian
    ng = model.n_guides
    rows = np.zeros(jc.shape[0], dtype=bool)
    rows[:ng] = True
    rows[ng : ng + model.n_contacts] = active_contacts(model, state)
    rows[-1] = load_constraint
    a = jc[rows]
    basis = null_space(a)
    if basis.shape[1] == 0:
        return None
    h = basis.T @ k @ basis
    w, vec = np.linalg.eigh(0.5 * (h + h.T))
    x = basis @ vec[:, 0]
    eta = np.zeros(jc.shape[0])
    eta[rows] = np.linalg.lstsq(a.T, k @ x - w[0] * x, rcond=None)[0]
    gap = float(w[1] - w[0]) if w.size > 1 else float("inf")
    return x, eta, float(w[0]), gap


def total_derivatives(
    model: Model,
    state: Solution,
    parameters: ParameterSet,
    weights: tuple[np.ndarray, np.ndarray] | None = None,
    mode: Mode = Mode.AUTO,
    rows: tuple[Observable, ...] = ROWS,
) -> tuple[np.ndarray, np.ndarray]:
    """(y, dy/dv): the kernel's observables ``rows`` and their total derivatives (n, n_par)
    with respect to every parameter of ``parameters``, at a converged ``state``.

    ``weights`` = (x, η) of :func:`eigen_weights` (zeros when None: λ_min row meaningless).
    """
    x, eta = weights if weights is not None else (np.zeros(model.n_coordinates), None)
    if eta is None:
        eta = np.zeros(model.n_guides + model.n_contacts + 1)
    key = (model.layout, parameters.angle, parameters.displacement_control)
    f64 = functools.partial(jnp.asarray, dtype=jnp.float64)
    v, z = f64(parameters.values), f64(state.z)
    out = _first_order.compiled(*key)(parameters.maps, v, z)
    y, y_z, y_v, jac, r_v = (np.asarray(a) for a in out)
    if Observable.MIN_EIGENVALUE in rows:
        e, e_z, e_v = _eigen.compiled(*key)(parameters.maps, v, z, f64(x), f64(eta))
        y = np.append(y, float(e))
        y_z, y_v = np.vstack([y_z, np.asarray(e_z)]), np.vstack([y_v, np.asarray(e_v)])
    pick = [ROWS.index(o) for o in rows]
    y, y_z, y_v = y[pick], y_z[pick], y_v[pick]
    adjoint = mode is Mode.ADJOINT or (mode is Mode.AUTO and len(pick) < r_v.shape[1])
    try:
        if adjoint:
            psi = np.linalg.solve(jac.T, y_z.T)
            return y, y_v - psi.T @ r_v
        return y, y_v - y_z @ np.linalg.solve(jac, r_v)
    except np.linalg.LinAlgError:
        raise ConfigError(
            "state", "a singular KKT Jacobian", "a regular equilibrium (not a limit point)"
        ) from None


def sensitivity(
    model: Model,
    state: Solution,
    observables: tuple[Observable | str, ...] | None = None,
    parameters: tuple[str, ...] | None = None,
    *,
    angle: AngleParameter | str = AngleParameter.HELICAL_ANGLE,
    per_fold: bool = False,
    mode: Mode | str = Mode.AUTO,
) -> Sensitivity:
    """Derivatives of observables of an equilibrium with respect to design parameters.

    Parameters
    ----------
    model : Model
    state : Solution
        A converged equilibrium of ``model`` (force or displacement control).
    observables : tuple of Observable or str, optional
        Default: u_z, u_r, θ, energy, λ_min, the load-point displacement and, under
        displacement control, the end force (the reaction −μ); λ_min is left out of the
        default where it has no derivative (a contact-locked state, a repeated eigenvalue),
        and ``Sensitivity.left_out`` says why.
    parameters : tuple of str, optional
        Names of :func:`~biplan.analysis.sensitivity.parameters.design_parameters` (default all).
    angle : AngleParameter
        β (``helical_angle``, degrees) or ``b`` as the crease-angle parameter.
    per_fold : bool
        Every fold's law as its own parameters.
    mode : Mode
        ``auto`` (adjoint when fewer observables than parameters), ``adjoint`` or ``direct``.

    Returns
    -------
    Sensitivity

    Raises
    ------
    ConfigError
        On a state that did not converge or is not of this model, an unknown observable or
        parameter, λ_min asked for by name at a contact-locked state (no free direction) or
        where it is a repeated eigenvalue, or a singular KKT Jacobian.
    """
    obs, pset, cols = request(model, state, observables, parameters, angle, per_fold)
    weights = None
    left_out: tuple[str, ...] = ()
    if Observable.MIN_EIGENVALUE in obs:
        found = eigen_weights(model, state)
        why = ""
        if found is None:
            why = "at a contact-locked state (no H_r)"
        elif found[3] <= SIMPLE_GAP * max(abs(found[2]), 1.0):
            why = f"where λ_min = {found[2]:.6g} is repeated (gap {found[3]:.2g}: no derivative)"
        else:
            weights = found[:2]
        if why and observables is not None:  # asked for by name: refused
            raise ConfigError("observables", "min_eigenvalue", f"left out {why}")
        if why:  # the default set: said, not refused
            obs = tuple(o for o in obs if o is not Observable.MIN_EIGENVALUE)
            left_out = (f"min_eigenvalue is left out {why}",)
    y, dy = total_derivatives(model, state, pset, weights, Mode(mode), obs)
    params = tuple(pset.parameters[j] for j in cols)
    return Sensitivity(obs, params, y, dy[:, cols], state, left_out)


def request(
    model: Model,
    state: Solution,
    observables: tuple[Observable | str, ...] | None,
    parameters: tuple[str, ...] | None,
    angle: AngleParameter | str,
    per_fold: bool,
) -> tuple[tuple[Observable, ...], ParameterSet, list[int]]:
    """A checked request: the observables (default those of the state's control), the
    parameter set and the positions of the parameters asked for (default all)."""
    check_state(model, state)
    disp = state.load.is_displacement_controlled
    if observables is None:
        observables = tuple(o for o in ROWS if disp or o is not Observable.FORCE)
    obs = tuple(observable(o) for o in observables)
    pset = design_parameters(model, state.load, angle=AngleParameter(angle), per_fold=per_fold)
    names = pset.names if parameters is None else tuple(parameters)
    return obs, pset, [pset.index(name) for name in names]


def check_state(model: Model, state: Solution) -> None:
    if not isinstance(state, Solution):
        raise ConfigError("state", type(state).__name__, "a biplan Solution")
    if state.z.shape != (model.n_unknowns,):
        raise ConfigError("state", state.z.shape, "a Solution of this model")
    if not state.converged:
        raise ConfigError("state", state.status.name, "a converged Solution")
