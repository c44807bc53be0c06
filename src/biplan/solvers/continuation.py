"""Path following through snap-through: load stepping and pseudo-arclength continuation.

``trace_path(model, method, start, load)`` follows the equilibrium branch from ``start``
while the load parameter Λ of the :class:`Control` ``load`` (end force, end displacement or
pressure) goes to ``load.stop``:

* :class:`LoadStepping` — natural-parameter continuation: Λ is stepped, the tangent predicts,
  Newton corrects. Under displacement control it passes force limit points; under force
  control it stops at the first limit point (status ``STALLED``; the tube would snap — use
  :class:`ArcLength` for the branch, or :func:`biplan.solvers.dynamics.integrate` for the jump).
* :class:`ArcLength` — pseudo-arclength continuation (Riks; Crisfield; Allgower & Georg), which
  follows the branch through limit points and snap-backs.

Steps adapt: a corrector that fails (no convergence in ``max_iterations``) halves the step
(a *cut-back*, counted in ``EquilibriumPath.stats``); easy steps (≤ 3 iterations) grow it by
``grow``, hard ones (≥ 7) shrink it. The whole loop is one compiled call on the model's system (see
:mod:`biplan.solvers.path_loop`); the recorded states are then observed in parallel
(:mod:`biplan.solvers.observation`): end force, u_z, u_r, θ, energy by fold, phase fractions, the
smallest reduced-Hessian eigenvalue and stability. Where that eigenvalue changes sign between
two steps, the crossing is located by repeated multisection (bisection generalised to
``events.MULTISECTION_POINTS`` interior points per round, :mod:`biplan.solvers.events`) on the
secant between them, and recorded as a limit point (Λ has an extremum there) or a bifurcation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from biplan._compile.numba_cache import kernel_array
from biplan._errors import ConfigError, ConvergenceError, check_integer, check_range
from biplan.model.assembly import Model
from biplan.solvers import path_loop
from biplan.solvers.control import Control
from biplan.solvers.events import insert, locate, observe_states, sign_changes
from biplan.solvers.newton import Newton, Solution, solve_equilibrium
from biplan.solvers.observation import Observation
from biplan.solvers.path_results import Critical, EquilibriumPath, Event, PathStats, PathStatus

__all__ = ["ArcLength", "LoadStepping", "trace_path"]

#: Largest contact penetration max(−w_∂) [mm] of a path state: 10 ε. With the contact
#: compliance c (``ModelOptions.contact_compliance``) a contact carrying λ_∂ closes past flat
#: by c λ_∂; a path that needs more (λ_∂ ≥ 10 N at c = 1e-6 mm/N) is pressing a tube that is
#: closed solid and stops there with ``PathStatus.FULL_CONTACT``.
FULL_CONTACT_PENETRATION = 1e-5


@dataclass(frozen=True)
class _Stepper:
    initial_step: float = 0.05
    min_step: float = 1e-7
    max_step: float = 0.25
    grow: float = 1.5
    max_steps: int = 2000
    atol: float = 1e-9
    max_iterations: int = 10
    locate_events: bool = True
    event_tolerance: float = 1e-3
    stop_at_limit_point: bool = False

    def __post_init__(self) -> None:
        name = type(self).__name__
        check_range(f"{name}.initial_step", self.initial_step, low=0.0)
        check_range(f"{name}.min_step", self.min_step, low=0.0, high=self.initial_step)
        check_range(f"{name}.max_step", self.max_step, low=self.initial_step, low_open=False)
        check_range(f"{name}.grow", self.grow, low=1.0)
        check_range(f"{name}.atol", self.atol, low=0.0)
        check_range(f"{name}.event_tolerance", self.event_tolerance, low=0.0, high=1.0)
        for attr in ("max_steps", "max_iterations"):
            object.__setattr__(
                self, attr, check_integer(f"{name}.{attr}", getattr(self, attr), low=1)
            )

    natural = True

    def loop_settings(self, load_weight: float) -> path_loop.PathSettings:
        """These settings as the compiled path loop takes them (every field of its type)."""
        return path_loop.PathSettings(
            bool(self.natural),
            float(self.initial_step),
            float(self.min_step),
            float(self.max_step),
            float(self.grow),
            int(self.max_steps),
            float(self.atol),
            int(self.max_iterations),
            float(load_weight),
            bool(self.stop_at_limit_point),
        )


@dataclass(frozen=True)
class LoadStepping(_Stepper):
    """Natural-parameter continuation: Λ advances by an adaptive step.

    Parameters
    ----------
    initial_step, min_step, max_step : float
        Steps of Λ in its own unit (N, mm or MPa).
    grow : float
        Growth factor after an easy step (≥ 1).
    max_steps : int
        Accepted steps at most.
    atol : float
        Corrector tolerance on ‖r‖∞.
    max_iterations : int
        Newton iterations per corrector before a cut-back.
    locate_events : bool
        Locate sign changes of λ_min(H_r) between steps.
    event_tolerance : float
        Relative width of the final bracket of a located event.
    stop_at_limit_point : bool
        End the path (``PathStatus.LIMIT_POINT``) at the first state past a limit point of Λ,
        where a load-controlled test would snap
        (:func:`biplan.analysis.response.loadcontrol.load_response`).
    """

    natural = True


@dataclass(frozen=True)
class ArcLength(_Stepper):
    """Pseudo-arclength continuation through limit points and snap-backs.

    Steps are arc lengths in the norm ‖(δq, δΛ)‖² = δqᵀδq + w_Λ² δΛ² (q in mm and rad;
    multipliers unweighted). Parameters as for :class:`LoadStepping`, plus:

    Parameters
    ----------
    load_weight : float
        w_Λ [1/unit of Λ · mm]: how much a change of Λ counts against a change of q.
    """

    load_weight: float = 1.0
    natural = False

    def __post_init__(self) -> None:
        super().__post_init__()
        check_range("ArcLength.load_weight", self.load_weight, low=0.0)


def _start_state(model: Model, control: Control, start: object, solver: Newton) -> Solution:
    from biplan.solvers.newton import relaxed_reference

    if start is None:
        ref = relaxed_reference(model, solver, throw=True)
        value = 0.0 if control.start is None else control.start
        return ref if value == 0.0 else _solve_at(model, control, ref, value, solver)
    if not isinstance(start, Solution):
        raise ConfigError("start", type(start).__name__, "a converged Solution or None")
    if not start.converged:
        raise ConfigError("start", start.status.name, "a converged Solution")
    value = (
        control.value_of(start.load, start.displacement, start.force, model)
        if control.start is None
        else control.start
    )
    return _solve_at(model, control, start, value, solver)


def _solve_at(
    model: Model, control: Control, start: Solution, value: float, solver: Newton
) -> Solution:
    sol = solve_equilibrium(model, solver, start, control.load(model, value))
    if not sol.converged:
        raise ConfigError(
            "start",
            f"{control.kind.value} = {value:g}",
            f"a state that is an equilibrium at the start value ({sol.message})",
        )
    return sol


def trace_path(
    model: Model,
    method: LoadStepping | ArcLength | None = None,
    start: Solution | None = None,
    load: Control | None = None,
    *,
    throw: bool = False,
) -> EquilibriumPath:
    """Follow the equilibrium path of ``model`` under the controlled load ``load``.

    Parameters
    ----------
    model : Model
    method : LoadStepping or ArcLength, optional
        Default ``ArcLength()``.
    start : Solution, optional
        Converged starting state; default the relaxed reference (Λ = 0).
    load : Control
        The controlled quantity and its final value.
    throw : bool
        Raise :class:`~biplan.ConvergenceError` instead of returning a path whose status is
        not ``ok`` (default ``False``, as for every driver).

    Returns
    -------
    EquilibriumPath
        Check ``path.status``: ``COMPLETED`` when Λ reached ``control.stop``; otherwise the
        path up to the last converged state, with the reason in ``path.message``
        (``FULL_CONTACT``: the tube is pressed shut, :data:`FULL_CONTACT_PENETRATION`).
    """
    if load is None:
        raise ConfigError("load", None, "a Control (Control.force / displacement / pressure)")
    if not isinstance(load, Control):
        raise ConfigError("load", type(load).__name__, "a biplan Control")
    control = load
    method = ArcLength() if method is None else method
    if not isinstance(method, LoadStepping | ArcLength):
        raise ConfigError("method", type(method).__name__, "LoadStepping or ArcLength")
    solver = Newton(atol=method.atol)
    first = _start_state(model, control, start, solver)
    load_parameter0 = control.value_of(first.load, first.displacement, first.force, model)
    ctl = control.coefficients(model)
    weight = getattr(method, "load_weight", 1.0)
    if load_parameter0 == control.stop:
        raise ConfigError(
            "control.stop", control.stop, f"a value other than the start {load_parameter0:g}"
        )

    system = model.system()
    z, load_parameter, tang, steps, its, count, cutbacks, code = path_loop.path_loop(
        system.data,
        kernel_array(first.z, float),
        float(load_parameter0),
        kernel_array(ctl, float),
        float(control.stop),
        method.loop_settings(weight),
    )
    z, load_parameter, tang = z[:count], load_parameter[:count], tang[:count]
    steps, its = steps[:count], its[:count]
    obs = observe_states(model, z, ctl, load_parameter)
    status = PathStatus.from_code(int(code))
    if count > 1 and not np.all(np.isfinite(z)):
        status = PathStatus.NONFINITE

    events: list[Event] = []
    inserted: list[tuple[int, np.ndarray, float]] = []
    solid = np.flatnonzero(obs.penetration > FULL_CONTACT_PENETRATION)
    if solid.size:
        count = max(int(solid[0]), 1)
        z, load_parameter, tang, steps, its = (
            z[:count],
            load_parameter[:count],
            tang[:count],
            steps[:count],
            its[:count],
        )
        obs = Observation(*(v[:count] for v in obs))
        status = PathStatus.FULL_CONTACT
    if method.locate_events and count > 1:
        for i in sign_changes(obs.min_eigenvalue):
            found = locate(
                model,
                ctl,
                z[i],
                load_parameter[i],
                z[i + 1],
                load_parameter[i + 1],
                obs,
                i,
                method,
                weight,
            )
            if found is None:
                continue
            zi, li, width = found
            kind = (
                Critical.LIMIT_POINT if tang[i, -1] * tang[i + 1, -1] < 0 else Critical.BIFURCATION
            )
            inserted.append((i, zi, li))
            events.append(
                Event(
                    kind=kind,
                    step=-1,
                    load_parameter=li,
                    force=np.nan,
                    displacement=np.nan,
                    tolerance=width,
                )
            )
    if inserted:
        z, load_parameter, tang, steps, its, flags = insert(
            z, load_parameter, tang, steps, its, inserted
        )
        obs = observe_states(model, z, ctl, load_parameter)
        idx = np.flatnonzero(flags)
        events = [
            Event(
                e.kind,
                int(k),
                float(load_parameter[k]),
                float(obs.force[k]),
                float(obs.displacement[k]),
                e.tolerance,
            )
            for e, k in zip(events, idx, strict=True)
        ]
    else:
        flags = np.zeros(len(load_parameter), bool)

    stats = PathStats(
        n_steps=count - 1,
        n_cutbacks=int(cutbacks),
        newton_iterations=int(its.sum()),
        n_events=len(events),
        smallest_step=float(steps[1:].min()) if count > 1 else float("nan"),
        largest_step=float(steps[1:].max()) if count > 1 else float("nan"),
    )
    path = EquilibriumPath.build(
        model=model,
        control=control,
        method=type(method).__name__,
        z=z,
        load_parameter=load_parameter,
        observation=obs,
        event_flags=flags,
        events=tuple(events),
        status=status,
        stats=stats,
        direction=tang[:, -1],
    )
    if throw and not path.status.ok:
        raise ConvergenceError(f"path under {control}: {path.message}")
    return path
