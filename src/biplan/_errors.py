"""Exception hierarchy of biplan.

Every invalid parameter raises :class:`ConfigError` (a :class:`ValueError`) that names the
parameter, its value and the valid range, before any solve starts. A solve that does not
converge returns a status; with ``throw=True`` it raises :class:`ConvergenceError` instead. A
result's status is a :class:`ResultStatus` (its code, a one-line ``message`` and ``ok``). A
valid request that will cost much more than usual (a tube of hundreds of modules) issues a
:class:`CostWarning` (a :class:`UserWarning`) saying what it will cost, before the work; the
command line prints it as one yellow line.
"""

from __future__ import annotations

import enum
import math
import numbers
from typing import Any

__all__ = [
    "BiplanError",
    "BiplanWarning",
    "ConfigError",
    "ConvergenceError",
    "CostWarning",
    "ResultStatus",
    "check_finite",
    "check_integer",
    "check_range",
]


class BiplanError(Exception):
    """Base class of every biplan error."""


class ConfigError(BiplanError, ValueError):
    """An input parameter is invalid.

    Parameters
    ----------
    parameter : str
        Name of the offending parameter (dotted path for nested config entries).
    value : object
        The value that was given.
    valid : str
        Human-readable description of the valid range.
    """

    def __init__(self, parameter: str, value: Any, valid: str) -> None:
        self.parameter = parameter
        self.value = value
        self.valid = valid
        super().__init__(f"invalid {parameter} = {value!r}: must be {valid}")


class ConvergenceError(BiplanError, RuntimeError):
    """A solver did not converge (raised only with ``throw=True``)."""


class ResultStatus(enum.Enum):
    """Base of every result's status (solve, path, trajectory, departure, minimum-energy path).

    A member is declared as ``NAME = code, message`` or ``NAME = code, message, ok``: ``value``
    is the code (what the compiled kernels return and the files hold), ``message`` says in one
    line why the result ended, ``ok`` whether it is the result asked for (default ``False``).
    Every result carries its status as ``result.status`` and a message that starts from it
    as ``result.message``; every driver's ``throw=True`` raises :class:`ConvergenceError`
    with that message when the status is not ``ok``.
    """

    message: str
    ok: bool

    def __new__(cls, *declared: Any) -> ResultStatus:  # (code, message[, ok])
        member = object.__new__(cls)
        member._value_ = declared[0]
        member.message = declared[1]
        member.ok = bool(declared[2]) if len(declared) > 2 else False
        return member


class BiplanWarning(UserWarning):
    """Base class of every biplan warning."""


class CostWarning(BiplanWarning):
    """A valid request whose cost is out of proportion (the message gives the estimate)."""


def check_finite(name: str, value: float) -> float:
    """Return ``float(value)`` or raise :class:`ConfigError` if it is not a finite number."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ConfigError(name, value, "a finite real number") from None
    if not math.isfinite(x):
        raise ConfigError(name, value, "a finite real number")
    return x


def check_range(
    name: str,
    value: float,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = True,
    high_open: bool = True,
    unit: str = "",
) -> float:
    """Return ``float(value)`` if it is finite and inside the given (open or closed) interval,
    else raise :class:`ConfigError` naming ``name``, the value and the interval (``> 0``,
    ``≥ 1``, ``in (0, 1]``…, followed by ``unit``)."""
    x = check_finite(name, value)
    if low is not None and high is not None:
        lo_txt = "(" if low_open else "["
        hi_txt = ")" if high_open else "]"
        interval = f"in {lo_txt}{low:g}, {high:g}{hi_txt}"
    elif low is not None:
        interval = f"{'>' if low_open else '≥'} {low:g}"
    elif high is not None:
        interval = f"{'<' if high_open else '≤'} {high:g}"
    else:
        interval = "a finite real number"
    if unit:
        interval += f" {unit}"
    if low is not None and (x < low or (low_open and x == low)):
        raise ConfigError(name, value, interval)
    if high is not None and (x > high or (high_open and x == high)):
        raise ConfigError(name, value, interval)
    return x


def check_integer(
    name: str, value: int, *, low: int, high: int | None = None, note: str = ""
) -> int:
    """Return ``int(value)`` if it is an integer (Python or NumPy, not a bool) in
    [``low``, ``high``], else raise :class:`ConfigError` naming ``name`` (``note`` is appended
    to the valid range)."""
    valid = f"an integer ≥ {low}" if high is None else f"an integer in [{low}, {high}]"
    if (
        isinstance(value, bool)
        or not isinstance(value, numbers.Integral)
        or value < low
        or (high is not None and value > high)
    ):
        raise ConfigError(name, value, valid + note)
    return int(value)
