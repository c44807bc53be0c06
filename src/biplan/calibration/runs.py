"""A calibration from a directory of specimen files, as ``biplan calibrate`` runs it.

* :func:`calibration_setup` — the specimen geometry and CSV format of a calibration config
  (:func:`~biplan.calibration.config.read_calibration_config`; defaults R = 2 mm, one fold)
  with overrides, and the fit options, checked before any file is read
  (:class:`CalibrationSetup`);
* :func:`calibrate_directory` — every ``*.csv`` of a directory read as one specimen, then the
  law of :class:`LawKind` fitted (:mod:`biplan.calibration.calibrate`);
* :func:`write_law` — the TOML law block with its provenance, intervals and caveats as
  comments (:func:`~biplan.calibration.law_blocks.calibration_toml`);
* :func:`write_table` — the band and the fit on the common grid as CSV (:data:`TABLE_COLUMNS`:
  displacement [mm], phase, count, median [N], std [N], fitted [N], residual [N]).

The figure is drawn by :func:`biplan.plot.calibration.calibration_band`.
"""

from __future__ import annotations

import csv
import enum
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from biplan.calibration import calibrate
from biplan.calibration.calibrate import Calibration, CalibrationOptions
from biplan.calibration.config import read_calibration_config, with_overrides
from biplan.calibration.files import SpecimenFormat, read_specimens
from biplan.calibration.fits import CftGeometry
from biplan.calibration.law_blocks import calibration_toml

__all__ = [
    "TABLE_COLUMNS",
    "CalibrationSetup",
    "LawKind",
    "calibrate_directory",
    "calibration_setup",
    "write_law",
    "write_table",
]

#: Columns of :func:`write_table`.
TABLE_COLUMNS = ("displacement", "phase", "count", "median", "std", "fitted", "residual")


class LawKind(enum.StrEnum):
    """The law a calibration fits."""

    trilinear = "trilinear"  #: bistable, from two-phase specimens
    linear = "linear"


@dataclass(frozen=True)
class CalibrationSetup:
    """Everything a calibration needs besides the specimen files.

    Attributes
    ----------
    geometry : CftGeometry
        Specimen geometry (radius [mm], circular folds in series).
    format : SpecimenFormat
        Columns and units of the specimen CSV files.
    options : CalibrationOptions
        Breakpoints or offset, bootstrap resamples, confidence, seed.
    """

    geometry: CftGeometry
    format: SpecimenFormat
    options: CalibrationOptions


def calibration_setup(
    config: Path | None = None,
    *,
    geometry: dict[str, Any] | None = None,
    fmt: dict[str, Any] | None = None,
    options: dict[str, Any] | None = None,
) -> CalibrationSetup:
    """The setup of a calibration: ``config`` (a TOML calibration config, or the defaults)
    with the changes ``geometry`` (fields of :class:`CftGeometry`) and ``fmt`` (fields of
    :class:`SpecimenFormat`) applied, None values ignored, and :class:`CalibrationOptions` of
    ``options``.

    Raises
    ------
    ConfigError
        An unreadable or invalid config (named by file and key), or an invalid change or
        option (named by its field: ``radius``, ``displacement column``, ``seed``, …).
    """
    base_geometry, base_fmt = (CftGeometry(), SpecimenFormat())
    if config is not None:
        base_geometry, base_fmt = read_calibration_config(config)
    changes = {k: v for k, v in (geometry or {}).items() if v is not None}
    return CalibrationSetup(
        geometry=replace(base_geometry, **changes),
        format=with_overrides(base_fmt, **(fmt or {})),
        options=CalibrationOptions(**(options or {})),
    )


def calibrate_directory(kind: LawKind, data_dir: Path, setup: CalibrationSetup) -> Calibration:
    """Calibrate a law of ``kind`` from every ``*.csv`` specimen file in ``data_dir``.

    Raises
    ------
    DataError
        No specimen file, or a file's first problem (file, row, column).
    ConfigError
        Specimens that do not fit the law (e.g. a trilinear law without two phases).
    """
    specimens = read_specimens(data_dir, setup.format, radius=setup.geometry.radius)
    if LawKind(kind) is LawKind.trilinear:
        return calibrate.calibrate_trilinear(specimens, setup.geometry, setup.options)
    return calibrate.calibrate_linear(specimens, setup.geometry, setup.options)


def write_law(result: Calibration, fold_set: str, file: Path, *, source: str = "") -> str:
    """Write the ``[laws.<fold_set>]`` block of a calibration to ``file`` (its folder
    created), with ``source`` (the data directory) among its comments; returns the text."""
    text = calibration_toml(result, fold_set, source=source)
    file.parent.mkdir(parents=True, exist_ok=True)
    file.write_text(text, encoding="utf-8")
    return text


def write_table(result: Calibration, file: Path) -> None:
    """Write the band and the fit on the band's common grid as CSV (:data:`TABLE_COLUMNS`:
    displacement [mm], phase, count, median, std, fitted, residual [N]; the residual is NaN
    off the fitted points, the fitted force outside the fitted range)."""
    band = result.band
    u = band.displacement
    fitted = np.interp(u, result.fit.displacement, result.fit.fitted, left=np.nan, right=np.nan)
    on_fit = np.isin(u, result.fit.displacement)
    with file.open("w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(TABLE_COLUMNS)
        for k in range(u.size):
            res = fitted[k] - band.median[k] if on_fit[k] else np.nan
            out.writerow(
                [f"{u[k]:.8g}", band.labels[band.phase[k]], int(band.count[k])]
                + [f"{x:.8g}" for x in (band.median[k], band.std[k], fitted[k], res)]
            )
