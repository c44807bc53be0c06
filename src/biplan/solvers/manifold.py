"""Return to the constraint manifold of a tube on the compiled system (Numba).

The manifold is g(q) = 0 (guides, exactly) and w_∂(q) ≥ 0 (contact gaps). :func:`project`
pulls a point q back onto it by minimum-norm Gauss–Newton steps on the rectangular system::

    c(q) = [g(q); min(w_∂(q), 0)] = 0       (n_g + n_c equations, n_q unknowns)

(penetrated contacts to zero gap, open ones left alone), the step dq = −J⁺ c by the
pseudo-inverse (:func:`pinv`, singular values below 10⁻¹⁰ of the largest dropped). It is the
iteration that the JAX Newton of the tests' oracle (minimum-norm steps, no
Levenberg–Marquardt, one halving,
watchdog of :data:`ITERATIONS` free steps) takes on that system, written out:

* the start is the first trial point; a trial is accepted whenever it is finite (the free
  steps), else the step is halved once, and a second non-finite trial ends the return;
* it stops when ‖c‖∞ < :data:`TOLERANCE` [mm], or after :data:`ITERATIONS` steps at the
  iterate of smallest ‖c‖ (the watchdog's best point), or when a step is not finite.

The nudged elastic band (:mod:`biplan.solvers.band_loop`) returns every image with it after
each step. ∂min(w, 0)/∂w is 1 below zero, 0 above and ½ at zero (JAX's balanced rule).
"""

from __future__ import annotations

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.assemble import _SECOND, _terms
from biplan.model.system.tables import SystemData

__all__ = ["ITERATIONS", "PINV_RTOL", "TOLERANCE", "constraints", "pinv", "project"]

#: Gauss–Newton iterations of the return to the constraint manifold (the free steps).
ITERATIONS = 4
#: Constraint violation ‖c‖∞ [mm] below which the return stops early.
TOLERANCE = 1e-13
#: Singular values below this fraction of the largest are dropped by :func:`pinv`.
PINV_RTOL = 1e-10
#: Step halvings, Armijo constant (inactive while the free steps last) and the largest
#: number of trial points of one return (the Newton core's limit for these settings).
_HALVINGS = 1
_ARMIJO = 1e-4
_MAX_EVALS = max(ITERATIONS, 1) * (_HALVINGS + 1)
_CONVERGED, _MAX_STEPS, _FAILED = 0, 1, 2


@kernel
def pinv(a: np.ndarray) -> np.ndarray:
    """Moore–Penrose pseudo-inverse (n, m) of a (m, n) by SVD, singular values at or below
    :data:`PINV_RTOL` times the largest dropped (:func:`biplan._compile.linalg.pinv`); NaN
    everywhere when ``a`` is not finite (as the SVD of JAX reports it)."""
    m, n = a.shape
    if not np.all(np.isfinite(a)):
        return np.full((n, m), np.nan)
    if m == 0 or n == 0:
        return np.zeros((n, m))
    u, s, vt = np.linalg.svd(np.ascontiguousarray(a), full_matrices=False)
    cutoff = PINV_RTOL * np.max(s)
    k = s.shape[0]
    scaled = np.zeros((k, m))
    for i in range(k):
        if s[i] > cutoff:
            scaled[i] = u[:, i] / s[i]
    return vt.T @ scaled


@kernel
def constraints(d: SystemData, q: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """(c (n_g + n_c,), ∂c/∂q (n_g + n_c, n_q), w_∂ (n_c,)) at q: c = (g, min(w_∂, 0)) [mm]
    (module docstring)."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    t = _terms(d, q, np.zeros(n_g), np.zeros(n_c), _SECOND)
    c = np.empty(n_g + n_c)
    jac = np.zeros((n_g + n_c, n_q))
    c[:n_g] = t[2]
    jac[:n_g] = t[4]
    gaps, c_mat = t[3], t[5]
    for i in range(n_c):
        w = gaps[i]
        c[n_g + i] = w if (w < 0.0 or w != w) else 0.0
        factor = 1.0 if w < 0.0 else (0.5 if w == 0.0 else 0.0)
        if factor != 0.0:
            jac[n_g + i] = factor * c_mat[i]
    return c, jac, gaps


@kernel
def project(d: SystemData, q0: np.ndarray) -> np.ndarray:
    """q0 (n_q,) returned to the constraint manifold (module docstring) [mm, rad]."""
    n = q0.shape[0]
    m = d.sizes[1] + d.sizes[2]
    alpha_min = 0.5**_HALVINGS
    z, r, f = q0.copy(), np.zeros(m), np.inf
    jac, dz = np.eye(m, n), np.zeros(n)
    slope, alpha, lm, damping = 0.0, 0.0, False, 1e-3
    steps, evals, status, free = 0, 0, -1, ITERATIONS
    best_z, best_r, best_f, best_jac, best_dz, best_lm = z, r, np.inf, jac, dz, False
    while status < 0 and evals < _MAX_EVALS:
        zt = z + alpha * dz
        rt, jt, _ = constraints(d, zt)
        ft = 0.5 * (rt @ rt)
        if not np.isfinite(ft):
            ft = np.inf
        armijo = ft <= f + _ARMIJO * alpha * slope
        accept = (ft < f if lm else armijo) or not np.isfinite(f) or free > 0
        accept = accept and np.isfinite(ft)
        to_lm = lm or alpha * 0.5 < alpha_min
        damping_r = damping * 10.0 if lm else damping
        was_finite = np.isfinite(f)
        if accept:
            dz_a = pinv(jt) @ -rt
            newton_ok = bool(np.all(np.isfinite(dz_a)))
            steps += 1 if was_finite else 0
            if np.max(np.abs(rt)) < TOLERANCE:
                status = _CONVERGED
            elif not newton_ok:  # no Levenberg–Marquardt: a singular step ends the return
                status = _FAILED
            elif steps >= ITERATIONS:
                status = _MAX_STEPS
            z, r, f, jac, dz = zt, rt, ft, jt, dz_a
            slope = float(rt @ (jt @ dz_a))
            alpha, lm, damping = 1.0, not newton_ok, max(damping * 0.3, 1e-9)
        else:
            if to_lm:  # the halvings are spent: the return ends here
                dz = np.full(n, np.nan)
                alpha = 1.0
                status = _FAILED
            else:
                alpha = 0.5 * alpha
                status = _FAILED if damping_r > 1e12 else status
            if status < 0 and steps >= ITERATIONS:
                status = _MAX_STEPS
            slope = float(r @ (jac @ dz))
            lm, damping = to_lm, damping_r
        evals += 1
        # the watchdog: count the free step, keep the best point, go back to it when spent
        used = accept and was_finite and free > 0
        if used:
            free -= 1
        if accept and f < best_f:
            best_z, best_r, best_f, best_jac, best_dz, best_lm = z, r, f, jac, dz, lm
        if used and free == 0 and status != _CONVERGED and best_f < f:
            z, r, f, jac, dz, lm = best_z, best_r, best_f, best_jac, best_dz, best_lm
            slope, alpha = float(r @ (jac @ dz)), 1.0
    return z
