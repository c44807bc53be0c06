"""Displacement-controlled quasi-static sweep with stable-branch selection.

Each step prescribes the load-point displacement U_k, warm-starts Newton from the previous
equilibrium and classifies the result with the reduced Hessian. When the equilibrium reached
is unstable (for example the symmetric state of folds in series past the force peak), the
sweep descends from it along its most unstable eigenmode (both signs; the next modes only if
that finds nothing) at the same U_k and keeps the stable equilibrium of lowest energy — the
branch a displacement-controlled test jumps to; the step is a snap when Newton from that state
back at the previous step's U does not return to the previous state (a pitchfork of identical
folds in series is left continuously). If none is found, the unstable equilibrium is recorded as
such. Path following through limit points (arc length) lives in the continuation
solver.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from biplan._errors import ConfigError, check_integer, check_range
from biplan.analysis.stability import Stability, Verdict, classify, reduced_hessian
from biplan.model.assembly import Load, Model
from biplan.solvers.newton import Newton, Solution, Status, relaxed_reference, solve_equilibrium

__all__ = ["SWEEP_KIND", "QuasiStaticPath", "displacement_sweep", "proximal_descent"]

#: ``kind`` attribute of a sweep's labelled dataset (:func:`biplan.io.results.sweep_dataset`).
SWEEP_KIND = "stable-branch sweep"

#: Length [mm, rad] of the displacement along an unstable mode that starts a descent.
KICK = 0.1
#: Newton iterations of a proximal sub-problem (inexact proximal point, :func:`proximal_descent`).
SUB_STEPS = 20
#: Residual ‖r‖∞ [N, mm] below which an unconverged proximal sub-problem moves the anchor.
SUB_TOLERANCE = 1e-6
#: Step halvings of a proximal sub-problem's line search before Levenberg–Marquardt, and of
#: the default Newton of :func:`displacement_sweep`.
SUB_BACKTRACKS = 8


def inexact_newton(solver: Newton, sub_steps: int = SUB_STEPS) -> Newton:
    """The Newton of a proximal sub-problem: ``solver`` with at most ``sub_steps`` iterations,
    at most :data:`SUB_BACKTRACKS` step halvings and no contact restart
    (:func:`proximal_descent`, and the departure stepper's descent: a failed sub-problem
    stiffens the anchor spring instead).

    A sub-problem that is not convex enough fails fast: with the full line search (30
    halvings, then Levenberg–Marquardt until its damping passes 1e12) one failure cost up to
    ``sub_steps`` × 31 Jacobians, 80–120 s at 48 modules (docs/performance.md)."""
    return replace(
        solver,
        max_steps=min(solver.max_steps, sub_steps),
        max_backtracks=min(solver.max_backtracks, SUB_BACKTRACKS),
        contact_restart=False,
    )


@dataclass(frozen=True)
class QuasiStaticPath:
    """A recorded quasi-static path (one entry per step).

    Attributes
    ----------
    displacement : ndarray
        Prescribed load-point displacement U [mm].
    force : ndarray
        End reaction force F [N].
    u_z, u_r, theta : ndarray
        Endpoint displacements [mm] and slope [rad].
    energy : ndarray
        Strain energy Π [N·mm].
    min_eigenvalue : ndarray
        Smallest reduced-Hessian eigenvalue (+inf when contact-locked).
    stable : ndarray of bool
    status : tuple of Status
    switched : ndarray of bool
        True where the sweep snapped: it left an unstable equilibrium for a stable one on
        another branch, one that does not lead back to the previous state (a stable state on
        the same branch, reached through an unstable one at a pitchfork, is not a snap).
    solutions : tuple of Solution
    """

    displacement: np.ndarray
    force: np.ndarray
    u_z: np.ndarray
    u_r: np.ndarray
    theta: np.ndarray
    energy: np.ndarray
    min_eigenvalue: np.ndarray
    stable: np.ndarray
    status: tuple[Status, ...]
    switched: np.ndarray
    solutions: tuple[Solution, ...] = field(repr=False)

    @property
    def n_steps(self) -> int:
        return len(self.displacement)


def proximal_descent(
    model: Model,
    start: Solution,
    load: Load,
    solver: Newton,
    *,
    direction: np.ndarray | None = None,
    amplitude: float = 1e-2,
    stiffness: float | None = None,
    max_iterations: int = 300,
    polish_every: int = 10,
    sub_steps: int = SUB_STEPS,
    sub_tolerance: float = SUB_TOLERANCE,
) -> tuple[Solution, Stability] | None:
    """Proximal-point descent to a stable equilibrium at ``load``.

    Starting from ``start`` (displaced by ``amplitude · direction`` if given), repeatedly solve
    the biased problem min Π − W + ½κ‖q − q_k‖² and move the anchor q_k to its solution. With
    κ above the largest negative curvature each sub-problem is locally convex, so Newton finds
    its minimiser rather than a saddle, and the anchors descend the energy. Every
    ``polish_every`` iterations (and when the anchors stop moving) an unbiased Newton solve is
    tried; the first stable equilibrium it reaches is returned, else None. κ halves after
    every accepted sub-problem (longer strides across flat landscapes such as the ghost of a
    vanished saddle-node) and quadruples after a failed one.

    The sub-problems are solved inexactly (an inexact proximal-point method): at most
    ``sub_steps`` Newton iterations each, and a sub-problem whose residual is below
    ``sub_tolerance`` moves the anchor even if it missed ``solver.atol``. The anchor only
    guides the descent — what is returned is always an unbiased solve to ``solver.atol`` — and
    near the kinks of a trilinear law (a fold at a branch transition, where the stiffness jumps
    and Newton can cycle at ‖r‖ ~ 1e-7) exact sub-problems cost the full ``solver.max_steps``
    each and, counted as failures, stiffened κ until the descent gave up (docs/performance.md,
    "inexact relaxation").

    Parameters
    ----------
    stiffness : float, optional
        κ; default 2|λ_min(H_r)| + 1 at ``start`` (or 10 if ``start`` is not at ``load``).
    sub_steps : int
        Newton iterations per sub-problem (at most ``solver.max_steps``).
    sub_tolerance : float
        Residual ‖r‖∞ below which an unconverged sub-problem still moves the anchor [N, mm].
    """
    check_integer("sub_steps", sub_steps, low=1)
    check_range("sub_tolerance", sub_tolerance, low=0.0, low_open=False)
    if stiffness is None:
        kappa = 10.0
        if start.converged and start.load == load:
            h, _ = reduced_hessian(model, start)
            lam_min = float(np.linalg.eigvalsh(h)[0]) if h.size else 0.0
            kappa = 2.0 * abs(min(lam_min, 0.0)) + 1.0
    else:
        kappa = float(stiffness)
    z = start.z.copy()
    if direction is not None:
        z[: model.n_coordinates] += (
            amplitude * direction / max(float(np.linalg.norm(direction)), 1e-300)
        )
    anchor = z[: model.n_coordinates].copy()
    kappa_min = 1e-3 * kappa
    inexact = inexact_newton(solver, sub_steps)
    for k in range(1, max_iterations + 1):
        step = solve_equilibrium(model.with_bias(anchor, kappa), inexact, z, load)
        if not (step.converged or step.residual_norm <= sub_tolerance):
            # Sub-problem not convex enough (or not solved): stiffen the bias and retry from the
            # same anchor.
            kappa *= 4.0
            if kappa > 1e6:
                return None
            continue
        moved = float(np.max(np.abs(step.q - anchor)))
        z, anchor = step.z, step.q.copy()
        # Flat landscape (e.g. the ghost of a vanished saddle-node): take longer strides.
        kappa = max(0.5 * kappa, kappa_min)
        if k % polish_every == 0 or moved < 1e-9:
            final = solve_equilibrium(model, solver, z, load)
            if final.converged:
                st = classify(model, final)
                if st.verdict is Verdict.STABLE:
                    return final, st
            if moved < 1e-9:
                return None
    return None


def _stabilise(
    model: Model, sol: Solution, stab: Stability, solver: Newton
) -> tuple[Solution, Stability, bool]:
    """Replace an unstable equilibrium by the lowest-energy stable one found by descending
    along its most unstable mode (both senses, displaced by :data:`KICK`); the next modes,
    most unstable first, only when that finds none.

    One mode, not all: at the symmetric bifurcation of N identical folds in series N − 1
    modes are unstable at once, and descending along each made a long tube's sweep cost
    O(N) descents per snap."""
    h, basis = reduced_hessian(model, sol)
    eig, vec = np.linalg.eigh(h)
    for i in np.flatnonzero(eig < 0):
        best: tuple[Solution, Stability] | None = None
        for sign in (1.0, -1.0):
            found = proximal_descent(
                model,
                sol,
                sol.load,
                solver,
                direction=sign * (basis @ vec[:, i]),
                amplitude=KICK,
                polish_every=3,
            )
            if found is not None and (best is None or found[0].energy < best[0].energy - 1e-12):
                best = found
        if best is not None:
            return best[0], best[1], True
    return sol, stab, False


def _snapped(model: Model, solver: Newton, current: Solution, found: Solution) -> bool:
    """Whether reaching the stable ``found`` from the stable ``current`` was a snap.

    The hysteresis test: a snap leaves a branch that has ended, so Newton from ``found`` back
    at ``current``'s displacement stays on ``found``'s branch and lands away from ``current``
    (or fails). On a continuous stable branch, which a step reaches through an unstable
    equilibrium only by the luck of the line search (the symmetric state of identical folds
    in series past their common capacity, a pitchfork), it lands back on ``current``."""
    back = solve_equilibrium(model, solver, found, Load.of_displacement(current.displacement))
    if not back.converged:
        return True
    step = float(np.max(np.abs(found.q - current.q)))
    return float(np.max(np.abs(back.q - current.q))) > max(1e-2 * step, 1e-9)


def _advance(
    model: Model,
    solver: Newton,
    current: Solution,
    target: float,
    select_stable: bool,
    depth: int = 0,
) -> tuple[Solution, Stability | None, bool]:
    """Solve at ``target`` from ``current``; on failure bisect the increment (≤ 4 levels).

    Only the first try restarts from zero contact multipliers on failure
    (:attr:`Newton.contact_restart`): the bisection starts from the same state, and past a
    vanished branch (a snap) every restart fails too, doubling each try's cost."""
    if depth:
        solver = replace(solver, contact_restart=False)
    sol = solve_equilibrium(model, solver, current, Load.of_displacement(target))
    if not sol.converged:
        if depth >= 4:
            found = proximal_descent(model, current, Load.of_displacement(target), solver)
            if found is None:
                return sol, None, False
            return found[0], found[1], _snapped(model, solver, current, found[0])
        mid = 0.5 * (current.displacement + target)
        half, _, sw1 = _advance(model, solver, current, mid, select_stable, depth + 1)
        if not half.converged:
            return sol, None, False
        sol, stab, sw2 = _advance(model, solver, half, target, select_stable, depth + 1)
        return sol, stab, sw1 or sw2
    stab = classify(model, sol)
    switched = False
    if select_stable and stab.verdict is Verdict.UNSTABLE:
        sol, stab, switched = _stabilise(model, sol, stab, solver)
        switched = switched and _snapped(model, solver, current, sol)
    return sol, stab, switched


