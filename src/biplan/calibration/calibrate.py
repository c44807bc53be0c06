"""Calibrate fold laws from measured CFT specimens (SI "Experimental Calibration").

Pipeline (:func:`calibrate_trilinear`, :func:`calibrate_linear`): the specimens' median ± 1 SD
band (:func:`~biplan.calibration.band.band_statistics`); a law fitted to the median curve at
the fold-field level (:mod:`biplan.calibration.fits`, specimen → field conversion F = H f(w),
u = n w); percentile bootstrap confidence intervals over specimens.

The median curve fitted
-----------------------
Median points enter the fit only where at least ``fit_coverage`` of the specimens have data
(default: all), so that specimens stopping (phase 1) or starting (phase 2) at different
displacements do not tilt the branches. For a trilinear law the breakpoints are either the
measured stability limits (:attr:`Breakpoints.MEASURED`, default: w1 = median end of phase 1,
w2 = median start of phase 2, each divided by n) — then the spinodal line is the
interpolation between the fitted branches at the two measured instability points, as the paper
does — or free (:attr:`Breakpoints.FREE`): the curve then carries the spinodal interpolated
linearly between the two measured instability points (``points_per_phase`` points,
:meth:`~biplan.calibration.band.Band.fit_curve`), which makes the breakpoints identifiable.

Bootstrap
---------
Resample the specimens with replacement (``n_bootstrap`` times, seeded), recompute the median
curve and its limits on the same grid, refit (free fits warm-started at the point estimate);
percentile intervals at level ``confidence``. With ten specimens, percentile intervals of a
median cover somewhat below their nominal rate (``docs/calibration.md``).

Caveats
-------
A calibration says when its numbers mean little (:attr:`Calibration.caveats`;
:mod:`biplan.calibration.caveats`).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

import numpy as np

from biplan._errors import ConfigError, check_integer, check_range
from biplan.calibration.band import Band, band_statistics
from biplan.calibration.caveats import (
    BISTABLE_DROP,
    MIN_BOOTSTRAP_SPECIMENS,
    POOR_FIT_RMS,
    Caveat,
    CaveatKind,
    caveats,
    force_drop,
)
from biplan.calibration.fits import CftGeometry, LawFit, fit_linear, fit_trilinear
from biplan.calibration.specimens import Specimen
from biplan.laws import LinearLaw, TrilinearLaw

__all__ = [
    "BISTABLE_DROP",
    "LINEAR_PARAMETERS",
    "MIN_BOOTSTRAP_SPECIMENS",
    "POOR_FIT_RMS",
    "TRILINEAR_PARAMETERS",
    "Breakpoints",
    "Calibration",
    "CalibrationOptions",
    "Caveat",
    "CaveatKind",
    "Estimate",
    "calibrate_linear",
    "calibrate_trilinear",
    "caveats",
    "force_drop",
]

#: Names and units of the fitted parameters, in the order of the estimates. l1, l2 are the
#: absolute breakpoints w1, w2 (``transitions`` under the ``absolute`` reading).
TRILINEAR_PARAMETERS = (
    ("k1", "N/mm²"),
    ("k2", "N/mm²"),
    ("k3", "N/mm²"),
    ("l1", "mm"),
    ("l2", "mm"),
)
LINEAR_PARAMETERS = (("k", "N/mm²"), ("offset", "N/mm"))


class Breakpoints(enum.Enum):
    """How a trilinear fit places its breakpoints w1 < w2.

    ``MEASURED``: at the measured stability limits (median end of phase 1, median start of
    phase 2), between which the paper interpolates the spinodal. ``FREE``: fitted.
    """

    MEASURED = "measured"
    FREE = "free"


@dataclass(frozen=True)
class CalibrationOptions:
    """Options of :func:`calibrate_trilinear` and :func:`calibrate_linear`.

    Parameters
    ----------
    breakpoints : Breakpoints
        Trilinear breakpoints measured (default) or free.
    offset : bool
        Linear fit with a free force offset (default: through the origin).
    n_bootstrap : int
        Bootstrap resamples of the specimens (≥ 0; 0: no intervals).
    confidence : float
        Two-sided level of the percentile intervals, in (0, 1).
    seed : int or None
        Seed of the bootstrap generator (≥ 0).
    points_per_phase, min_coverage
        Passed to :func:`~biplan.calibration.band.band_statistics`.
    fit_coverage : float
        Fraction in (0, 1] of the specimens that must have data at a median point for it to
        enter the fit (default 1: only where every specimen is measured, so that specimens
        stopping or starting at different displacements do not bias the branch slopes).
    """

    breakpoints: Breakpoints = Breakpoints.MEASURED
    offset: bool = False
    n_bootstrap: int = 200
    confidence: float = 0.95
    seed: int | None = 0
    points_per_phase: int = 60
    min_coverage: float = 0.5
    fit_coverage: float = 1.0

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "breakpoints", Breakpoints(self.breakpoints))
        except ValueError:
            valid = ", ".join(b.value for b in Breakpoints)
            raise ConfigError("breakpoints", self.breakpoints, f"one of {valid}") from None
        if isinstance(self.n_bootstrap, bool) or int(self.n_bootstrap) != self.n_bootstrap:
            raise ConfigError("n_bootstrap", self.n_bootstrap, "an integer ≥ 0")
        if self.n_bootstrap < 0:
            raise ConfigError("n_bootstrap", self.n_bootstrap, "an integer ≥ 0")
        check_range("confidence", self.confidence, low=0.0, high=1.0)
        check_range("fit_coverage", self.fit_coverage, low=0.0, high=1.0, high_open=False)
        if self.seed is not None:
            object.__setattr__(self, "seed", check_integer("seed", self.seed, low=0))


@dataclass(frozen=True)
class Estimate:
    """A fitted parameter with its bootstrap confidence interval.

    Attributes
    ----------
    name, unit : str
    value : float
        Fit to the median curve of all specimens.
    low, high : float
        Percentile interval bounds (NaN without bootstrap).
    """

    name: str
    unit: str
    value: float
    low: float
    high: float

    def covers(self, truth: float) -> bool:
        """Whether ``low ≤ truth ≤ high``."""
        return bool(self.low <= truth <= self.high)


@dataclass(frozen=True, eq=False)
class Calibration:
    """Result of :func:`calibrate_trilinear` / :func:`calibrate_linear`.

    Attributes
    ----------
    fit : LawFit
        Fit to the band's median curve (with the interpolated spinodal for free breakpoints).
    band : Band
        The specimens' median ± 1 SD band.
    estimates : tuple of Estimate
        (k1, k2, k3, l1, l2) or (k, offset), with intervals.
    options : CalibrationOptions
    samples : ndarray, shape (B, P)
        Bootstrap parameter samples (successful resamples only).
    n_failed : int
        Bootstrap resamples whose fit failed (dropped).
    caveats : tuple of Caveat
        What makes the numbers mean little (few specimens, bistable data under a linear law,
        a poor fit); empty when nothing does.
    """

    fit: LawFit
    band: Band
    estimates: tuple[Estimate, ...]
    options: CalibrationOptions
    samples: np.ndarray = field(repr=False)
    n_failed: int = 0
    caveats: tuple[Caveat, ...] = ()

    @property
    def law(self) -> TrilinearLaw | LinearLaw:
        """The fitted fold-field law."""
        return self.fit.law

    @property
    def geometry(self) -> CftGeometry:
        """The specimen geometry used for the conversion."""
        return self.fit.geometry

    def estimate(self, name: str) -> Estimate:
        """The estimate called ``name``."""
        for e in self.estimates:
            if e.name == name:
                return e
        raise KeyError(name)


def _band_curve(band: Band, options: CalibrationOptions, kind: str) -> tuple[np.ndarray, ...]:
    """The data (u, F) fitted to a band (see :class:`CalibrationOptions`)."""
    if kind == "trilinear" and len(band.labels) < 2:
        raise ConfigError(
            "segments",
            f"{len(band.labels)} phase(s) {list(band.labels)}",
            "two phases (labels) for a trilinear fit: phase 1 before the spinodal, phase 2 after",
        )
    free = kind == "trilinear" and options.breakpoints is Breakpoints.FREE
    gap = options.points_per_phase if free else 0
    need = math.ceil(options.fit_coverage * band.n_specimens - 1e-9)
    u, f, _ = band.fit_curve(gap_points=gap, min_count=need)
    return u, f


def _band_fit(
    band: Band,
    geometry: CftGeometry,
    options: CalibrationOptions,
    kind: str,
    start: tuple[float, float] | None = None,
) -> LawFit:
    """The law fitted to a band's median curve (``start``: free breakpoints' start [mm])."""
    u, f = _band_curve(band, options, kind)
    if kind == "linear":
        return fit_linear(u, f, geometry, offset=options.offset)
    limits = (float(band.limits[0, 1, 0]), float(band.limits[1, 0, 0]))
    if options.breakpoints is Breakpoints.MEASURED:
        return fit_trilinear(u, f, geometry, breakpoints=limits)
    return fit_trilinear(u, f, geometry, start=start or limits)


def _calibrate(
    specimens: tuple[Specimen, ...] | list[Specimen],
    geometry: CftGeometry | None,
    options: CalibrationOptions | None,
    kind: str,
) -> Calibration:
    geometry = geometry or CftGeometry()
    options = options or CalibrationOptions()
    band = band_statistics(
        specimens, points_per_phase=options.points_per_phase, min_coverage=options.min_coverage
    )
    fit = _band_fit(band, geometry, options, kind)
    start = None
    if isinstance(fit.law, TrilinearLaw):
        w1, w2 = fit.law.transitions
        start = (w1 * geometry.n_folds, w2 * geometry.n_folds)
    rng = np.random.default_rng(options.seed)
    samples, failed = [], 0
    for _ in range(options.n_bootstrap):
        idx = rng.integers(0, band.n_specimens, band.n_specimens)
        try:
            samples.append(_band_fit(band.subset(idx), geometry, options, kind, start).parameters)
        except (ConfigError, ValueError, np.linalg.LinAlgError):
            failed += 1
    table = TRILINEAR_PARAMETERS if kind == "trilinear" else LINEAR_PARAMETERS
    draws = np.asarray(samples, dtype=float).reshape(-1, len(table))
    tail = 50.0 * (1.0 - options.confidence)
    if draws.shape[0]:
        low, high = np.percentile(draws, [tail, 100.0 - tail], axis=0)
    else:
        low = high = np.full(len(table), np.nan)
    estimates = tuple(
        Estimate(name, unit, float(v), float(lo), float(hi))
        for (name, unit), v, lo, hi in zip(table, fit.parameters, low, high, strict=True)
    )
    notes = caveats(fit, band.n_specimens, options.n_bootstrap)
    return Calibration(fit, band, estimates, options, draws, failed, notes)


def calibrate_trilinear(
    specimens: tuple[Specimen, ...] | list[Specimen],
    geometry: CftGeometry | None = None,
    options: CalibrationOptions | None = None,
) -> Calibration:
    """Calibrate a trilinear fold law from trilinear-CFT specimens.

    Median ± 1 SD band of the specimens, spinodal interpolated between the measured
    instability points, trilinear fit (:func:`fit_trilinear`, breakpoints per
    ``options.breakpoints``), specimen → field conversion with ``geometry``, percentile
    bootstrap intervals over specimens.

    Parameters
    ----------
    specimens : sequence of Specimen
        Each with two phases (segment labels): phase 1 up to its instability point, phase 2
        from its stability limit on.
    geometry : CftGeometry, optional
        Default R = 2 mm, one fold.
    options : CalibrationOptions, optional

    Returns
    -------
    Calibration
        Estimates (k1, k2, k3, l1, l2); l1, l2 are the absolute breakpoints w1, w2 [mm].

    Raises
    ------
    ConfigError
        If the specimens do not measure two phases.
    """
    return _calibrate(specimens, geometry, options, "trilinear")


def calibrate_linear(
    specimens: tuple[Specimen, ...] | list[Specimen],
    geometry: CftGeometry | None = None,
    options: CalibrationOptions | None = None,
) -> Calibration:
    """Calibrate a linear fold law from linear-CFT specimens (see :func:`calibrate_trilinear`).

    Returns
    -------
    Calibration
        Estimates (k, offset); offset is 0 unless ``options.offset``.
    """
    return _calibrate(specimens, geometry, options, "linear")
