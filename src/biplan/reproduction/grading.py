"""Verdicts of the paper's claims, always derived from computed checks, never typed.

Every check function of :mod:`biplan.reproduction.claims` returns a :class:`Finding` whose
verdict comes from :func:`grade` (a list of computed pass/fail checks) or
:func:`grade_distance` (a computed distance to the paper's value).
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["Finding", "Grade", "fmt", "grade", "grade_distance", "yes_no"]


class Grade(enum.StrEnum):
    """How far a claim of the paper is reproduced (the stability verdict is
    :class:`biplan.analysis.stability.Verdict`)."""

    REPRODUCED = "reproduced"
    PARTLY = "partly"
    NOT = "not"


def grade(checks: Sequence[bool]) -> Grade:
    """All checks pass: reproduced; some: partly; none (or no checks): not."""
    passed = sum(bool(c) for c in checks)
    if checks and passed == len(checks):
        return Grade.REPRODUCED
    return Grade.PARTLY if passed else Grade.NOT


def grade_distance(distance: float, exact: float, near: float) -> Grade:
    """Reproduced when ``distance ≤ exact``, partly when ``≤ near``, else (or NaN) not."""
    d = float(distance)
    return grade([d <= exact, d <= near]) if np.isfinite(d) else grade([])


@dataclass(frozen=True)
class Finding:
    """What a check function returns: our value, the verdict and why.

    Attributes
    ----------
    value : str
        Our number or observation, in words.
    verdict : Grade
    reason : str
        What was checked, and which checks passed.
    """

    value: str
    verdict: Grade
    reason: str


def fmt(x: float, digits: int = 3) -> str:
    """``x`` to ``digits`` significant digits; ``—`` when not finite."""
    return f"{x:.{digits}g}" if np.isfinite(x) else "—"


def yes_no(checks: Sequence[bool]) -> str:
    """The checks as ``yes/no/…``, in order (for a finding's reason)."""
    return "/".join("yes" if c else "no" for c in checks)
