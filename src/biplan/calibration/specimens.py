"""Measured specimen curves: segments and specimens (their band: :mod:`biplan.calibration.band`).

Contract
--------
A :class:`Specimen` is one tested tube: one or more :class:`Segment` s of (displacement [mm],
force [N]) samples, each strictly monotonic in displacement. Segments carry a phase label; in
the paper's trilinear Circular Folded Tube (CFT) tests (SI "Experimental Calibration") phase 1
is measured under pressure-driven extension up to its instability point and phase 2 under
gravity-induced contraction down to its stability limit, so nothing is measured inside the
spinodal between them.

:func:`~biplan.calibration.band.band_statistics` makes their median ± 1 SD band
(:mod:`biplan.calibration.band`); :func:`~biplan.calibration.validation.compare_to_band`
measures a predicted curve against it (the validation of paper Fig. 3 A.2).

All arrays are NumPy float64; no file I/O here (see :mod:`biplan.calibration.files`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan._errors import ConfigError

__all__ = ["MIN_POINTS", "Segment", "SegmentProblem", "Specimen", "segment_problem"]

#: Default minimum number of samples in one segment.
MIN_POINTS = 5


@dataclass(frozen=True)
class SegmentProblem:
    """The first defect of a segment's samples (see :func:`segment_problem`).

    Attributes
    ----------
    index : int
        0-based sample index of the offending point (the last sample for too few points).
    quantity : str
        ``"displacement"``, ``"force"`` or ``"points"``.
    value : object
        The offending value.
    valid : str
        What would have been valid.
    """

    index: int
    quantity: str
    value: Any
    valid: str


def segment_problem(
    displacement: np.ndarray, force: np.ndarray, *, min_points: int = MIN_POINTS
) -> SegmentProblem | None:
    """The first defect of one segment's samples, or None if they are valid.

    Checked in this order: finite values (no NaN or inf), strictly monotonic displacement
    (increasing or decreasing throughout), at least ``min_points`` samples.

    Parameters
    ----------
    displacement, force : ndarray, shape (n,)
        Samples in mm and N.
    min_points : int
        Minimum number of samples.

    Returns
    -------
    SegmentProblem or None
    """
    u = np.asarray(displacement, dtype=float)
    f = np.asarray(force, dtype=float)
    for name, x in (("displacement", u), ("force", f)):
        bad = np.flatnonzero(~np.isfinite(x))
        if bad.size:
            return SegmentProblem(int(bad[0]), name, float(x[bad[0]]), "a finite number")
    d = np.diff(u)
    if d.size:
        direction = np.sign(d[0])
        wrong = np.flatnonzero(np.sign(d) != direction) if direction else np.array([0])
        if wrong.size:
            i = int(wrong[0]) + 1
            sense = "increasing" if direction >= 0 else "decreasing"
            valid = (
                f"strictly {sense} within the segment, like the values before it "
                f"(non-monotonic displacement: the previous value is {u[i - 1]:.6g} mm)"
            )
            if not direction:
                valid = (
                    f"different from the previous value {u[0]:.6g} mm "
                    "(non-monotonic displacement: it must be strictly monotonic)"
                )
            return SegmentProblem(i, "displacement", float(u[i]), valid)
    if u.size < min_points:
        return SegmentProblem(
            max(u.size - 1, 0), "points", int(u.size), f"at least {min_points} points"
        )
    return None


def _frozen(x: np.ndarray) -> np.ndarray:
    x = np.array(x, dtype=float)
    x.flags.writeable = False
    return x


@dataclass(frozen=True, eq=False)
class Segment:
    """One continuously measured stretch of a specimen curve.

    Parameters
    ----------
    displacement : array_like, shape (n,)
        End displacement (tube extension) u [mm], strictly monotonic; stored increasing.
    force : array_like, shape (n,)
        End force F [N] (tension positive).
    label : str
        Phase label (e.g. ``"1"``, ``"2"``); segments with equal labels across specimens are
        averaged together.

    Raises
    ------
    ConfigError
        On mismatched shapes or any :func:`segment_problem` (with ``min_points`` = 2).
    """

    displacement: np.ndarray
    force: np.ndarray
    label: str = "1"

    def __post_init__(self) -> None:
        u = np.asarray(self.displacement, dtype=float).ravel()
        f = np.asarray(self.force, dtype=float).ravel()
        if u.shape != f.shape:
            raise ConfigError(
                f"segment {self.label!r} force", f.shape, f"the displacement's shape {u.shape}"
            )
        problem = segment_problem(u, f, min_points=2)
        if problem is not None:
            raise ConfigError(
                f"segment {self.label!r} {problem.quantity}[{problem.index}]",
                problem.value,
                problem.valid,
            )
        if u[-1] < u[0]:
            u, f = u[::-1], f[::-1]
        object.__setattr__(self, "displacement", _frozen(u))
        object.__setattr__(self, "force", _frozen(f))
        object.__setattr__(self, "label", str(self.label))

    @property
    def start(self) -> tuple[float, float]:
        """(u, F) of the sample of smallest displacement [mm, N]."""
        return float(self.displacement[0]), float(self.force[0])

    @property
    def end(self) -> tuple[float, float]:
        """(u, F) of the sample of largest displacement [mm, N]."""
        return float(self.displacement[-1]), float(self.force[-1])


@dataclass(frozen=True, eq=False)
class Specimen:
    """One tested specimen: its segments, ordered by displacement and not overlapping.

    Parameters
    ----------
    name : str
        Identifier (the file name when read from disk).
    segments : tuple of Segment
        At least one; labels unique within the specimen.
    """

    name: str
    segments: tuple[Segment, ...]

    def __post_init__(self) -> None:
        segs = tuple(sorted(self.segments, key=lambda s: s.start[0]))
        if not segs:
            raise ConfigError(f"{self.name} segments", (), "at least one segment")
        labels = [s.label for s in segs]
        if len(set(labels)) != len(labels):
            raise ConfigError(f"{self.name} segment labels", labels, "unique within a specimen")
        for a, b in itertools.pairwise(segs):
            if b.start[0] <= a.end[0]:
                raise ConfigError(
                    f"{self.name} segment {b.label!r} start",
                    b.start[0],
                    f"> {a.end[0]:.6g} mm, the end of segment {a.label!r} (no overlap)",
                )
        object.__setattr__(self, "segments", segs)

    def segment(self, label: str) -> Segment | None:
        """The segment of phase ``label``, or None."""
        return next((s for s in self.segments if s.label == label), None)
