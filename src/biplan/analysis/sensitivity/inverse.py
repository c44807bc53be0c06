"""Inverse design: the design parameters that give a wanted response, by gradient-based least
squares on the exact design sensitivities.

A :class:`Target` asks for one observable at a load, of a named stable state of a tube with
bistable folds, or for the first instability under force control; its text form is
``OBSERVABLE[/l0]=VALUE[@F=FORCE | @U=DISPLACEMENT | @state=LABEL]``::

    u_z/l0=0.06@F=1.6       u_z / l0 = 0.06 at the end force F = 1.6 N  (l0 = N l)
    u_r=-0.2@U=3            u_r = −0.2 mm at the load-point displacement U = 3 mm
    force=1.2@U=2           the reaction 1.2 N at U = 2 mm
    u_z/l0=0.9@state=66     u_z / l0 = 0.9 in the stable state 66 at zero end load
    limit_force=1.5         the first-instability force F* = 1.5 N
    limit_displacement=0.4  its load-point displacement U* = 0.4 mm

Observables: those of :class:`~biplan.analysis.sensitivity.equilibrium.Observable` (``u_z``,
``u_r``,
``theta``, ``force``, ``energy``, ``displacement``, ``min_eigenvalue`` at a load;
``limit_force``, ``limit_displacement`` without one).

:func:`inverse_design` varies the named design parameters (:mod:`._parameters`) within their
valid ranges to minimise Σ ((y_i − t_i) / s_i)², s_i = max(|t_i|, :data:`SCALE_FLOOR`), with
``scipy.optimize.least_squares`` (trust-region reflective, bounds), the Jacobian from
:func:`~biplan.analysis.sensitivity.equilibrium.total_derivatives` (and
:func:`~biplan.analysis.sensitivity.limit_point.limit_point_sensitivity`). Each evaluation
re-solves the
targets' states from the previous design's (a continuation in the design); a state that cannot
be followed is found again from the relaxed reference
(:func:`~biplan.analysis.response.reached.reached_state`), and a named state that cannot be followed
(or that changed its fold states or lost its stability) from its own seed
(:func:`~biplan.analysis.states.search.relax_state`). Several starts (the given design, then points
drawn in ±:data:`SPREAD` around it within the ranges) are tried until one meets every target.
"""

from __future__ import annotations

import math

import numpy as np

from biplan._errors import BiplanError, ConfigError, ConvergenceError
from biplan.analysis.response.reached import reached_state
from biplan.analysis.sensitivity.equilibrium import Observable, eigen_weights, total_derivatives
from biplan.analysis.sensitivity.limit_point import (
    LimitPoint,
    limit_point_sensitivity,
    locate_limit_point,
)
from biplan.analysis.sensitivity.parameters import ParameterSet, design_parameters
from biplan.analysis.sensitivity.targets import DesignResult, Target, check_targets
from biplan.analysis.stability import Verdict, classify
from biplan.analysis.states.labels import bits_to_label
from biplan.analysis.states.search import relax_state, state_bits
from biplan.model.assembly import Load, Model
from biplan.solvers.newton import Newton, Solution, solve_equilibrium

__all__ = ["DesignResult", "Target", "check_targets", "inverse_design"]

#: Smallest residual scale s_i [target units].
SCALE_FLOOR = 1e-3
#: Relative spread of the random starts around the given design.
SPREAD = 0.3
#: Scaled residual of every target at a design where a target's state is lost.
LOST = 1e3


