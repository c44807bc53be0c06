"""The interface of the Newton core (:mod:`biplan.solvers.core`): the traced
:class:`Settings` of a compiled iteration and the :class:`Status` a solve ends with.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from biplan._compile.setup import jnp
from biplan._errors import ResultStatus

__all__ = ["Settings", "Status"]

Array = Any


class Status(ResultStatus):
    """Outcome of a solve."""

    CONVERGED = 0, "converged", True
    MAX_STEPS = 1, "maximum number of Newton steps reached before the residual tolerance"
    LINE_SEARCH_FAILED = (
        2,
        "neither the Newton line search nor Levenberg–Marquardt reduced the residual",
    )
    NONFINITE = 3, "the residual or the Newton step became non-finite"


class Settings(NamedTuple):
    """The traced settings of the compiled iteration (float64 scalars;
    :meth:`biplan.solvers.Newton.settings` builds them).

    Attributes
    ----------
    atol : scalar
        Convergence when ‖R‖∞ < atol (the residual's units).
    max_steps : scalar
        Accepted Newton steps allowed.
    max_backtracks : scalar
        Step halvings of the line search before Levenberg–Marquardt (or failure).
    armijo : scalar
        Sufficient-decrease constant c of the Armijo test.
    free_steps : scalar
        Watchdog length (read only by a machine built with ``free_steps=None``).
    """

    atol: Array
    max_steps: Array
    max_backtracks: Array
    armijo: Array
    free_steps: Array

    @classmethod
    def of(
        cls,
        atol: Any,
        max_steps: Any,
        max_backtracks: Any = 30,
        armijo: Any = 1e-4,
        free_steps: Any = 0,
    ) -> Settings:
        """Settings from numbers or traced scalars (each as a float64 array)."""
        values = (atol, max_steps, max_backtracks, armijo, free_steps)
        return cls(*(jnp.asarray(v, dtype=jnp.float64) for v in values))
