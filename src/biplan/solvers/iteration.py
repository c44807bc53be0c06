"""The compiled Newton iteration on a :class:`~biplan.model.system.System` (Numba; MODEL §11).

The same globalised Newton as the JAX oracle of the tests (one trial point a pass):
Armijo backtracking on the merit ½‖R‖², a Levenberg–Marquardt fallback with adaptive damping
once the halvings are spent (or when the Newton system is singular; with the fallback off such
a search ends the solve, the plain damped Newton of the path corrector), and the watchdog of
free steps (Chamberlain et al. 1982). The start enters as the first trial point (merit +∞,
accepted when finite); the Jacobian is evaluated at accepted points only. Its settings are a
:class:`NewtonSettings` (named fields; :func:`newton_settings`, or
:meth:`biplan.solvers.Newton.loop_settings`).

The system R(x) = 0 is the KKT system r(z) = 0 at a load (plus, in a time step, the inertia
rows of :func:`biplan.model.system.inertia.add_inertia`), or, with a border row, the bordered
system of path following (x = [z, Λ], load (c_F Λ, c_U Λ, d))::

    R(x) = [r(z, Λ),  row_zᵀ z + row_Λ Λ − ρ],   ∂R/∂x = [[∂r/∂z, ∂r/∂Λ], [row_zᵀ, row_Λ]]

with ∂r/∂Λ = [−c_F ∇z_p, 0, …, −d c_U] (the load enters L as (μd − F) z_p and the last row
as d (z_p − U)).

Deflation (:func:`solve` with a ``deflation`` array; Farrell, Birkisson & Funke 2015) runs the
same iteration on M(q) R(z), M(q) = Π_i (‖q − q_i‖^−p + σ) over known states q_i, whose roots
are the other roots of R: ∂(M R)/∂z = M ∂R/∂z + M R ∇ηᵀ (η = log M, on the q columns), and a
solve converges when the undeflated residual is below the tolerance.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from biplan._compile.numba_cache import kernel, kernel_array
from biplan.model.system.assemble import evaluate_into
from biplan.model.system.chainterm import load_point
from biplan.model.system.inertia import add_inertia
from biplan.model.system.tables import SystemData
from biplan.solvers.bordered import direction
from biplan.solvers.levenberg import finite, levenberg_marquardt
from biplan.solvers.status import Status

__all__ = [
    "ESCAPE",
    "NO_BORDER",
    "NO_DEFLATION",
    "NO_STEP",
    "NewtonSettings",
    "deflate",
    "deflation_data",
    "log_deflation",
    "newton",
    "newton_settings",
    "solve",
    "solve_system",
]

_CONVERGED = Status.CONVERGED.value
_MAX_STEPS = Status.MAX_STEPS.value
_FAILED = Status.LINE_SEARCH_FAILED.value
_NONFINITE = Status.NONFINITE.value


#: No border row: the KKT system itself. (Python callers only: a global array read inside
#: compiled code is a read-only constant, another argument type and another compile; compiled
#: callers pass ``np.zeros(0)``.)
NO_BORDER = np.zeros(0)
#: No time step: the static system (else :func:`biplan.model.system.inertia.step_data`).
NO_STEP = np.zeros(0)
#: No deflation (else :func:`deflation_data`).
NO_DEFLATION = np.zeros(0)
#: Coordinates beyond this [mm or rad] make a deflated residual NaN (an iterate pushed off to
#: infinity is rejected).
ESCAPE = 1e3
#: Squared distances below this [mm²] are clamped (the deflation stays finite at a root).
_TINY = 1e-300


class NewtonSettings(NamedTuple):
    """The settings of the compiled Newton (:func:`solve`), by name.

    Attributes
    ----------
    atol : float
        Convergence when ‖R‖∞ < atol.
    max_steps : int
        Newton steps.
    max_backtracks : int
        Step halvings of the Armijo line search before Levenberg–Marquardt (or failure).
    armijo : float
        Sufficient-decrease constant.
    free_steps : int
        Watchdog steps taken in full whenever finite.
    levenberg_marquardt : bool
        Fall back to Levenberg–Marquardt steps (off: the plain damped Newton, which fails where
        the halvings are spent).
    """

    atol: float
    max_steps: int
    max_backtracks: int
    armijo: float
    free_steps: int
    levenberg_marquardt: bool


def newton_settings(
    atol: float,
    max_steps: int,
    max_backtracks: int,
    armijo: float,
    free_steps: int,
    levenberg_marquardt: bool = True,
) -> NewtonSettings:
    """:class:`NewtonSettings` with every field of its type (one compiled signature)."""
    return NewtonSettings(
        float(atol),
        int(max_steps),
        int(max_backtracks),
        float(armijo),
        int(free_steps),
        bool(levenberg_marquardt),
    )


@kernel(inline="always")
def system(
    d: SystemData,
    x: np.ndarray,
    load: np.ndarray,
    border: np.ndarray,
    rho: float,
    second: bool,
    step: np.ndarray,
    jac: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(R(x), ∂R/∂x or (0, 0)): the KKT system at ``load`` when ``border`` is empty, else the
    bordered system with ``load`` the control coefficients (c_F, c_U, d) and ``border`` the
    row (row_z, row_Λ) (module docstring). ∂R/∂x is written into ``jac``, zeros of (n, n)
    for the n unknowns x where ``second``, (0, 0) where not.

    Inlined into :func:`solve`, its only caller: compiled on its own it would optimise the
    assembly below it once more (docs/performance.md, "One-time compile")."""
    if border.shape[0] == 0:
        out = evaluate_into(d, x, load, second, jac)
        if step.shape[0]:  # the inertia rows of a time step (solvers.step_loop)
            add_inertia(d, x[: d.sizes[0]], step, out[0], out[1], second)
        return out[0], out[1]
    n = x.shape[0] - 1
    lam = x[n]
    at = np.array([load[0] * lam, load[1] * lam, load[2]])
    out = evaluate_into(d, x[:n], at, second, jac)  # its leading n × n block
    res = np.empty(n + 1)
    res[:n] = out[0]
    res[n] = border[:n] @ x[:n] + border[n] * lam - rho
    if not second:
        return res, jac
    n_q = d.sizes[0]
    grad_zp = out[3]
    if at[0] == 0.0 and at[2] == 0.0 and load[0] != 0.0:  # at rest evaluate skips z_p
        grad_zp = np.zeros(n_q)
        load_point(d, x[:n_q], grad_zp, np.zeros((0, 0)), 0.0, False)
    for i in range(n_q):
        jac[i, n] = -load[0] * grad_zp[i]
    jac[n - 1, n] = -load[2] * load[1]
    jac[n, :] = border
    return res, jac