class _Evaluator:
    """The targets and their derivatives at parameter values, warm-started design to design."""

    def __init__(self, model: Model, targets: tuple[Target, ...], pset: ParameterSet,
                 cols: list[int]) -> None:  # fmt: skip
        self.model, self.targets, self.pset, self.cols = model, targets, pset, cols
        self.states: dict[int, Solution] = {}
        self.limit: LimitPoint | None = None
        self.count = 0
        self.last: tuple[tuple[float, ...], np.ndarray, np.ndarray] | None = None

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = tuple(float(v) for v in x)
        if self.last is not None and self.last[0] == key:
            return self.last[1], self.last[2]
        v = self.pset.values.copy()
        v[self.cols] = x
        moved = self.pset.model_at(self.model, v)[0]
        names = [self.pset.names[j] for j in self.cols]
        y = np.zeros(len(self.targets))
        jac = np.zeros((len(self.targets), len(self.cols)))
        pitch = float(moved.params.geometry.pitch)
        l0 = moved.tube.n_modules * pitch
        for i, t in enumerate(self.targets):
            y[i], jac[i] = self._one(moved, i, t, names)
            if t.per_length:  # y / (N l)
                if "geometry.pitch" in names:
                    jac[i, names.index("geometry.pitch")] -= y[i] / pitch
                y[i], jac[i] = y[i] / l0, jac[i] / l0
        self.count += 1
        self.last = (key, y, jac)
        return y, jac

    def _one(self, moved: Model, i: int, t: Target, names: list[str]) -> tuple[float, np.ndarray]:
        if t.load is None:
            self.limit = _follow_limit(moved, self.limit)
            sens = limit_point_sensitivity(moved, self.limit, tuple(names))
            row = sens.observables.index(t.observable)
            return float(sens.values[row]), sens.derivatives[row]
        if t.state is not None:
            state = _follow_state(moved, self.states.get(i), t.state)
        else:
            state = _follow(moved, self.states.get(i), t.load)
        self.states[i] = state
        pset = design_parameters(moved, t.load)
        weights = None
        if t.observable is Observable.MIN_EIGENVALUE:
            found = eigen_weights(moved, state)
            if found is None:
                raise ConvergenceError(f"{t.label}: the state is contact-locked (no λ_min)")
            weights = found[:2]
        y, dy = total_derivatives(moved, state, pset, weights, rows=(t.observable,))
        return float(y[0]), dy[0, [pset.index(n) for n in names]]


def _follow(model: Model, previous: Solution | None, load: Load) -> Solution:
    """The state at ``load`` followed from the previous design's, else reached anew."""
    if previous is not None:
        sol = solve_equilibrium(model, Newton(atol=1e-12), previous, load)
        if sol.converged:
            return sol
    return reached_state(model, load)


def _follow_state(model: Model, previous: Solution | None, label: str) -> Solution:
    """The named stable state followed from the previous design's while it keeps its fold
    states and its stability, else relaxed anew from its seed."""
    if previous is not None:
        sol = solve_equilibrium(model, Newton(atol=1e-12), previous, Load.of_force(0.0))
        if (
            sol.converged
            and bits_to_label(state_bits(model, sol.q)) == label
            and classify(model, sol).verdict is Verdict.STABLE
        ):
            return sol
    return relax_state(model, label)


def _follow_limit(model: Model, previous: LimitPoint | None) -> LimitPoint:
    if previous is not None:
        try:
            return locate_limit_point(model, previous.state)
        except BiplanError:
            pass
    return locate_limit_point(model)


def _starts(pset: ParameterSet, cols: list[int], n: int, seed: int) -> list[np.ndarray]:
    """The given design, then n − 1 points drawn within ±SPREAD of it inside the ranges."""
    x0 = pset.values[cols]
    low, high = _bounds(pset, cols)
    rng = np.random.default_rng(seed)
    out = [x0]
    for _ in range(n - 1):
        x = x0 * (1.0 + rng.uniform(-SPREAD, SPREAD, x0.size))
        out.append(np.clip(x, *_inside(low, high)))
    return out


def _bounds(pset: ParameterSet, cols: list[int]) -> tuple[np.ndarray, np.ndarray]:
    low = np.asarray([pset.parameters[j].low for j in cols])
    high = np.asarray([pset.parameters[j].high for j in cols])
    return low, high