def displacement_sweep(
    model: Model,
    displacements: np.ndarray,
    method: Newton | None = None,
    start: Solution | None = None,
    *,
    select_stable: bool = True,
    progress: Callable[[int, int], object] | None = None,
) -> QuasiStaticPath:
    """Sweep the prescribed end displacement through ``displacements`` [mm].

    Parameters
    ----------
    model : Model
    displacements : array_like
        Finite load-point displacements U [mm], in the order to visit.
    method : Newton, optional
        Default ``Newton(max_backtracks=SUB_BACKTRACKS)``: a step past a vanished branch (a
        snap) fails, and with 30 halvings a failure cost up to 2 × 60 × 31 residuals and
        Jacobians (docs/performance.md, "Fail-fast Newton at snaps"); converged steps are the same.
    start : Solution, optional
        Starting equilibrium; default the relaxed reference.
    select_stable : bool
        Leave unstable equilibria for stable ones at the same U (see module docstring).
    progress : callable, optional
        Called as ``progress(step_done, n_steps)`` after every step (e.g. a progress bar).

    Returns
    -------
    QuasiStaticPath
        Failed steps are recorded with their status; the sweep continues from the last
        converged equilibrium.
    """
    u = np.asarray(displacements, dtype=float).ravel()
    if u.size == 0 or not np.all(np.isfinite(u)):
        raise ConfigError("displacements", displacements, "a non-empty array of finite mm values")
    method = method or Newton(max_backtracks=SUB_BACKTRACKS)
    current = start if start is not None else relaxed_reference(model, method, throw=True)
    rows: list[tuple] = []
    sols: list[Solution] = []
    for target in u:
        sol, stab, switched = _advance(model, method, current, float(target), select_stable)
        if sol.converged and stab is not None:
            current = sol
            e = sol.data.endpoint  # evaluated by the solve with the rest of the state
            rows.append(
                (
                    target,
                    sol.force,
                    float(e.u_z),
                    float(e.u_r),
                    float(e.theta),
                    sol.energy,
                    stab.min_eigenvalue,
                    stab.stable,
                    sol.status,
                    switched,
                )
            )
        else:
            nan = float("nan")
            rows.append((target, nan, nan, nan, nan, nan, nan, False, sol.status, False))
        sols.append(sol)
        if progress is not None:
            progress(len(sols), u.size)
    cols = list(zip(*rows, strict=True))
    return QuasiStaticPath(
        displacement=np.asarray(cols[0]),
        force=np.asarray(cols[1]),
        u_z=np.asarray(cols[2]),
        u_r=np.asarray(cols[3]),
        theta=np.asarray(cols[4]),
        energy=np.asarray(cols[5]),
        min_eigenvalue=np.asarray(cols[6]),
        stable=np.asarray(cols[7], dtype=bool),
        status=tuple(cols[8]),
        switched=np.asarray(cols[9], dtype=bool),
        solutions=tuple(sols),
    )
