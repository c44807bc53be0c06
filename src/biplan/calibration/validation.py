"""A predicted force–displacement curve measured against a measured band (paper Fig. 3 A.2).

:func:`compare_to_band` interpolates the prediction onto the band's grid (never extrapolating),
and reports the residual to the median, the root-mean-square error and the displacement
intervals where the prediction leaves the median ± 1 SD band. Arrays in, a frozen
:class:`BandComparison` out; running the model that makes the prediction is the caller's job
(``biplan validate``).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from biplan._errors import ConfigError
from biplan.calibration.band import Band

__all__ = ["BandComparison", "compare_to_band", "write_comparison"]


@dataclass(frozen=True, eq=False)
class BandComparison:
    """A predicted curve measured against a band (paper Fig. 3 A.2).

    Attributes
    ----------
    band : Band
    prediction_displacement, prediction_force : ndarray
        The predicted curve as given [mm, N] (finite points, sorted).
    predicted : ndarray, shape (G,)
        Prediction interpolated onto the band grid [N]; NaN outside its range.
    residual : ndarray, shape (G,)
        ``predicted − median`` [N]; NaN where either is missing.
    outside : ndarray of bool, shape (G,)
        Where |residual| exceeds the band's standard deviation.
    rms : float
        Root-mean-square residual [N] over the compared grid points.
    intervals : tuple of (float, float)
        Displacement intervals [mm] (runs of grid points within one phase) outside the band.
    """

    band: Band
    prediction_displacement: np.ndarray
    prediction_force: np.ndarray
    predicted: np.ndarray
    residual: np.ndarray
    outside: np.ndarray
    rms: float
    intervals: tuple[tuple[float, float], ...]

    @property
    def n_compared(self) -> int:
        """Grid points where both the median and the prediction exist."""
        return int(np.isfinite(self.residual).sum())

    @property
    def fraction_outside(self) -> float:
        """Fraction of the compared grid points outside the band."""
        n = self.n_compared
        return float(self.outside.sum() / n) if n else float("nan")


def compare_to_band(band: Band, displacement: np.ndarray, force: np.ndarray) -> BandComparison:
    """Compare a predicted force–displacement curve with a measured median ± 1 SD band.

    Parameters
    ----------
    band : Band
    displacement, force : array_like, shape (n,)
        Predicted curve [mm], [N]; non-finite points are dropped, the rest sorted by
        displacement and interpolated linearly onto the band grid (never extrapolated).

    Returns
    -------
    BandComparison

    Raises
    ------
    ConfigError
        If the prediction has no finite point, or none overlaps the measured band.
    """
    u = np.asarray(displacement, dtype=float).ravel()
    f = np.asarray(force, dtype=float).ravel()
    if u.shape != f.shape:
        raise ConfigError("force", f.shape, f"the displacement's shape {u.shape}")
    ok = np.isfinite(u) & np.isfinite(f)
    if not ok.any():
        raise ConfigError("prediction", "no finite point", "at least one finite (u, F) point")
    order = np.argsort(u[ok], kind="stable")
    u, f = u[ok][order], f[ok][order]
    grid = band.displacement
    inside = (grid >= u[0]) & (grid <= u[-1])
    predicted = np.where(inside, np.interp(grid, u, f), np.nan)
    residual = predicted - band.median
    compared = np.isfinite(residual)
    if not compared.any():
        raise ConfigError(
            "prediction displacement range",
            (float(u[0]), float(u[-1])),
            f"overlapping the measured band ({grid[0]:.4g} to {grid[-1]:.4g} mm)",
        )
    outside = compared & np.isfinite(band.std) & (np.abs(residual) > band.std)
    intervals = []
    for p in np.unique(band.phase):
        mask = outside & (band.phase == p)
        edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
        for i, j in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
            intervals.append((float(grid[i]), float(grid[j - 1])))
    rms = float(np.sqrt(np.mean(residual[compared] ** 2)))
    return BandComparison(
        band=band,
        prediction_displacement=u,
        prediction_force=f,
        predicted=predicted,
        residual=residual,
        outside=outside,
        rms=rms,
        intervals=tuple(sorted(intervals)),
    )


def write_comparison(result: BandComparison, file: Path) -> None:
    """Write a :class:`BandComparison` on its band grid as CSV (``validation.csv`` of
    ``biplan validate`` and ``biplan reproduce``): displacement [mm], phase, count, median [N],
    std [N], predicted [N], residual [N], outside (1/0)."""
    band = result.band
    with file.open("w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(
            ["displacement", "phase", "count", "median", "std", "predicted", "residual", "outside"]
        )
        for k in range(band.displacement.size):
            numbers = (band.median[k], band.std[k], result.predicted[k], result.residual[k])
            out.writerow(
                [f"{band.displacement[k]:.8g}", band.labels[band.phase[k]], int(band.count[k])]
                + [f"{x:.8g}" for x in numbers]
                + [int(result.outside[k])]
            )
