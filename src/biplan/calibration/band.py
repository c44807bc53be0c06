"""The median ± 1 SD band of measured specimens on a common displacement grid.

:func:`band_statistics` resamples every :class:`~biplan.calibration.specimens.Specimen` onto a
common grid (per phase, linear interpolation, NaN outside the specimen's own segment) and
returns a :class:`Band`: the median curve and the ±1 standard deviation band where at least a
fraction ``min_coverage`` of the specimens have data; the measured instability points are the
medians over specimens of each phase's end points, and :meth:`Band.fit_curve` interpolates the
spinodal linearly between them, as the paper does (SI "Experimental Calibration").
Specimens that stop at different displacements therefore thin the band out at its ends instead
of biasing it with a few survivors. All arrays are NumPy float64.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from biplan._errors import ConfigError, check_range
from biplan.calibration.specimens import Specimen

__all__ = ["Band", "band_statistics"]


@dataclass(frozen=True, eq=False)
class Band:
    """Median ± 1 SD band of specimens resampled onto a common displacement grid.

    Attributes
    ----------
    specimens : tuple of Specimen
    labels : tuple of str
        Phase labels, ordered by displacement.
    displacement : ndarray, shape (G,)
        Grid [mm], increasing within each phase, phases in order.
    phase : ndarray of int, shape (G,)
        Index into ``labels`` of each grid point.
    curves : ndarray, shape (S, G)
        Specimen forces [N] on the grid; NaN outside a specimen's segment.
    count : ndarray of int, shape (G,)
        Specimens with data at each grid point.
    median, std : ndarray, shape (G,)
        Median force and sample standard deviation [N]; NaN where fewer than ``min_count``
        specimens have data (std also where fewer than two).
    limits : ndarray, shape (P, 2, 2)
        Measured stability limits: ``limits[p, 0]`` = (u, F) median over specimens of the
        first sample of phase p, ``limits[p, 1]`` of the last one [mm, N].
    min_count : int
        Specimens needed at a grid point for a median.
    ends : ndarray, shape (S, P, 2, 2)
        Per specimen and phase, (u, F) of its first and last sample; NaN where a specimen
        does not measure the phase.
    """

    specimens: tuple[Specimen, ...]
    labels: tuple[str, ...]
    displacement: np.ndarray
    phase: np.ndarray
    curves: np.ndarray
    count: np.ndarray
    median: np.ndarray
    std: np.ndarray
    limits: np.ndarray
    min_count: int
    ends: np.ndarray

    @property
    def n_specimens(self) -> int:
        """Number of specimens S."""
        return len(self.specimens)

    def subset(self, indices: np.ndarray | list[int]) -> Band:
        """The band of the specimens ``indices`` (repeats allowed: a bootstrap sample).

        The grid is kept; ``min_count`` is recomputed with the same coverage fraction.
        """
        idx = np.asarray(indices, dtype=int)
        fraction = self.min_count / self.n_specimens
        return _statistics(
            tuple(self.specimens[i] for i in idx),
            self.labels,
            self.displacement,
            self.phase,
            self.curves[idx],
            self.ends[idx],
            max(1, math.ceil(fraction * idx.size - 1e-9)),
        )

    def fit_curve(
        self, *, gap_points: int = 0, min_count: int | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The median curve, optionally with each gap between phases interpolated linearly.

        Within phase p the median points between the measured limits ``limits[p]`` with at
        least ``min_count`` specimens are kept. With ``gap_points > 0``, between phases p and
        p + 1 the curve runs straight from ``limits[p, 1]`` to ``limits[p + 1, 0]`` (the
        spinodal, interpolated between the two measured instability points, SI "Experimental
        Calibration"), sampled at ``gap_points`` points including both limits.

        Parameters
        ----------
        gap_points : int
            Interpolated points per gap (0: none, else ≥ 2).
        min_count : int, optional
            Specimens needed at a median point (at most those measuring the phase); default
            :attr:`min_count`.

        Returns
        -------
        displacement, force : ndarray, shape (M,)
            [mm], [N], increasing in displacement.
        measured : ndarray of bool, shape (M,)
            False on interpolated points.
        """
        need = self.min_count if min_count is None else max(int(min_count), self.min_count)
        us: list[np.ndarray] = []
        fs: list[np.ndarray] = []
        for p in range(len(self.labels)):
            (u0, _), (u1, _) = self.limits[p]
            n_phase = int(np.isfinite(self.ends[:, p, 0, 0]).sum())  # specimens measuring p
            sel = (self.phase == p) & np.isfinite(self.median) & (self.count >= min(need, n_phase))
            sel &= (self.displacement >= u0 - 1e-12) & (self.displacement <= u1 + 1e-12)
            us.append(self.displacement[sel])
            fs.append(self.median[sel])
        u_m, f_m = np.concatenate(us), np.concatenate(fs)
        u_g, f_g = np.zeros(0), np.zeros(0)
        if gap_points:
            gaps = []
            for p in range(len(self.labels) - 1):
                (ua, fa), (ub, fb) = self.limits[p, 1], self.limits[p + 1, 0]
                t = np.linspace(0.0, 1.0, max(2, int(gap_points)))
                gaps.append((ua + (ub - ua) * t, fa + (fb - fa) * t))
            if gaps:
                u_g = np.concatenate([g[0] for g in gaps])
                f_g = np.concatenate([g[1] for g in gaps])
        u = np.concatenate([u_m, u_g])
        f = np.concatenate([f_m, f_g])
        m = np.concatenate([np.ones(u_m.size, dtype=bool), np.zeros(u_g.size, dtype=bool)])
        order = np.argsort(u, kind="stable")
        return u[order], f[order], m[order]


