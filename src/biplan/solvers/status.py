"""The :class:`Status` an iterative solve ends with (the one Newton, :mod:`.iteration`, and
every compiled loop built on it)."""

from __future__ import annotations

from biplan._errors import ResultStatus

__all__ = ["Status"]


class Status(ResultStatus):
    """Outcome of a solve."""

    CONVERGED = 0, "converged", True
    MAX_STEPS = 1, "maximum number of Newton steps reached before the residual tolerance"
    LINE_SEARCH_FAILED = (
        2,
        "neither the Newton line search nor Levenberg–Marquardt reduced the residual",
    )
    NONFINITE = 3, "the residual or the Newton step became non-finite"
