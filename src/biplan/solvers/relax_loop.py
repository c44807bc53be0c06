"""Seeded relaxation on the compiled system: fold-state seeds → equilibria at zero end load
(Numba; MODEL §15).

Each seed goes through three stages, the first two in the reduced coordinates x = (u, γ) of
:mod:`biplan.model.system.reduced` (the guides solved in closed form: N + Nc unknowns, and no
guide penalty to make the descent stiff):

1. **Kinematic seed.** Gauss–Newton on r(x) = m ⊙ (w̄(q(x)) − t) from x = 0, where w̄ is the
   length-mean elongation of every fold, t the target of each fold (0 for closed, the law's
   open well for open) and m masks the folds that take part (bistable ones); a small
   Levenberg damping (10⁻¹⁰) keeps it well posed. Steps are capped at
   :data:`SEED_MAX_STEP`, and a step into a kinematically locked module (q(x) undefined)
   ends the seed where it is.
2. **Quasi-static relaxation.** Modified Newton descent on the penalised energy
   Π(q(x)) + ½k_p‖min(w_∂(q(x)), 0)‖² (the contacts as stiff penalties), so that the seed
   slides into the well it lies in and never stops on a saddle: the Hessian is shifted to
   positive definite (a Cholesky factorisation of H − :data:`SHIFT_FLOOR`·I decides whether it
   needs a shift; its smallest eigenvalue is computed only then), the step capped at
   :data:`DESCENT_MAX_STEP`, and the first of the step lengths 1, ½, … (16 of them) that
   satisfies Armijo's condition is taken. It ends when ‖∇‖∞ < :data:`DESCENT_GTOL` with the
   Hessian positive definite, when no step length is accepted, or after ``max_iterations``.
3. **KKT polish.** The package's Newton (:func:`biplan.solvers.iteration.newton`) on the
   full KKT system at rest, from q(x), contact multipliers estimated from the penalty (the
   penalty force k_p max(−w_∂, 0) or, if larger, the multiplier on the smoothed
   Fischer–Burmeister curve at max(w_∂, 0): a closed contact carrying almost no force would
   otherwise start at the curve's corner) and the guide multipliers by least squares on the
   stationarity rows. Its status and residual are the seed's.

:func:`relax_rows` relaxes a block of seeds; the blocks run in parallel
(:mod:`biplan.solvers.lanes`). It is the one compiled entry point: the stages and
:func:`relax_seed` are inlined into it (``inline="always"``), since each compiled on its own
would optimise the code below it (the Newton with the assembly, for :func:`relax_seed`) once
more (docs/performance.md, "One-time compile").
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.assemble import _SECOND, _terms
from biplan.model.system.reduced import (
    fold_openings,
    full_coordinates,
    penalized_derivatives,
    penalized_value,
)
from biplan.model.system.tables import SystemData
from biplan.solvers.bordered import dense_solve
from biplan.solvers.iteration import NewtonSettings, newton

__all__ = ["relax_rows", "relax_seed"]

#: Gauss–Newton iterations of the kinematic seed (at most), the largest step [mm] per
#: iteration, and the step below which the seed has converged [mm].
SEED_ITERATIONS = 40
SEED_MAX_STEP = 0.2
SEED_STEP_TOL = 1e-13
#: Descent: trial step lengths 1, 1/2, … (LINE_SEARCH_POINTS of them), Armijo constant,
#: largest step [mm], gradient tolerance [N, N·mm] and the smallest Hessian eigenvalue after
#: the shift.
LINE_SEARCH_POINTS = 16
ARMIJO = 1e-4
DESCENT_MAX_STEP = 1.0
DESCENT_GTOL = 1e-3
SHIFT_FLOOR = 1e-6


@kernel
def _positive_definite(h: np.ndarray, floor: float) -> bool:
    """Whether h − floor·I has a Cholesky factorisation (every pivot > 0)."""
    n = h.shape[0]
    low = np.zeros((n, n))
    for j in range(n):
        s = h[j, j] - floor
        for k in range(j):
            s -= low[j, k] * low[j, k]
        if not s > 0.0:
            return False
        low[j, j] = math.sqrt(s)
        for i in range(j + 1, n):
            t = h[i, j]
            for k in range(j):
                t -= low[i, k] * low[j, k]
            low[i, j] = t / low[j, j]
    return True


@kernel
def _seed_residual(d: SystemData, x: np.ndarray, target: np.ndarray, mask: np.ndarray) -> tuple:  # type: ignore[type-arg]
    w, jac = fold_openings(d, x)
    r = mask * (w - target)
    for i in range(r.shape[0]):
        jac[i] *= mask[i]
    return r, jac


@kernel
def _finite(x: np.ndarray) -> bool:
    return bool(np.all(np.isfinite(x)))


@kernel(inline="always")
def kinematic_seed(d: SystemData, target: np.ndarray, mask: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """(x, max |r| [mm]): stage 1 (module docstring) toward fold openings ``target`` (N + Nc,)
    [mm] where ``mask`` is 1."""
    nx = target.shape[0]
    x = np.zeros(nx)
    damping = 1e-10 * np.eye(nx)
    for _ in range(SEED_ITERATIONS):
        r, jac = _seed_residual(d, x, target, mask)
        step = dense_solve(jac.T @ jac + damping, -(jac.T @ r))
        scale = min(1.0, SEED_MAX_STEP / (np.max(np.abs(step)) + 1e-300))
        new = x + scale * step
        ok = _finite(_seed_residual(d, new, target, mask)[0])
        moved = np.max(np.abs(scale * step))
        if ok:
            x = new
        if not ok or moved < SEED_STEP_TOL:
            break
    return x, np.max(np.abs(_seed_residual(d, x, target, mask)[0]))


@kernel(inline="always")
def descent(d: SystemData, x0: np.ndarray, stiffness: float, max_iterations: int) -> tuple:  # type: ignore[type-arg]
    """(x, iterations): stage 2 (module docstring) from x0 with penalty stiffness k_p [N/mm]."""
    x = x0.copy()
    e, gaps = penalized_value(d, x, stiffness)
    nx = x.shape[0]
    it = 0
    while it < max_iterations:
        it += 1
        gr, h = penalized_derivatives(d, x, gaps, stiffness)
        if not (_finite(gr) and _finite(h) and np.isfinite(e)):
            break  # no finite step from here
        lo = math.inf
        if not _positive_definite(h, SHIFT_FLOOR):
            lo = np.linalg.eigvalsh(h)[0]
        shift = max(0.0, SHIFT_FLOOR - lo)
        a = h.copy()
        for i in range(nx):
            a[i, i] += shift
        step = dense_solve(a, -gr)
        step *= min(1.0, DESCENT_MAX_STEP / (np.max(np.abs(step)) + 1e-300))
        slope = gr @ step
        accepted = False
        alpha = 1.0
        for _ in range(LINE_SEARCH_POINTS):
            trial = x + alpha * step
            et, gt = penalized_value(d, trial, stiffness)
            if np.isfinite(et) and et <= e + ARMIJO * alpha * slope:
                accepted = True
                x, e, gaps = trial, et, gt
                break
            alpha *= 0.5
        if (np.max(np.abs(gr)) < DESCENT_GTOL and lo > SHIFT_FLOOR) or not accepted:
            break
    return x, it


@kernel(inline="always")
def polish_start(d: SystemData, x: np.ndarray, stiffness: float) -> np.ndarray:
    """The start z = [q(x), λ, λ_∂, 0] of the KKT polish (module docstring, stage 3)."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    q = full_coordinates(d, x)[0]
    gaps = penalized_value(d, x, stiffness)[1]
    eps2, comp, eps = d.scalars[3] ** 2, d.scalars[4], d.scalars[3]
    lam_c = np.empty(n_c)
    for i in range(n_c):
        wp = max(gaps[i], 0.0)
        den = wp + math.sqrt(wp * wp + 2.0 * comp * eps2)
        on_curve = eps2 / max(den, 1e-300) if den > 0.0 else eps
        lam_c[i] = max(-stiffness * gaps[i], on_curve)
    t = _terms(d, q, np.zeros(n_g), lam_c, _SECOND)
    g_mat = t[4]
    lam = -dense_solve(g_mat @ g_mat.T, g_mat @ t[0])
    z = np.zeros(n_q + n_g + n_c + 1)
    z[:n_q] = q
    z[n_q : n_q + n_g] = lam
    z[n_q + n_g : n_q + n_g + n_c] = lam_c
    return z


