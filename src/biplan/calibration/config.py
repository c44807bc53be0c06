"""The calibration config: specimen geometry and CSV format from a TOML file
(:func:`read_calibration_config`), and a format with options of the command line on top
(:func:`with_overrides`).
"""

from __future__ import annotations

import tomllib
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from biplan._errors import ConfigError
from biplan.calibration.files import SpecimenFormat
from biplan.calibration.fits import CftGeometry

__all__ = ["read_calibration_config", "with_overrides"]


def read_calibration_config(path: str | Path) -> tuple[CftGeometry, SpecimenFormat]:
    """Specimen geometry and CSV format from a TOML file.

    Schema (all keys optional)::

        [geometry]
        radius = 2.0          # R [mm] of the CFT specimens
        n_folds = 1           # circular folds in series
        [columns]
        displacement = "displacement"
        force = "force"
        pressure = "pressure"
        segment = "segment"
        min_points = 5
        [units]
        displacement = "mm"
        force = "N"
        pressure = "kPa"

    Raises
    ------
    ConfigError
        On unreadable files, bad TOML or unknown or invalid keys (``parameter`` = dotted key).
    """
    source = str(path)
    try:
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise ConfigError(source, str(err), "a readable TOML calibration config") from None
    allowed = {
        "geometry": ("radius", "n_folds"),
        "columns": ("displacement", "force", "pressure", "segment", "min_points"),
        "units": ("displacement", "force", "pressure"),
    }
    for key, table in data.items():
        if key not in allowed or not isinstance(table, dict):
            raise ConfigError(f"{source}: {key}", table, f"one of the tables {list(allowed)}")
        for name in table:
            if name not in allowed[key]:
                raise ConfigError(f"{source}: {key}.{name}", table[name], f"one of {allowed[key]}")
    geo = data.get("geometry", {})
    cols = dict(data.get("columns", {}))
    units = {f"{k}_unit": v for k, v in data.get("units", {}).items()}
    try:
        geometry = CftGeometry(**geo)
    except ConfigError as err:
        raise ConfigError(f"{source}: geometry.{err.parameter}", err.value, err.valid) from None
    try:
        fmt = SpecimenFormat(**cols, **units)
    except ConfigError as err:
        name = str(err.parameter)
        if name.endswith("_unit"):
            key = f"units.{name.removesuffix('_unit')}"
        else:
            key = f"columns.{name.removesuffix(' column')}"
        raise ConfigError(f"{source}: {key}", err.value, err.valid) from None
    return geometry, fmt


def with_overrides(fmt: SpecimenFormat, **changes: Any) -> SpecimenFormat:
    """``fmt`` with the given fields replaced (None values ignored)."""
    valid = {f.name for f in fields(SpecimenFormat)}
    return replace(fmt, **{k: v for k, v in changes.items() if v is not None and k in valid})
