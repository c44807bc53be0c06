"""The data files of one response: ``STEM.nc`` and ``STEM.csv``, whatever traced it.

A path or trajectory is written by :func:`~biplan.io.results.labelled` /
:func:`~biplan.io.results.save_csv`, a stable-branch displacement sweep by
:func:`~biplan.io.results.sweep_labelled` / :func:`~biplan.io.results.save_sweep_csv` (its
labelled form needs the model: a sweep does not carry it). Both write their netCDF file
without importing xarray (:func:`biplan.io.netcdf.write_labelled`); the file reads back as
the result's ``xarray.Dataset`` (:func:`~biplan.io.results.dataset`,
:func:`~biplan.io.results.sweep_dataset`).
"""

from __future__ import annotations

from pathlib import Path as FilePath

from biplan._errors import ConfigError
from biplan.analysis.response.quasistatic import QuasiStaticPath
from biplan.io.results import labelled, save_csv, save_netcdf, save_sweep_csv, sweep_labelled
from biplan.model.assembly import Model
from biplan.solvers.path_results import EquilibriumPath
from biplan.solvers.trajectory_results import Trajectory

__all__ = ["save_response"]


def save_response(
    result: QuasiStaticPath | EquilibriumPath | Trajectory,
    stem: str | FilePath,
    model: Model | None = None,
) -> tuple[FilePath, FilePath]:
    """Write ``stem.nc`` (the labelled result, with the tube configuration) and ``stem.csv``
    (one row per step or time).

    Parameters
    ----------
    result : QuasiStaticPath, EquilibriumPath or Trajectory
    stem : str or pathlib.Path
        The files' path without suffix; its folder must exist.
    model : Model, optional
        The model of a sweep (required for a ``QuasiStaticPath``, unused otherwise).

    Returns
    -------
    tuple of pathlib.Path
        The netCDF and the CSV file.

    Raises
    ------
    ConfigError
        A sweep without its model.
    """
    stem = FilePath(stem)
    nc, csv = stem.with_name(stem.name + ".nc"), stem.with_name(stem.name + ".csv")
    if isinstance(result, QuasiStaticPath):
        if model is None:
            raise ConfigError("model", None, "the model of the stable-branch sweep")
        return save_netcdf(sweep_labelled(result, model), nc), save_sweep_csv(result, csv)
    return save_netcdf(labelled(result), nc), save_csv(result, csv)