@kernel(inline="always")
def _zeroed(pool: tuple, k: int, n: int) -> tuple:  # type: ignore[type-arg]
    """The pool of :func:`solve`'s Jacobians with its array k zeroed to (n, n), allocated
    when first used (the arrays of the others stay as they are)."""
    a = pool[k]
    if a.shape[0] != n:
        a = np.zeros((n, n))
    else:
        a[:, :] = 0.0
    if k == 0:
        return (a, pool[1], pool[2])
    if k == 1:
        return (pool[0], a, pool[2])
    return (pool[0], pool[1], a)


@kernel(inline="always")
def newton(
    d: SystemData,
    load: np.ndarray,
    z0: np.ndarray,
    settings: NewtonSettings,
    border: np.ndarray,
    rho: float,
    step: np.ndarray,
) -> tuple:  # type: ignore[type-arg]
    """Solve R(z) = 0 of the system (d, load, border, ρ, step) from z0 (:func:`system`); the
    KKT system with ``border`` = :data:`NO_BORDER` and ``step`` = :data:`NO_STEP`, a time step
    of :mod:`biplan.solvers.step_loop` with its step data. (No default arguments: Numba keys
    an omitted array default by its identity, so a function with one is never found in the
    cache.)

    Returns (z, R, merit f, Jacobian at z, steps, status); the Jacobian is the one at z once a
    pass was accepted (finite f).

    Inlined into its compiled callers (``inline="always"``): a compiled function of its own
    would re-optimise the whole system below it once more (docs/performance.md, "One-time
    compile"); Python calls :func:`solve` with :data:`NO_DEFLATION` instead.
    """
    return solve(d, load, z0, settings, border, rho, step, np.zeros(0))


def solve_system(system: Any, z0: np.ndarray, settings: NewtonSettings) -> tuple:  # type: ignore[type-arg]
    """:func:`newton` on a :class:`~biplan.model.system.System` (its data and load) from z0,
    called from Python (through :func:`solve`, which is compiled on its own). Raises
    ValueError for a start that is not a vector of the system's ``n_unknowns`` (the compiled
    loop would read past it)."""
    start = kernel_array(z0, float)
    if start.shape != (system.n_unknowns,):
        raise ValueError(
            f"start of shape {start.shape}: the system has {system.n_unknowns} unknowns"
        )
    return solve(  # type: ignore[no-any-return]
        system.data,
        system.load,
        start,
        settings,
        NO_BORDER,
        0.0,
        NO_STEP,
        NO_DEFLATION,
    )