def _column_median(values: np.ndarray) -> np.ndarray:
    """Median over axis 0 ignoring NaN; NaN for all-NaN columns (without warnings)."""
    out = np.full(values.shape[1:], np.nan)
    ok = np.isfinite(values).any(axis=0)
    if ok.any():
        out[ok] = np.nanmedian(values[:, ok], axis=0)
    return out


def _statistics(
    specimens: tuple[Specimen, ...],
    labels: tuple[str, ...],
    grid: np.ndarray,
    phase: np.ndarray,
    curves: np.ndarray,
    ends: np.ndarray,
    min_count: int,
) -> Band:
    """Median, SD, counts and limits of resampled curves (shared by the full band and subsets)."""
    have = np.isfinite(curves)
    count = have.sum(axis=0)
    covered = count >= min_count
    median = np.full(grid.shape, np.nan)
    median[covered] = np.nanmedian(curves[:, covered], axis=0)
    std = np.full(grid.shape, np.nan)
    two = covered & (count >= 2)
    x = np.where(have[:, two], curves[:, two], 0.0)
    mean = x.sum(axis=0) / count[two]
    dev = np.where(have[:, two], curves[:, two] - mean, 0.0)
    std[two] = np.sqrt((dev**2).sum(axis=0) / (count[two] - 1))
    limits = _column_median(ends)
    for p, label in enumerate(labels):
        if not np.all(np.isfinite(limits[p])):
            raise ConfigError(f"phase {label!r}", "no specimen", "measured by some specimen")
    return Band(
        specimens=specimens,
        labels=labels,
        displacement=grid,
        phase=phase,
        curves=curves,
        count=count,
        median=median,
        std=std,
        limits=limits,
        min_count=min_count,
        ends=ends,
    )


def band_statistics(
    specimens: tuple[Specimen, ...] | list[Specimen],
    *,
    points_per_phase: int = 60,
    min_coverage: float = 0.5,
) -> Band:
    """Resample specimens onto a common grid; median and ±1 SD band per grid point.

    Parameters
    ----------
    specimens : sequence of Specimen
        At least one. Phases are matched by segment label and ordered by the median
        displacement at which they start.
    points_per_phase : int
        Grid points spanning each phase, from the smallest start to the largest end
        displacement of any specimen in it (≥ 2).
    min_coverage : float
        Fraction in (0, 1] of the specimens measuring a phase that must have data at a grid
        point for the median and SD there (handles specimens stopping at different
        displacements).

    Returns
    -------
    Band

    Raises
    ------
    ConfigError
        On no specimens or invalid options.
    """
    specs = tuple(specimens)
    if not specs:
        raise ConfigError("specimens", specs, "at least one specimen")
    if isinstance(points_per_phase, bool) or int(points_per_phase) != points_per_phase:
        raise ConfigError("points_per_phase", points_per_phase, "an integer ≥ 2")
    if points_per_phase < 2:
        raise ConfigError("points_per_phase", points_per_phase, "an integer ≥ 2")
    check_range("min_coverage", min_coverage, low=0.0, high=1.0, high_open=False)
    found: dict[str, list[float]] = {}
    for sp in specs:
        for seg in sp.segments:
            found.setdefault(seg.label, []).append(seg.start[0])
    labels = tuple(sorted(found, key=lambda lab: (float(np.median(found[lab])), lab)))
    grids, phases = [], []
    for p, label in enumerate(labels):
        starts = [sp.segment(label) for sp in specs]
        lo = min(s.start[0] for s in starts if s is not None)
        hi = max(s.end[0] for s in starts if s is not None)
        grids.append(np.linspace(lo, hi, int(points_per_phase)))
        phases.append(np.full(int(points_per_phase), p))
    grid, phase = np.concatenate(grids), np.concatenate(phases)
    curves = np.full((len(specs), grid.size), np.nan)
    ends = np.full((len(specs), len(labels), 2, 2), np.nan)
    for i, sp in enumerate(specs):
        for p, label in enumerate(labels):
            one = sp.segment(label)
            if one is None:
                continue
            sel = (phase == p) & (grid >= one.start[0]) & (grid <= one.end[0])
            curves[i, sel] = np.interp(grid[sel], one.displacement, one.force)
            ends[i, p] = (one.start, one.end)
    n_phase = max(len([s for s in specs if s.segment(lab)]) for lab in labels)
    min_count = max(1, math.ceil(min_coverage * n_phase - 1e-9))
    return _statistics(specs, labels, grid, phase, curves, ends, min_count)