@kernel(inline="always")
def relax_seed(
    d: SystemData,
    target: np.ndarray,
    mask: np.ndarray,
    stiffness: float,
    max_iterations: int,
    settings: NewtonSettings,
) -> tuple:  # type: ignore[type-arg]
    """(z, status, max |r|, descent iterations) of one seed (module docstring); ``settings``:
    the Newton settings of the polish (:class:`~biplan.solvers.iteration.NewtonSettings`)."""
    x, _ = kinematic_seed(d, target, mask)
    x, iterations = descent(d, x, stiffness, max_iterations)
    z0 = polish_start(d, x, stiffness)
    at_rest = np.zeros(3)
    z, r, _, _, _, status = newton(d, at_rest, z0, settings, np.zeros(0), 0.0, np.zeros(0))
    return z, status, np.max(np.abs(r)), iterations


@kernel(nogil=True)
def relax_rows(
    d: SystemData,
    targets: np.ndarray,
    masks: np.ndarray,
    stiffness: float,
    max_iterations: int,
    settings: NewtonSettings,
    zs: np.ndarray,
    status: np.ndarray,
    residual: np.ndarray,
    iterations: np.ndarray,
    lo: int,
    hi: int,
) -> None:
    """:func:`relax_seed` of the rows lo … hi − 1 of ``targets``/``masks`` (k, N + Nc), into
    rows lo:hi of z (k, n_z), status (k,), max |r| (k,) and descent iterations (k,) (a lane of
    :func:`biplan.solvers.lanes.run_rows`)."""
    for i in range(lo, hi):
        z, s, r, it = relax_seed(d, targets[i], masks[i], stiffness, max_iterations, settings)
        zs[i] = z
        status[i] = s
        residual[i] = r
        iterations[i] = it