@kernel
def log_deflation(q: np.ndarray, roots: np.ndarray, power: float, shift: float) -> tuple:  # type: ignore[type-arg]
    """(η = log M(q), ∇η (n_q,)) of the deflation operator M(q) = Π_i (‖q − q_i‖^−p + σ) over
    the known states ``roots`` (R, n_q) [mm, rad]; ``power`` p ≥ 1, ``shift`` σ ≥ 0 (Farrell,
    Birkisson & Funke 2015)."""
    eta = 0.0
    grad = np.zeros(q.shape[0])
    for i in range(roots.shape[0]):
        diff = q - roots[i]
        s = np.sum(diff * diff)
        r2 = max(s, _TINY)
        a = r2 ** (-0.5 * power)
        eta += math.log(a + shift)
        # ∂ max(s, tiny)/∂s: 1 above, ½ at the clamp (JAX's balanced rule), 0 below
        ds = 1.0 if s > _TINY else (0.5 if s == _TINY else 0.0)
        coef = -0.5 * power * r2 ** (-0.5 * power - 1.0) * ds / (a + shift)
        grad += (2.0 * coef) * diff
    return eta, grad


@kernel
def deflate(
    d: SystemData, x: np.ndarray, res: np.ndarray, jac: np.ndarray, deflation: np.ndarray
) -> float:
    """Turns (R, ∂R/∂x) at x into the deflated (M R, M ∂R/∂x + M R ∇ηᵀ) in place (∇η on the q
    columns; the Jacobian only when it is not empty; R NaN beyond :data:`ESCAPE`) and returns
    M. ``deflation`` = [p, σ, roots (R, n_q) flattened] (:func:`deflation_data`)."""
    n_q = d.sizes[0]
    roots = deflation[2:].reshape((-1, n_q))
    eta, grad = log_deflation(x[:n_q], roots, deflation[0], deflation[1])
    m = math.exp(eta)
    escaped = np.max(np.abs(x[:n_q])) > ESCAPE
    if jac.shape[0]:
        for i in range(res.shape[0]):
            for j in range(jac.shape[1]):
                jac[i, j] *= m
            for j in range(n_q):
                jac[i, j] += m * res[i] * grad[j]
    for i in range(res.shape[0]):
        res[i] = math.nan if escaped else m * res[i]
    return m


def deflation_data(roots: np.ndarray, power: float, shift: float) -> np.ndarray:
    """The ``deflation`` array of :func:`solve`: [p, σ, roots (R, n_q) flattened]."""
    return np.concatenate([[float(power), float(shift)], np.asarray(roots, float).ravel()])


