"""Load-controlled response: what a force- or pressure-controlled test does.

A test that holds the end force F (or the internal pressure p) and raises it slowly follows a
stable branch of equilibria. Where that branch loses stability (a limit point of the load, or
a bifurcation at which a fold starts to transform on its own) the tube cannot follow the load
any further: it snaps, at that load, to a stable state on another branch, and the test goes
on from there. :func:`load_response` reproduces that sequence:

1. pseudo-arclength continuation (:func:`~biplan.solvers.continuation.trace_path`) from the
   start toward the stop value, ending at the first limit point of the load;
2. the stable stretch of that path up to the first loss of stability, which the continuation
   has located (sign change of λ_min(H_r), to ``ArcLength.event_tolerance`` of the step);
3. the landing state: a proximal-point descent at the fixed load
   (:func:`~biplan.analysis.response.quasistatic.proximal_descent`) from the state at the loss
   of stability, displaced along the most unstable mode of the first unstable state beyond it
   (in the sense the path was leaving in; both senses at a symmetric bifurcation, or along the
   softest mode of the last state where the branch turned back); the stable equilibrium of lowest
   potential Π − F z_p that differs from the start of the descent. A landing state that is
   itself the end of its branch (a neighbouring fold pushed past its peak) snaps again at the
   same load: a cascade, recorded as successive snaps;
4. from there, step 1 again, until the stop value is reached.

The result is one :class:`~biplan.solvers.path_results.EquilibriumPath` of stable states with
``segment`` (branch index per state) and ``snaps`` (:class:`~biplan.solvers.path_results.Snap`:
where, at what load, which folds went, how the landing was found). The equilibrium path
through unstable states, a numerical device, is
:func:`~biplan.solvers.continuation.trace_path` itself.
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import Any

import numpy as np

from biplan._errors import ConfigError, check_integer
from biplan.analysis.response.quasistatic import KICK, proximal_descent
from biplan.analysis.stability import Verdict, reduced_hessian
from biplan.model.assembly import Model
from biplan.solvers.continuation import ArcLength, trace_path
from biplan.solvers.control import Control
from biplan.solvers.newton import Newton, Solution, solve_equilibrium
from biplan.solvers.path_results import Critical, EquilibriumPath, PathStats, PathStatus, Snap
from biplan.solvers.results import fold_names

__all__ = [
    "LANDING",
    "MAX_SNAPS",
    "PEAK_METHOD",
    "PEAK_SEARCH_FORCE",
    "first_snap",
    "load_response",
]

#: How :func:`load_response` finds the state a snap lands in.
LANDING = "descent at fixed load"
#: Most snaps of one response.
MAX_SNAPS = 64
#: Force [N] up to which :func:`first_snap` looks for the first loss of stability.
PEAK_SEARCH_FORCE = 100.0
#: Continuation settings of the located phase-1 peak: those of ``biplan respond`` (its
#: ``--step`` 0.05 and ``--max-step`` 0.1), so that every command reports the same number.
PEAK_METHOD = ArcLength(initial_step=0.05, max_step=0.1)
#: A turn of the load on stable states is re-traced with TURN_REFINEMENT times shorter steps,
#: at most TURN_ROUNDS times, until the neighbours of the turn are within TURN_TOLERANCE
#: (relative) of it.
TURN_REFINEMENT = 16
TURN_ROUNDS = 3
TURN_TOLERANCE = 1e-5
#: |cos| between the most unstable mode and the path's last secant above which only the
#: sense the path was leaving in is descended.
ALIGNED = 0.1
#: A descent that ends within this distance (max |Δq| [mm, rad]) of its start went nowhere.
SAME_STATE = 1e-3
#: Relative load increments tried when no descent leaves the state at the located load.
LOAD_NUDGES = (0.0, 1e-5, 1e-4, 1e-3)

#: Statuses of a stretch whose stable branch ended before the stop value: it turned back.
_BRANCH_ENDS = (PathStatus.RETURNED, PathStatus.LIMIT_POINT)

_PER_STEP = (
    "load_parameter", "force", "displacement", "u_z", "u_r", "theta", "energy",
    "helical_energy", "circular_energy", "fold_energy", "phase_fraction", "min_eigenvalue",
    "stable", "constraint_residual", "is_event", "direction", "q", "z",
)  # fmt: skip


def load_response(
    model: Model,
    control: Control,
    method: ArcLength | None = None,
    start: Solution | None = None,
    *,
    stop_at_snap: bool = False,
    max_snaps: int = MAX_SNAPS,
) -> EquilibriumPath:
    """The response of a load-controlled test (force or pressure), snaps included.

    Parameters
    ----------
    model : Model
    control : Control
        Force F [N] or pressure p [MPa] and its stop value.
    method : ArcLength, optional
        Continuation settings of the stable stretches (default :data:`PEAK_METHOD`); its
        ``stop_at_limit_point`` is set.
    start : Solution, optional
        A converged stable state; default the relaxed reference.
    stop_at_snap : bool
        End at the first loss of stability (status ``SNAPPED``; the snap is recorded without
        a landing).
    max_snaps : int
        Most snaps before the response ends (status ``MAX_STEPS``).

    Returns
    -------
    EquilibriumPath
        The stable states in order of load, with ``segment`` and ``snaps``. ``status``:
        ``COMPLETED`` at the stop value; ``SNAPPED`` at the first snap when asked;
        ``NO_LANDING`` when no stable state was found at a snap load; otherwise the status of
        the last stretch (e.g. ``FULL_CONTACT``, ``STALLED``).
    """
    if control.is_displacement:
        raise ConfigError(
            "control", control.kind.value, "force or pressure (displacement: displacement_sweep)"
        )
    check_integer("max_snaps", max_snaps, low=0)
    method = replace(PEAK_METHOD if method is None else method, stop_at_limit_point=True)
    solver = Newton(atol=method.atol)
    pieces: list[EquilibriumPath] = []
    snaps: list[Snap] = []
    current, lam_start = start, control.start
    while True:
        stretch = trace_path(model, method, current, replace(control, start=lam_start))
        if not bool(stretch.stable[0]):
            raise ConfigError("start", "an unstable state", "a stable equilibrium")
        end = _first_unstable(stretch)
        if end is None and stretch.status not in _BRANCH_ENDS:
            pieces.append(stretch)
            status = stretch.status
            break
        # The stable branch ends at state k: the largest load before the first unstable state
        # (the located event, or the last stable state, before it) — a load that turns back
        # on stable states (a kink or a contact) ends it too: past the turn, no equilibrium
        # nearby carries more load.
        sense = float(np.sign(control.stop - stretch.load_parameter[0]))
        k, end = _stable_end(stretch, end, sense)
        for _ in range(TURN_ROUNDS):
            if (
                end is not None
                or k == 0
                or _critical(stretch, k, end)[1] <= _turn_tolerance(stretch, k)
            ):
                break
            stretch = _refine_turn(model, method, control, stretch, k)
            k, end = _stable_end(stretch, _first_unstable(stretch), sense)
        head = _head(stretch, k + 1)
        pieces.append(head)
        offset = sum(p.n_steps for p in pieces) - 1
        critical, tolerance = _critical(stretch, k, end)
        load_parameter, force, before = (
            float(head.load_parameter[-1]), float(head.force[-1]), float(head.displacement[-1])
        )  # fmt: skip
        if stop_at_snap or len(snaps) >= max_snaps:
            snaps.append(
                Snap(offset, load_parameter, force, before, float("nan"), critical, (),
                     "not computed (stopped at the snap)", tolerance)
            )  # fmt: skip
            status = PathStatus.SNAPPED if stop_at_snap else PathStatus.MAX_STEPS
            break
        landed = _land(model, control, stretch, k, end, solver)
        if landed is None:
            status = PathStatus.NO_LANDING
            break
        current, lam_start = landed
        after = float(current.displacement)
        snaps.append(
            Snap(offset, load_parameter, force, before, after, critical, (), LANDING, tolerance)
        )
    result = _join(pieces, tuple(snaps), status)
    return replace(result, snaps=tuple(_with_folds(result, s) for s in result.snaps))


def first_snap(
    model: Model, up_to: float = PEAK_SEARCH_FORCE, method: ArcLength | None = None
) -> Snap | None:
    """The first loss of stability under force control from the relaxed reference: the
    phase-1 peak force, located (its ``tolerance``), or None below ``up_to`` [N].

    ``method`` defaults to :data:`PEAK_METHOD`."""
    response = load_response(model, Control.force(up_to), method, stop_at_snap=True)
    return response.snaps[0] if response.snaps else None


def _stable_end(path: EquilibriumPath, end: int | None, sense: float) -> tuple[int, int | None]:
    """(k, end): the largest load before the first unstable state ``end``; ``end`` becomes
    None when the load turned back on stable states before it."""
    last = path.n_steps if end is None else end
    k = int(np.argmax(path.load_parameter[:last] * sense))
    return k, (end if k == last - 1 else None)


def _turn_tolerance(path: EquilibriumPath, k: int) -> float:
    """The tolerance a turn of the load is located to: :data:`TURN_TOLERANCE` relative."""
    return TURN_TOLERANCE * max(abs(float(path.load_parameter[k])), 1.0)


def _refine_turn(
    model: Model, method: ArcLength, control: Control, path: EquilibriumPath, k: int
) -> EquilibriumPath:
    """``path`` with the steps around a turn of the load at state ``k`` traced again from
    state k − 1 with :data:`TURN_REFINEMENT` times shorter steps."""
    j = min(k + 1, path.n_steps - 1)
    span = float(
        np.hypot(np.linalg.norm(path.q[j] - path.q[k - 1]),
                 path.load_parameter[j] - path.load_parameter[k - 1])
    )  # fmt: skip
    ds = max(span / TURN_REFINEMENT, 10 * method.min_step)
    fine = replace(method, initial_step=ds, max_step=ds, min_step=min(method.min_step, ds / 10))
    start = solve_equilibrium(
        model,
        Newton(atol=method.atol),
        path.z[k - 1],
        control.load(model, float(path.load_parameter[k - 1])),
    )
    if not start.converged:
        return path
    again = trace_path(
        model, fine, start, replace(control, start=float(path.load_parameter[k - 1]))
    )
    return _concat([_head(path, k - 1), again])


def _first_unstable(path: EquilibriumPath) -> int | None:
    """Index of the first state (past the start) that is unstable and not a located event."""
    bad = np.flatnonzero(~path.stable[1:] & ~path.is_event[1:])
    return int(bad[0]) + 1 if bad.size else None


def _critical(path: EquilibriumPath, k: int, end: int | None) -> tuple[Critical, float]:
    """What was lost at state ``k`` (the last kept) and the located tolerance in Λ."""
    for e in path.events:
        if e.step == k:
            return e.kind, e.tolerance
    if end is None:  # the load turned back after state k: located to its neighbours
        near = path.load_parameter[max(k - 1, 0) : k + 2]
        return Critical.LIMIT_POINT, float(np.max(np.abs(near - path.load_parameter[k])))
    return Critical.LOSS_OF_STABILITY, abs(float(path.load_parameter[end] - path.load_parameter[k]))


def _head(path: EquilibriumPath, n: int) -> EquilibriumPath:
    """The first ``n`` states of a path (events beyond them dropped)."""
    cut = {f.name: getattr(path, f.name)[:n] for f in fields(path) if f.name in _PER_STEP}
    return replace(path, events=tuple(e for e in path.events if e.step < n), **cut)


def _potential(sol: Solution) -> float:
    """Π − F z_p [N·mm] at a load-controlled state (the end force F does the work)."""
    return float(sol.energy - sol.force * sol.displacement)


def _land(
    model: Model, control: Control, path: EquilibriumPath, k: int, end: int | None, solver: Newton
) -> tuple[Solution, float] | None:
    """The stable state the tube snaps to from state ``k`` of ``path`` (see the module
    docstring), with the load at which it was found, or None.

    The descents (:func:`_directions`) start at state ``k`` displaced by :data:`KICK`, at its
    load; if none leaves ``k``, they are repeated at loads nudged toward the stop value by
    :data:`LOAD_NUDGES`, where state ``k`` is no longer an equilibrium."""
    load_parameter = float(path.load_parameter[k])
    origin = solve_equilibrium(model, solver, path.z[k], control.load(model, load_parameter))
    if not origin.converged:
        return None
    directions = _directions(model, control, path, k, end, solver, origin)
    for nudge in LOAD_NUDGES:
        value = load_parameter + nudge * max(abs(load_parameter), 1.0) * float(
            np.sign(control.stop - load_parameter)
        )
        load = control.load(model, value)
        best: Solution | None = None
        for d in directions:
            found = proximal_descent(
                model, origin, load, solver, direction=d, amplitude=KICK, polish_every=3
            )
            if found is None or found[1].verdict is not Verdict.STABLE:
                continue
            sol = found[0]
            if float(np.max(np.abs(sol.q - origin.q))) < SAME_STATE:
                continue
            if best is None or _potential(sol) < _potential(best) - 1e-12:
                best = sol
        if best is not None:
            return best, float(value)
    return None


def _directions(
    model: Model,
    control: Control,
    path: EquilibriumPath,
    k: int,
    end: int | None,
    solver: Newton,
    origin: Solution,
) -> list[np.ndarray]:
    """Senses of descent from state ``k``: the most unstable mode of state ``end`` in the sense
    the path was leaving in (both senses when the mode is nearly orthogonal to the path: a
    symmetric bifurcation); without ``end`` (the branch turned back at ``k``) the softest mode
    of ``k`` itself, both senses."""
    state = origin
    if end is not None:
        lam_end = float(path.load_parameter[end])
        beyond = solve_equilibrium(model, solver, path.z[end], control.load(model, lam_end))
        state = beyond if beyond.converged else origin
    h, basis = reduced_hessian(model, state)
    if h.size == 0:
        return []
    _, vec = np.linalg.eigh(h)
    v = basis @ vec[:, 0]
    if state is origin:
        return [v, -v]
    secant = path.q[end] - path.q[k]
    cos = float(v @ secant) / max(float(np.linalg.norm(v) * np.linalg.norm(secant)), 1e-300)
    return [float(np.sign(cos)) * v] if abs(cos) > ALIGNED else [v, -v]


def _concat(pieces: list[EquilibriumPath]) -> EquilibriumPath:
    """The states of the paths in order, as one path (events renumbered, stats summed)."""
    first = pieces[0]
    arrays: dict[str, Any] = {
        name: np.concatenate([getattr(p, name) for p in pieces], axis=0) for name in _PER_STEP
    }
    offsets = np.cumsum([0] + [p.n_steps for p in pieces[:-1]])
    events = tuple(
        replace(e, step=e.step + int(o)) for p, o in zip(pieces, offsets, strict=True)
        for e in p.events
    )  # fmt: skip
    stats = [p.stats for p in pieces if p.stats is not None]
    total = PathStats(
        n_steps=sum(s.n_steps for s in stats),
        n_cutbacks=sum(s.n_cutbacks for s in stats),
        newton_iterations=sum(s.newton_iterations for s in stats),
        n_events=len(events),
        smallest_step=min((s.smallest_step for s in stats), default=float("nan")),
        largest_step=max((s.largest_step for s in stats), default=float("nan")),
    )
    return replace(first, events=events, stats=total, status=pieces[-1].status, **arrays)


def _join(
    pieces: list[EquilibriumPath], snaps: tuple[Snap, ...], status: PathStatus
) -> EquilibriumPath:
    """One EquilibriumPath of the stretches in order, with ``segment``, ``snaps`` and ``status``."""
    segment = np.concatenate([np.full(p.n_steps, i) for i, p in enumerate(pieces)])
    return replace(_concat(pieces), method="stable", status=status, segment=segment, snaps=snaps)


def _with_folds(path: EquilibriumPath, snap: Snap) -> Snap:
    """The snap with the folds whose dominant phase differs between its two states."""
    if snap.step + 1 >= path.n_steps:
        return snap
    before = np.argmax(path.phase_fraction[snap.step], axis=-1)
    after = np.argmax(path.phase_fraction[snap.step + 1], axis=-1)
    names = fold_names(path.model)
    return replace(snap, folds=tuple(names[i] for i in np.flatnonzero(before != after)))
