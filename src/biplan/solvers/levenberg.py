"""The Levenberg–Marquardt fallback of the compiled Newton (Numba;
:mod:`biplan.solvers.iteration`).

The step solves (JᵀJ + ν diag(JᵀJ + 1e-12)) dz = −Jᵀr, entries that are not finite set to 0:
from the normal equations (dense LU), or for a long tube by the augmented system in the
bordered banded solve (:func:`biplan.solvers.bordered.lm_solve`) where the layout fits.
"""

from __future__ import annotations

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.tables import SystemData
from biplan.solvers.bordered import _full_order, dense_solve, fits, lm_solve

__all__ = ["finite", "levenberg_marquardt", "lm_direction", "lm_step", "normal_equations"]


@kernel
def finite(x: np.ndarray) -> bool:
    """Whether every entry of x is finite."""
    return bool(np.all(np.isfinite(x)))


@kernel
def lm_step(jtj: np.ndarray, g: np.ndarray, damping: float) -> np.ndarray:
    """Levenberg–Marquardt step (JᵀJ + ν diag(JᵀJ + 1e-12)) dz = g, g = −Jᵀr (0 where not
    finite), from JᵀJ and g (:func:`normal_equations`)."""
    a = jtj.copy()
    for i in range(a.shape[0]):
        a[i, i] += damping * (jtj[i, i] + 1e-12)
    step = dense_solve(a, g)
    for i in range(step.shape[0]):
        if not np.isfinite(step[i]):
            step[i] = 0.0
    return step


@kernel
def normal_equations(jac: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(JᵀJ, −Jᵀr) of the Levenberg–Marquardt step."""
    return jac.T @ jac, -(jac.T @ r)


@kernel
def lm_direction(jac: np.ndarray, r: np.ndarray, damping: float) -> np.ndarray:
    """Levenberg–Marquardt step (JᵀJ + ν diag(JᵀJ + 1e-12)) dz = −Jᵀr (0 where not finite)."""
    jtj, g = normal_equations(jac, r)
    return lm_step(jtj, g, damping)


@kernel
def levenberg_marquardt(
    d: SystemData,
    jac: np.ndarray,
    r: np.ndarray,
    damping: float,
    structured: bool,
    jtj: np.ndarray,
    g: np.ndarray,
    kept: bool,
) -> tuple:  # type: ignore[type-arg]
    """(step, JᵀJ, −Jᵀr, kept): the Levenberg–Marquardt step of :func:`lm_direction` at
    (J, r), by the augmented system in the bordered banded solve where ``structured`` and the
    layout fits (:func:`biplan.solvers.bordered.lm_solve`), else from the normal equations
    (JᵀJ, −Jᵀr), formed once an iterate (``kept``: they are those of this J and r)."""
    n = jac.shape[0]
    order, band = d.solve_order, d.solve_band
    if structured and fits(n, order, band):
        step, ok = lm_solve(jac, r, damping, _full_order(order, n), band[0], band[1], band[2])
        if ok and finite(step):
            return step, jtj, g, kept
    if not kept:
        jtj, g = normal_equations(jac, r)
    return lm_step(jtj, g, damping), jtj, g, True