@kernel
def solve(
    d: SystemData,
    load: np.ndarray,
    z0: np.ndarray,
    settings: NewtonSettings,
    border: np.ndarray,
    rho: float,
    step: np.ndarray,
    deflation: np.ndarray,
) -> tuple:  # type: ignore[type-arg]
    """:func:`newton`, on the deflated system M(q) R(z) where ``deflation`` is not empty
    (:data:`NO_DEFLATION`; :func:`deflation_data`): converged when the *undeflated* residual
    is below the tolerance, ‖M R‖∞ < atol · M."""
    atol, max_steps, max_bt = settings.atol, settings.max_steps, settings.max_backtracks
    c_arm, free, with_lm = settings.armijo, settings.free_steps, settings.levenberg_marquardt
    deflated = deflation.shape[0] > 0
    # the bordered banded solve of the layout (solvers.bordered); dense LU for the deflated
    # system (M R ∇ηᵀ fills the q columns) and a time step's inertia rows
    structured = not deflated and step.shape[0] == 0
    no_jacobian = np.zeros((0, 0))  # (a global array would be read-only)
    # The Jacobians are written into a pool of three arrays, reused: the current iterate's
    # (jac), the watchdog's best (best_jac) and a trial's; ``cur`` and ``best`` are the
    # arrays of the first two (−1: not in the pool). A fresh n × n array a Jacobian cost more
    # than the rest of a Newton step at N = 400 (docs/performance.md). Once no watchdog
    # return is left (free = 0) an accepted point overwrites the current Jacobian: a solve
    # without the watchdog allocates one array (71 ms of page faults at N = 400).
    pool = (no_jacobian, no_jacobian, no_jacobian)
    cur, best = -1, -1
    alpha_min = 0.5**max_bt
    max_evals = max(max_steps, 1) * (max_bt + 1)
    n = z0.shape[0]
    z = z0.copy()
    r = np.zeros(n)
    f = np.inf
    jac = no_jacobian  # the current iterate's, once a point is accepted
    dz = np.zeros(n)
    slope, alpha, lm, damping = 0.0, 0.0, False, 1e-3
    steps, evals, status = 0, 0, -1
    best_z, best_r, best_f, best_jac, best_dz, best_lm = z.copy(), r.copy(), np.inf, jac, dz, False
    # JᵀJ and −Jᵀr at the current iterate for dense Levenberg–Marquardt steps, kept while
    # trials are rejected there (only the damping changes): one product JᵀJ (O(n³)) an iterate
    lm_jtj, lm_g, lm_kept = np.zeros((0, 0)), np.zeros(0), False
    while status < 0 and evals < max_evals:
        zt = z + alpha * dz
        rt = system(d, zt, load, border, rho, False, step, no_jacobian)[0]
        if deflated:
            deflate(d, zt, rt, no_jacobian, deflation)
        ft = 0.5 * (rt @ rt)
        if not np.isfinite(ft):
            ft = np.inf
        accept = ft < f if lm else ft <= f + c_arm * alpha * slope
        accept = (accept or not np.isfinite(f) or free > 0) and np.isfinite(ft)
        to_lm = lm or alpha * 0.5 < alpha_min
        damping_r = damping * 10.0 if lm else damping
        was_finite = np.isfinite(f)
        if accept:
            if free == 0 and cur >= 0:
                # no watchdog return is left: the current Jacobian is not needed again
                k = cur
            else:
                k = 0
                while k in (cur, best):
                    k += 1
            pool = _zeroed(pool, k, n)
            rj, jt = system(d, zt, load, border, rho, True, step, pool[k])
            m = deflate(d, zt, rj, jt, deflation) if deflated else 1.0
            dz_n, jdz = direction(jt, -rt, d.solve_order, d.solve_band, structured)
            newton_ok = finite(dz_n)
            lm_kept = False
            if newton_ok:
                dz_a = dz_n
            elif with_lm:
                dz_a, lm_jtj, lm_g, lm_kept = levenberg_marquardt(
                    d, jt, rt, damping, structured, lm_jtj, lm_g, False
                )
                jdz = jt @ dz_a
            else:  # a singular Newton system ends the plain damped Newton
                dz_a = dz_n
                status = _FAILED
            z, r, f, jac, dz = zt, rt, ft, jt, dz_a
            cur = k
            slope = float(rt @ jdz)
            alpha, lm, damping = 1.0, not newton_ok, max(damping * 0.3, 1e-9)
            if was_finite:
                steps += 1
            if np.max(np.abs(rt)) < atol * m:  # m = 1 undeflated
                status = _CONVERGED
            elif status == _FAILED:
                pass
            elif steps >= max_steps:
                status = _MAX_STEPS
        else:
            if not np.isfinite(f):  # a non-finite start: no point to step from (NONFINITE)
                break
            if to_lm and not with_lm:  # halvings spent: the damped Newton fails here
                status = _FAILED
            elif to_lm and damping_r > 1e12:  # fails below: no step to compute
                alpha = 1.0
            elif to_lm:
                dz, lm_jtj, lm_g, lm_kept = levenberg_marquardt(
                    d, jac, r, damping_r, structured, lm_jtj, lm_g, lm_kept
                )
                alpha = 1.0
            else:  # a halving: dz, and with it the slope, stay
                alpha = 0.5 * alpha
            if to_lm:
                slope = float(r @ (jac @ dz))
            lm, damping = to_lm and with_lm, damping_r
            if status == _FAILED:
                pass
            elif damping_r > 1e12:
                status = _FAILED
            elif steps >= max_steps:
                status = _MAX_STEPS
        evals += 1
        # watchdog: count the free step, keep the best iterate, go back to it when spent
        used = accept and was_finite and free > 0
        if used:
            free -= 1
        if accept and f < best_f:
            best_z, best_r, best_f, best_jac, best_dz, best_lm = z, r, f, jac, dz, lm
            best = cur
        if used and free == 0 and status != _CONVERGED and best_f < f:
            z, r, f, jac, dz, lm = best_z, best_r, best_f, best_jac, best_dz, best_lm
            cur = best
            lm_kept = False
            slope, alpha = float(r @ (jac @ dz)), 1.0
    if status < 0:
        status = _MAX_STEPS
    if not np.isfinite(f):
        status = _NONFINITE
        jac = np.eye(n)  # (no Jacobian was evaluated; an n × n placeholder for the callers)
    return z, r, f, jac, steps, status
