"""Result files: labelled datasets of paths and trajectories in netCDF and CSV.

* :func:`dataset` — a :class:`~biplan.solvers.results.Path` or
  :class:`~biplan.solvers.results.Trajectory` as an ``xarray.Dataset`` whose attributes carry
  the tube's TOML configuration (``config``) so that the file re-opens as a model;
* :func:`save` — write ``.nc`` (netCDF4 via h5netcdf) or ``.csv`` (one row per step/time, the
  scalar observables; units in the header comment line);
* :func:`load_result` and :func:`model_of` — read a netCDF result and rebuild its model.
"""

from __future__ import annotations

import csv
from pathlib import Path as FilePath
from typing import Any

import numpy as np

from biplan._errors import ConfigError
from biplan.assembly import Model
from biplan.io.config import dump_config, load_config_text
from biplan.solvers.results import Path, Trajectory

__all__ = ["CSV_COLUMNS", "dataset", "load_result", "model_of", "save", "save_csv", "save_netcdf"]

#: Scalar columns of the CSV form, in order (``t`` first for trajectories).
CSV_COLUMNS = (
    "load_parameter",
    "force",
    "displacement",
    "u_z",
    "u_r",
    "theta",
    "energy",
    "helical_energy",
    "circular_energy",
    "min_eigenvalue",
    "stable",
)
_TRAJECTORY_EXTRA = ("kinetic_energy", "external_work", "dissipated_energy", "total_energy")


def dataset(result: Path | Trajectory) -> Any:
    """The labelled form of a result, with ``attrs["config"]`` = the tube's TOML text."""
    if not isinstance(result, Path | Trajectory):
        raise ConfigError("result", type(result).__name__, "a biplan Path or Trajectory")
    ds = result.to_dataset()
    ds.attrs["config"] = dump_config(result.model.tube)
    return ds


def save_netcdf(result: Path | Trajectory | Any, path: str | FilePath) -> FilePath:
    """Write a result (or its dataset) to netCDF [h5netcdf engine]."""
    ds = result if not isinstance(result, Path | Trajectory) else dataset(result)
    out = FilePath(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(out, engine="h5netcdf")
    return out


def save_csv(result: Path | Trajectory, path: str | FilePath) -> FilePath:
    """Write the scalar observables, one row per step (path) or time (trajectory, column
    ``t`` [s] first). A first comment line gives the units."""
    if not isinstance(result, Path | Trajectory):
        raise ConfigError("result", type(result).__name__, "a biplan Path or Trajectory")
    ds = result.to_dataset()
    cols = list(CSV_COLUMNS)
    if isinstance(result, Trajectory):
        cols = ["t", *cols, *_TRAJECTORY_EXTRA]
    else:
        cols = ["step", *cols, "limit_point"]
    data = {c: _column(ds, c) for c in cols}
    units = {c: ds[c].attrs.get("units", "") if c in ds else "" for c in cols}
    units["t"] = "s"
    out = FilePath(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w", newline="") as fh:
        fh.write("# units: " + ", ".join(f"{c} [{units[c] or '-'}]" for c in cols) + "\n")
        w = csv.writer(fh)
        w.writerow(cols)
        for i in range(len(data[cols[0]])):
            w.writerow([_fmt(data[c][i]) for c in cols])
    return out


def _column(ds: Any, name: str) -> np.ndarray:
    if name == "t":
        return np.asarray(ds["time"].values)
    if name == "step":
        return np.asarray(ds["step"].values)
    return np.asarray(ds[name].values)


def _fmt(v: Any) -> str:
    if isinstance(v, np.integer | int):
        return str(int(v))
    return repr(float(v))


def save(result: Path | Trajectory, path: str | FilePath) -> FilePath:
    """Write ``.nc`` or ``.csv`` by the file suffix."""
    p = FilePath(path)
    if p.suffix == ".nc":
        return save_netcdf(result, p)
    if p.suffix == ".csv":
        return save_csv(result, p)
    raise ConfigError("path", str(path), "a file name ending in .nc or .csv")


def load_result(path: str | FilePath) -> Any:
    """Open a result file written by :func:`save_netcdf` (loaded into memory)."""
    import xarray as xr

    p = FilePath(path)
    if not p.is_file():
        raise ConfigError("result", str(path), "an existing netCDF result file")
    with xr.open_dataset(p, engine="h5netcdf") as ds:
        return ds.load()


def model_of(ds: Any) -> Model:
    """The Model of a result dataset (from its ``config`` attribute)."""
    text = ds.attrs.get("config")
    if not text:
        raise ConfigError("dataset.attrs['config']", None, "the tube configuration of the result")
    return Model(load_config_text(text, source="<result file>"))
