"""Calibration and validation figures (paper SI Fig. calib; main Fig. 3 A.2).

:func:`calibration_band` draws a CFT calibration: every specimen as a thin grey line, the median
curve and its ±1 SD band (shaded), the spinodal interpolated between the measured instability
points (dashed) and the fitted law mapped back to the specimen level (F = H f(u / n)). A
secondary axis on the right gives the fold-field line force f = F / H [N/mm].

:func:`validation_band` draws a design's predicted force–displacement curve over the measured
median ± 1 SD band (the gap between measured phases drawn as a dashed straight line), marks the
grid points where the prediction leaves the band and states the RMS error.

Both follow the :mod:`biplan.plot` contract ``f(result, *, ax=None) -> Axes``; colours are
Okabe–Ito (colour-blind safe). :func:`write_calibration_band` writes the first to a file
(``biplan calibrate --figure``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.laws import TrilinearLaw
from biplan.plot.files import figure_file
from biplan.plot.response import COLUMN_FIGSIZE, FONT_SIZE, _new_axes, _style

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from biplan.calibration.band import Band
    from biplan.calibration.calibrate import Calibration
    from biplan.calibration.validation import BandComparison

__all__ = ["calibration_band", "validation_band", "write_calibration_band"]

#: Okabe–Ito colours: band/median (blue), fit or prediction (vermillion), specimens (grey).
BAND_COLOR = "#0072B2"
FIT_COLOR = "#D55E00"
SPECIMEN_COLOR = "0.6"


def _band(band: Band, ax: Axes, *, gap_label: str, label_specimens: bool = True) -> None:
    """Specimens, median ± 1 SD per phase, straight lines across the gaps between phases."""
    for i, sp in enumerate(band.specimens):
        for j, seg in enumerate(sp.segments):
            first = label_specimens and i == 0 and j == 0
            ax.plot(
                seg.displacement,
                seg.force,
                "-",
                color=SPECIMEN_COLOR,
                lw=0.4,
                alpha=0.8,
                label=f"specimens ({band.n_specimens})" if first else None,
                zorder=1,
            )
    for p in range(len(band.labels)):
        sel = band.phase == p
        u, med, sd = band.displacement[sel], band.median[sel], band.std[sel]
        ok = np.isfinite(med)
        shade = ok & np.isfinite(sd)
        ax.fill_between(
            u,
            np.where(shade, med - sd, np.nan),
            np.where(shade, med + sd, np.nan),
            color=BAND_COLOR,
            alpha=0.25,
            lw=0,
            label=r"$\pm 1$ SD" if p == 0 else None,
            zorder=2,
        )
        ax.plot(u[ok], med[ok], "-", color=BAND_COLOR, lw=1.2, label="median" if p == 0 else None)
    for p in range(len(band.labels) - 1):
        (ua, fa), (ub, fb) = band.limits[p, 1], band.limits[p + 1, 0]
        ax.plot(
            [ua, ub], [fa, fb], "--", color=BAND_COLOR, lw=0.9, label=gap_label if p == 0 else None
        )
        ax.plot([ua, ub], [fa, fb], "o", color=BAND_COLOR, ms=2.5, zorder=3)


def _finish(ax: Axes, xlabel: str) -> None:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(r"$F$ [N]")
    ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
    ax.legend(fontsize=FONT_SIZE - 1, frameon=False, loc="best")
    _style(ax)


def calibration_band(
    result: Calibration, *, ax: Axes | None = None, field_axis: bool = True
) -> Axes:
    """Plot a CFT calibration: specimens, median ± 1 SD band and the fitted law.

    Parameters
    ----------
    result : Calibration
        From :func:`~biplan.calibration.calibrate.calibrate_trilinear` or
        :func:`~biplan.calibration.calibrate.calibrate_linear`.
    ax : Axes, optional
        Axes to draw into; a new 3.4 × 2.6 in figure when omitted.
    field_axis : bool
        Add a right-hand axis with the fold-field line force f = F / H [N/mm].

    Returns
    -------
    Axes
    """
    from biplan.calibration.fits import cft_force

    ax = _new_axes(ax, COLUMN_FIGSIZE)
    band = result.band
    _band(band, ax, gap_label="spinodal (interpolated)")
    hi = max(float(np.max(sp.segments[-1].displacement)) for sp in band.specimens)
    u = np.linspace(0.0, hi, 400)
    geo = result.geometry
    f = cft_force(result.law, geo, u) + result.fit.offset * geo.fold_length
    kind = "trilinear" if isinstance(result.law, TrilinearLaw) else "linear"
    ax.plot(u, f, "-", color=FIT_COLOR, lw=1.0, label=f"{kind} fit", zorder=4)
    _finish(ax, r"$u$ [mm]")
    if field_axis:
        h = result.geometry.fold_length

        def to_field(x: Any) -> Any:
            return np.asarray(x) / h

        def to_specimen(x: Any) -> Any:
            return np.asarray(x) * h

        sec = ax.secondary_yaxis("right", functions=(to_field, to_specimen))
        sec.set_ylabel(r"$f = F/H$ [N/mm]", fontsize=FONT_SIZE)
        sec.tick_params(labelsize=FONT_SIZE)
    return ax


def validation_band(result: BandComparison, *, ax: Axes | None = None) -> Axes:
    """Plot a predicted force–displacement curve over the measured median ± 1 SD band.

    Parameters
    ----------
    result : BandComparison
        From :func:`~biplan.calibration.validation.compare_to_band`.
    ax : Axes, optional
        Axes to draw into; a new 3.4 × 2.6 in figure when omitted.

    Returns
    -------
    Axes
    """
    ax = _new_axes(ax, COLUMN_FIGSIZE)
    band = result.band
    _band(band, ax, gap_label="not measured")
    ax.plot(
        result.prediction_displacement,
        result.prediction_force,
        "-",
        color=FIT_COLOR,
        lw=1.0,
        label=f"prediction (RMS {result.rms:.3g} N)",
        zorder=4,
    )
    out = result.outside
    if out.any():
        ax.plot(
            band.displacement[out],
            result.predicted[out],
            "x",
            color=FIT_COLOR,
            ms=3.0,
            mew=0.7,
            ls="none",
            label="outside band",
            zorder=5,
        )
    _finish(ax, r"$U$ [mm]")
    return ax


def write_calibration_band(result: Calibration, file: Path) -> None:
    """Write :func:`calibration_band` of ``result`` to ``file`` (one journal column; the
    format follows the suffix)."""
    with figure_file(file, figsize=COLUMN_FIGSIZE) as (_, ax):
        calibration_band(result, ax=ax)