def _inside(low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The open ranges shrunk by a small margin (the bounds themselves are invalid designs)."""
    span = np.where(np.isfinite(high - low), high - low, np.abs(low) + 1.0)
    margin = 1e-6 * np.where(np.isfinite(span), span, 1.0)
    return low + margin, high - margin


def inverse_design(
    model: Model,
    targets: tuple[Target | str, ...],
    vary: tuple[str, ...],
    *,
    starts: int = 3,
    tolerance: float = 1e-6,
    max_evaluations: int = 60,
    seed: int = 0,
) -> DesignResult:
    """The design parameters ``vary`` that give ``targets`` (module docstring).

    Parameters
    ----------
    model : Model
        The starting design.
    targets : tuple of Target or str
    vary : tuple of str
        Design parameter names (:func:`~biplan.analysis.sensitivity.parameters.design_parameters`;
        not
        the load).
    starts : int
        Most starts, ≥ 1 (the search stops at the first that meets every target).
    tolerance : float
        Relative tolerance of a met target.
    max_evaluations : int
        Most evaluations per start.
    seed : int
        Of the random starts.

    Returns
    -------
    DesignResult
        The best design found (``success`` False when a target is not met).

    Raises
    ------
    ConfigError
        An unknown or repeated parameter, the load among ``vary``, a malformed target, no
        target or nothing to vary.
    ConvergenceError
        Every start failed (a target's state or limit point could not be found).
    """
    from scipy.optimize import least_squares

    wanted = tuple(t if isinstance(t, Target) else Target.parse(t) for t in targets)
    if not wanted:
        raise ConfigError("targets", (), "at least one target")
    if not vary or len(set(vary)) != len(vary):
        raise ConfigError("vary", vary, "one or more distinct design parameters")
    pset = design_parameters(model, Load.of_force(0.0))
    cols = [pset.index(name) for name in vary]
    if len(pset.parameters) - 1 in cols:
        raise ConfigError("vary", "load.force", "design parameters (the load is in the targets)")
    check_targets(model.tube, wanted)
    goal = np.asarray([t.value for t in wanted])
    scale = np.maximum(np.abs(goal), SCALE_FLOOR)
    evaluate = _Evaluator(model, wanted, pset, cols)
    lost: list[str] = []

    def residual(x: np.ndarray) -> np.ndarray:
        # A design where a target's state is lost (a named state no longer stable, a branch
        # that cannot be followed) counts as far from every target: the trust region shrinks.
        try:
            return (evaluate(x)[0] - goal) / scale
        except BiplanError as err:
            if evaluate.last is None:
                raise
            lost.append(str(err))
            return np.full(goal.size, LOST)

    def jacobian(x: np.ndarray) -> np.ndarray:
        try:
            return evaluate(x)[1] / scale[:, None]
        except BiplanError:
            assert evaluate.last is not None
            return evaluate.last[2] / scale[:, None]

    low, high = _inside(*_bounds(pset, cols))
    best: tuple[float, np.ndarray, str] | None = None
    tried = 0
    for x0 in _starts(pset, cols, starts, seed):
        tried += 1
        try:
            fit = least_squares(
                residual,
                x0,
                jac=jacobian,
                bounds=(low, high),
                x_scale=np.maximum(np.abs(x0), 1e-3),
                xtol=1e-14, ftol=1e-14, gtol=1e-14,
                max_nfev=max_evaluations,
            )  # fmt: skip
            cost, x, note = float(2 * fit.cost), fit.x, str(fit.message)
        except BiplanError as err:
            note = f"start {tried} failed: {err}"
            if best is None:
                best = (math.inf, x0, note)
            continue
        if best is None or cost < best[0]:
            best = (cost, x, note)
        y = evaluate(x)[0]
        if np.all(np.abs(y - goal) <= tolerance * scale):
            break
    assert best is not None
    cost, x, note = best
    if not math.isfinite(cost):
        raise ConvergenceError(f"inverse design: every start failed; {note}")
    y, jac = evaluate(x)
    v = pset.values.copy()
    v[cols] = x
    return DesignResult(
        names=tuple(vary),
        values=np.asarray(x),
        start=pset.values[cols],
        targets=wanted,
        achieved=y,
        met=np.abs(y - goal) <= tolerance * scale,
        jacobian=jac,
        tube=pset.tube_at(model.tube, v),
        iterations=evaluate.count,
        starts=tried,
        message=note + (f"; {len(lost)} trial designs lost a target's state" if lost else ""),
    )
