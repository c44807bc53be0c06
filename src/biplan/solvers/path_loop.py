"""The compiled path loop: an adaptive predictor–corrector path in one Numba call (MODEL §11).

The load parameter Λ enters the loading affinely, (F, U, d) = (c_F Λ, c_U Λ, d) with
``ctl = (c_F, c_U, d)``: force control (1, 0, 0), displacement control (0, 1, 1), pressure
(πR², 0, 0). The corrector is the Newton of :mod:`biplan.solvers.iteration` on the bordered
system (Riks/Crisfield; Allgower & Georg)::

    r(z, Λ) = 0,     c_zᵀ z + c_Λ Λ = ρ

without the Levenberg–Marquardt fallback (a failed corrector is cut back by the loop). The side
condition is the pseudo-arclength hyperplane through the predictor, orthogonal to the tangent
in the weighted norm ‖(δq, δΛ)‖² = δqᵀδq + w_Λ² δΛ² (multipliers carry no weight), or
Λ = Λ_target (natural parameter stepping and the final step onto the stop value). After a
failed pseudo-arclength corrector the loop retries with the local parametrisation by the
fastest-changing coordinate (Rheinboldt), then a natural step of Λ; the step halves after a
whole failed cycle.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.tables import SystemData
from biplan.solvers.iteration import NewtonSettings, newton
from biplan.solvers.status import Status

__all__ = [
    "COMPLETED",
    "LIMIT_POINT",
    "MAX_STEPS",
    "RETURNED",
    "STALLED",
    "PathSettings",
    "correct_rows",
    "corrector",
    "path_loop",
]

#: Codes of the loop status (see ``PathStatus``).
RUNNING, COMPLETED, MAX_STEPS, STALLED = -1, 0, 1, 2
#: The path would have run back past its start value (the step is not recorded), or it passed
#: a limit point of Λ and was asked to stop there (the step past it is recorded).
RETURNED, LIMIT_POINT = 5, 6
#: Step halvings of the corrector's line search (smallest step fraction 2⁻¹²).
DAMPED_BACKTRACKS = 12


class PathSettings(NamedTuple):
    """The settings of :func:`path_loop`, by name.

    Attributes
    ----------
    natural : bool
        Step Λ by ds (load stepping); False: pseudo-arclength steps ds.
    initial_step, min_step, max_step : float
        Step lengths ds.
    grow : float
        Step growth after an easy step, > 1.
    max_steps : int
        Steps of the path.
    atol : float
        Corrector tolerance ‖r‖∞.
    max_iterations : int
        Corrector Newton steps.
    load_weight : float
        w_Λ of Λ in the arclength norm.
    stop_at_limit : bool
        End at the first state past a limit point of Λ (``LIMIT_POINT``).
    """

    natural: bool
    initial_step: float
    min_step: float
    max_step: float
    grow: float
    max_steps: int
    atol: float
    max_iterations: int
    load_weight: float
    stop_at_limit: bool


@kernel(inline="always")
def corrector(
    d: SystemData,
    z0: np.ndarray,
    load_parameter0: float,
    ctl: np.ndarray,
    row: np.ndarray,
    rho: float,
    atol: float,
    max_iterations: int,
) -> tuple:  # type: ignore[type-arg]
    """Damped Newton on the bordered system from (z0, Λ0), the border ``row`` = (c_z, c_Λ).

    Returns (z, Λ, converged, iterations, ∂r/∂z (n, n), ∂r/∂Λ (n,)) with the derivatives at
    the returned point.
    """
    n = z0.shape[0]
    x0 = np.empty(n + 1)
    x0[:n] = z0
    x0[n] = load_parameter0
    settings = NewtonSettings(
        float(atol), int(max_iterations), int(DAMPED_BACKTRACKS), 1e-4, 0, False
    )
    x, _, _, jac, steps, status = newton(d, ctl, x0, settings, row, rho, np.zeros(0))
    return (
        x[:n],
        x[n],
        status == Status.CONVERGED.value,
        steps,
        jac[:n, :n].copy(),
        jac[:n, n].copy(),
    )


@kernel(nogil=True)
def correct_rows(
    d: SystemData,
    zp: np.ndarray,
    lp: np.ndarray,
    ctl: np.ndarray,
    row: np.ndarray,
    rho: np.ndarray,
    atol: float,
    max_iterations: int,
    z: np.ndarray,
    lam: np.ndarray,
    ok: np.ndarray,
    lo: int,
    hi: int,
) -> None:
    """:func:`corrector` of the predictors lo … hi − 1 (zp (k, n), Λp (k,)) on the
    hyperplanes row·x = ρ_k, into rows lo:hi of z (k, n), Λ (k,) and converged (k,) (a lane of
    :func:`biplan.solvers.lanes.run_rows`)."""
    for i in range(lo, hi):
        out = corrector(d, zp[i], lp[i], ctl, row, rho[i], atol, max_iterations)
        z[i], lam[i], ok[i] = out[0], out[1], out[2]


@kernel
def tangent(
    jac: np.ndarray, r_load: np.ndarray, weights: np.ndarray, w_lam: float, previous: np.ndarray
) -> np.ndarray:
    """Unit tangent (weighted norm) of the solution curve, oriented along ``previous``."""
    n = jac.shape[0]
    a = np.zeros((n + 1, n + 1))
    a[:n, :n] = jac
    a[:n, n] = r_load
    a[n, :n] = weights * previous[:n]
    a[n, n] = w_lam**2 * previous[n]
    rhs = np.zeros(n + 1)
    rhs[n] = 1.0
    try:
        t = np.linalg.solve(a, rhs)
    except Exception:  # singular bordered matrix
        return np.full(n + 1, np.nan)
    norm = np.sqrt(np.sum(weights * t[:n] ** 2) + (w_lam * t[n]) ** 2)
    return t / norm


@kernel
def path_loop(
    d: SystemData,
    z0: np.ndarray,
    load_parameter0: float,
    ctl: np.ndarray,
    stop: float,
    settings: PathSettings,
) -> tuple:  # type: ignore[type-arg]
    """Adaptive predictor–corrector path from (z0, Λ0) toward Λ = ``stop``.

    ``settings``: :class:`PathSettings`; ``natural`` steps Λ by ds (load stepping), else
    pseudo-arclength steps ds; ``stop_at_limit`` ends the loop (``LIMIT_POINT``) at the first
    state past a limit point of Λ (the Λ-component of the tangent turned against the direction
    of ``stop``). A
    corrected state whose Λ lies beyond the start value on the far side from ``stop`` ends
    the loop with ``RETURNED`` before it is recorded.

    Returns (z (B, n), Λ (B,), tangents (B, n + 1), step lengths (B,), corrector iterations
    (B,), count, cut-backs, status), the first ``count`` rows filled.
    """
    natural = settings.natural
    ds, ds_min, ds_max = settings.initial_step, settings.min_step, settings.max_step
    grow, max_steps, atol = settings.grow, settings.max_steps, settings.atol
    max_it, w_lam = settings.max_iterations, settings.load_weight
    stop_at_limit = settings.stop_at_limit
    n = z0.shape[0]
    size = max_steps + 1
    weights = np.zeros(n)
    weights[: d.sizes[0]] = 1.0
    direction = np.sign(stop - load_parameter0)
    buf_z = np.zeros((size, n))
    buf_l = np.zeros(size)
    buf_t = np.zeros((size, n + 1))
    buf_s = np.zeros(size)
    buf_i = np.zeros(size, dtype=np.int64)
    buf_z[0] = z0
    buf_l[0] = load_parameter0
    count, cutbacks, status = 1, 0, RUNNING
    z, lam = z0.copy(), load_parameter0
    t = np.zeros(n + 1)
    t[n] = direction
    fails, started = 0, False
    while status == RUNNING:
        first = not started
        tz, tl = t[:n], float(t[n])
        tl_safe = tl if abs(tl) > 1e-12 else 1e-12
        mode = 2 if natural else fails % 3
        if first:  # the first pass stays at the start: it yields the start's tangent
            zp, lp = z.copy(), lam
        elif mode == 2:  # natural step: tangent predictor (load stepping) or, retrying, none
            zp = z + (ds * direction / tl_safe) * tz if natural else z.copy()
            lp = lam + ds * direction
        else:
            zp, lp = z + ds * tz, lam + ds * tl
        final = (not first) and (lp - stop) * direction >= 0.0
        fix = mode == 2 or final or first
        local = mode == 1 and not fix
        row = np.zeros(n + 1)
        if fix:
            row[n] = 1.0
        elif local:
            row[np.argmax(weights * np.abs(tz))] = 1.0
        else:
            row[:n] = weights * tz
            row[n] = w_lam**2 * tl
        target = stop if final else lp
        rho = target if fix else row[:n] @ zp + row[n] * lp
        if final and natural:
            zp = z + ((stop - lam) / tl_safe) * tz
        cz, cl, ok, its, cj, cr = corrector(
            d, zp, target if fix else lp, ctl, row, rho, atol, 0 if first else max_it
        )
        # orient the new tangent along the old one after a pseudo-arclength step (smooth limit
        # points), along the secant of the step after a retry (sharp corners)
        secant = np.empty(n + 1)
        secant[:n] = cz - z
        secant[n] = cl - lam
        sec_norm = np.sqrt(np.sum(weights * secant[:n] ** 2) + (w_lam * secant[n]) ** 2)
        prev = secant if (sec_norm > 0 and mode > 0 and started) else t
        t_new = tangent(cj, cr, weights, w_lam, prev)
        # a retry must move on along the branch in q, not fall back onto the traversed part
        forward = np.sum(weights * secant[:n] * tz) > 0.0
        ok = ok and np.all(np.isfinite(t_new)) and (mode == 0 or natural or forward)
        back = ok and started and (cl - load_parameter0) * direction < 0.0
        turned = ok and not back and stop_at_limit and t_new[n] * direction < 0.0 and started
        ok = ok and not back and started
        record = ok or first
        i = 0 if first else count
        if ok:
            buf_z[i], buf_l[i], buf_s[i], buf_i[i] = cz, cl, ds, its
            count += 1
        if record:
            buf_t[i] = t_new
        if not ok and not back and started:
            cutbacks += 1
        if ok:
            ds = min(ds * grow, ds_max) if its <= 3 else (0.7 * ds if its >= 7 else ds)
        elif mode == 2 and started:
            ds = 0.5 * ds
        if first:
            status = RUNNING
        elif back:
            status = RETURNED
        elif turned and not final:
            status = LIMIT_POINT
        elif ok and final:
            status = COMPLETED
        elif not ok and ds < ds_min:
            status = STALLED
        elif count - 1 >= max_steps or count >= size:
            status = MAX_STEPS
        if ok:
            z, lam = cz, cl
        if record:
            t = t_new
            fails = 0
        else:
            fails += 1
        started = True
    return buf_z, buf_l, buf_t, buf_s, buf_i, count, cutbacks, status
