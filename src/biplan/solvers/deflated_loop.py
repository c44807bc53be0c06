"""Deflated Newton on the compiled system at rest (Numba; Farrell, Birkisson & Funke 2015).

Given known equilibria q_1 … q_m, the KKT residual r(z) at zero end load (MODEL §11) is
multiplied by the deflation operator::

    M(q) = Π_i ( 1 / ‖q − q_i‖^p + σ ),        η = log M

so that the known states are no longer roots of R = M r while every other root of r is. Its
Jacobian is ∂R/∂z = M J + M r ∇ηᵀ (∇η on the q columns). :func:`deflated_newton` runs the
package's one Newton (:func:`biplan.solvers.iteration.solve` with the deflation: Armijo
backtracking on ½‖R‖², the Levenberg–Marquardt fallback, the watchdog), converged when the
*undeflated* residual is small; a point with a coordinate beyond
:data:`~biplan.solvers.iteration.ESCAPE` has a NaN residual (a trial point there is rejected).
"""

from __future__ import annotations

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.assemble import _FIRST, evaluate
from biplan.model.system.tables import SystemData
from biplan.solvers.iteration import (
    ESCAPE,
    NewtonSettings,
    deflate,
    log_deflation,
    solve,
)

__all__ = ["ESCAPE", "deflated_newton", "deflated_system", "log_deflation"]


@kernel
def deflated_system(
    d: SystemData,
    z: np.ndarray,
    roots: np.ndarray,
    power: float,
    shift: float,
    second: bool,
) -> tuple:  # type: ignore[type-arg]
    """(R = M r (n_z,), ∂R/∂z (n_z, n_z) or (0, 0), M) at z at zero end load (module
    docstring); ``second`` (a run-time flag): whether to form the Jacobian."""
    r, jac = evaluate(d, z, np.zeros(3), second)[:2]
    data = np.concatenate((np.array([power, shift]), roots.ravel()))
    m = deflate(d, z, r, jac, data)
    return r, jac, m


@kernel
def deflated_newton(
    d: SystemData,
    z0: np.ndarray,
    roots: np.ndarray,
    power: float,
    shift: float,
    settings: NewtonSettings,
) -> tuple:  # type: ignore[type-arg]
    """Newton on the deflated system from z0 (module docstring).

    ``settings``: :class:`~biplan.solvers.iteration.NewtonSettings` (its tolerance on the
    undeflated residual [N, mm]).
    Returns (z, status, ‖r‖∞ of the undeflated residual at z, accepted steps).
    """
    data = np.concatenate((np.array([power, shift]), roots.ravel()))
    z, _, _, _, steps, status = solve(
        d, np.zeros(3), z0, settings, np.zeros(0), 0.0, np.zeros(0), data
    )
    undeflated = evaluate(d, z, np.zeros(3), _FIRST)[0]
    return z, status, np.max(np.abs(undeflated)), steps
