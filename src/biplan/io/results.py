"""Result files: labelled datasets of paths and trajectories in netCDF and CSV.

* :func:`dataset` — a :class:`~biplan.solvers.path_results.EquilibriumPath` or
  :class:`~biplan.solvers.trajectory_results.Trajectory` as an ``xarray.Dataset`` whose
  attributes carry the tube's TOML configuration (``config``) so that the file re-opens as a
  model;
* :func:`save` — write ``.nc`` (netCDF4 via h5netcdf) or ``.csv`` (one row per step/time, the
  scalar observables; units in the header comment line);
* :func:`load_result` and :func:`model_of` — read a netCDF result and rebuild its model;
* :func:`sweep_dataset`, :func:`save_sweep_csv` — the same for a stable-branch displacement
  sweep (:func:`~biplan.analysis.response.quasistatic.displacement_sweep`);
* :func:`result_kind` and :func:`describe_result` — what a result file is (a path, trajectory,
  sweep, state catalogue, design or stability map), read from its attributes.
"""

from __future__ import annotations

import csv
import enum
from pathlib import Path as FilePath
from typing import Any

import numpy as np

from biplan._errors import ConfigError
from biplan.analysis.response.quasistatic import SWEEP_KIND, QuasiStaticPath
from biplan.io.config import dump_config, load_config_text
from biplan.io.netcdf import write_labelled, write_netcdf
from biplan.model.assembly import Load, Model
from biplan.solvers.path_results import EquilibriumPath
from biplan.solvers.results import ENERGY_BALANCE, RESPONSE_VARIABLES, Labelled
from biplan.solvers.trajectory_results import Trajectory

__all__ = [
    "CSV_COLUMNS",
    "SWEEP_COLUMNS",
    "SWEEP_CSV_COLUMNS",
    "ResultKind",
    "dataset",
    "describe_result",
    "labelled",
    "load_result",
    "model_of",
    "result_kind",
    "save",
    "save_csv",
    "save_netcdf",
    "save_sweep_csv",
    "sweep_dataset",
    "sweep_labelled",
]

#: Scalar columns of the CSV form, in order (``t`` first for trajectories).
CSV_COLUMNS = (*RESPONSE_VARIABLES, "min_eigenvalue", "stable")
_TRAJECTORY_EXTRA = ENERGY_BALANCE
#: Columns of a stable-branch sweep: name → (unit, description).
SWEEP_COLUMNS = {
    "displacement": ("mm", "prescribed load-point displacement U"),
    "force": ("N", "end reaction force F"),
    "u_z": ("mm", "axial endpoint displacement"),
    "u_r": ("mm", "radial endpoint displacement"),
    "theta": ("rad", "endpoint slope"),
    "energy": ("N*mm", "strain energy"),
    "min_eigenvalue": ("N*mm", "smallest reduced-Hessian eigenvalue (inf: contact-locked)"),
    "stable": ("1", "1 stable"),
    "switched": ("1", "1 where the sweep snapped to a stable state on another branch"),
}
#: Columns of :func:`save_sweep_csv`, in order.
SWEEP_CSV_COLUMNS = (
    "displacement", "force", "u_z", "u_r", "theta", "energy", "min_eigenvalue", "stable",
    "status", "switched",
)  # fmt: skip


def _checked(result: Any) -> EquilibriumPath | Trajectory:
    if not isinstance(result, EquilibriumPath | Trajectory):
        raise ConfigError("result", type(result).__name__, "a biplan EquilibriumPath or Trajectory")
    return result


def labelled(result: EquilibriumPath | Trajectory) -> Labelled:
    """The labelled form of a result in plain arrays (what :func:`dataset` holds), with
    ``attrs["config"]`` = the tube's TOML text."""
    result = _checked(result)
    return result.labelled().with_attrs(config=dump_config(result.model.tube))


def dataset(result: EquilibriumPath | Trajectory) -> Any:
    """The labelled form of a result as an ``xarray.Dataset``, with ``attrs["config"]`` = the
    tube's TOML text."""
    return labelled(result).to_dataset()


def save_netcdf(
    result: EquilibriumPath | Trajectory | Labelled | Any, path: str | FilePath
) -> FilePath:
    """Write a result, its :class:`~biplan.solvers.results.Labelled` form or an
    ``xarray.Dataset`` to netCDF [h5netcdf engine]; a result or its labelled form is written
    without importing xarray (:func:`biplan.io.netcdf.write_labelled`)."""
    out = FilePath(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(result, EquilibriumPath | Trajectory):
        result = labelled(result)
    if isinstance(result, Labelled):
        return write_labelled(result, out)
    return write_netcdf(result, out)


def save_csv(result: EquilibriumPath | Trajectory, path: str | FilePath) -> FilePath:
    """Write the scalar observables, one row per step (path) or time (trajectory, column
    ``t`` [s] first). A first comment line gives the units."""
    lab = _checked(result).labelled()
    cols = list(CSV_COLUMNS)
    if isinstance(result, Trajectory):
        cols = ["t", *cols, *_TRAJECTORY_EXTRA]
    else:
        cols = ["step", *cols, "limit_point"]
        cols += [c for c in ("segment", "switched") if c in lab.variables]
    data = {c: lab.values("time" if c == "t" else c) for c in cols}
    units = {c: lab.units(c) for c in cols}
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


def _fmt(v: Any) -> str:
    if isinstance(v, np.integer | int):
        return str(int(v))
    return repr(float(v))


def save(result: EquilibriumPath | Trajectory, path: str | FilePath) -> FilePath:
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


def sweep_dataset(path: QuasiStaticPath, model: Model) -> Any:
    """A stable-branch displacement sweep as an ``xarray.Dataset`` over ``step``
    (:func:`sweep_labelled`)."""
    return sweep_labelled(path, model).to_dataset()


def sweep_labelled(path: QuasiStaticPath, model: Model) -> Labelled:
    """A stable-branch displacement sweep in plain arrays over ``step`` (the content of
    :func:`sweep_dataset`).

    Holds the scalar columns of :data:`SWEEP_COLUMNS`, ``status`` (Status value), the
    coordinates ``q`` and, as a path's dataset does, every fold's energy and phase fractions
    (``fold_energy`` (step, fold), ``helical_energy``, ``circular_energy``, ``phase_fraction``
    (step, fold, phase)) — so the energy, eigenvalue, phase and animation plots read it too.
    Failed steps are NaN. ``attrs["config"]`` is the tube's TOML text.
    """
    from biplan.solvers import observation
    from biplan.solvers.results import PHASES, fold_names

    nq, n, names = model.n_coordinates, path.n_steps, fold_names(model)
    ok = np.array([s.converged for s in path.solutions], dtype=bool)
    q = np.full((n, nq), np.nan)
    fold_energy = np.full((n, len(names)), np.nan)
    phase = np.full((n, len(names), len(PHASES)), np.nan)
    if ok.any():
        z = np.stack([np.asarray(s.z, dtype=float) for s in path.solutions if s.converged])
        q[ok] = z[:, :nq]
        zero = np.zeros(len(z))
        # fold energies and branch fractions depend on q only (the load enters the force)
        obs = observation.observe(model, z, Load(zero, zero, zero))
        fold_energy[ok] = np.asarray(obs.fold_energy, dtype=float)
        phase[ok] = np.asarray(obs.phase_fraction, dtype=float)
    data: dict[str, Any] = {}
    for name, (unit, desc) in SWEEP_COLUMNS.items():
        v = np.asarray(getattr(path, name))
        v = v.astype(np.int8) if v.dtype == bool else v.astype(float)
        data[name] = ("step", v, {"units": unit, "long_name": desc})
    data["status"] = ("step", np.asarray([s.value for s in path.status]), {"units": "1"})
    data["q"] = (("step", "coordinate"), q, {"units": "mm|rad"})
    n_h = model.layout.n_modules
    data["fold_energy"] = (("step", "fold"), fold_energy, {"units": "N*mm"})
    data["helical_energy"] = ("step", fold_energy[:, :n_h].sum(axis=1), {"units": "N*mm"})
    data["circular_energy"] = ("step", fold_energy[:, n_h:].sum(axis=1), {"units": "N*mm"})
    data["phase_fraction"] = (("step", "fold", "phase"), phase, {"units": "1"})
    attrs = {
        "kind": SWEEP_KIND,
        "control": "displacement",
        "initial_length": float(model.tube.initial_length),
        "config": dump_config(model.tube),
    }
    coords = {"step": np.arange(n), "fold": names, "phase": list(PHASES)}
    return Labelled(data, coords, attrs)


def save_sweep_csv(path: QuasiStaticPath, file: str | FilePath) -> FilePath:
    """Write a stable-branch sweep, one row per step with the columns :data:`SWEEP_CSV_COLUMNS`
    (units as in :data:`SWEEP_COLUMNS`; ``status`` is the Status name). The format of
    ``demo.csv`` and ``semi_sweep.csv``."""
    out = FilePath(file)
    out.parent.mkdir(parents=True, exist_ok=True)
    numbers = [c for c in SWEEP_CSV_COLUMNS if c not in ("stable", "status", "switched")]
    with out.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(SWEEP_CSV_COLUMNS)
        for k in range(path.n_steps):
            w.writerow(
                [f"{float(getattr(path, c)[k]):.12g}" for c in numbers]
                + [int(bool(path.stable[k])), path.status[k].name, int(bool(path.switched[k]))]
            )
    return out


class ResultKind(enum.StrEnum):
    """What a result file holds (:func:`result_kind`)."""

    path = "path"
    trajectory = "trajectory"
    sweep = SWEEP_KIND
    states = "states"
    design_map = "design map"
    stability_map = "stability map"
    unknown = "unknown"


#: ``quantity`` attribute of a map → its kind (``biplan map design|stability``).
_MAP_KINDS = {
    "force_ramp_response": ResultKind.design_map,
    "stability_count": ResultKind.stability_map,
}


def result_kind(ds: Any) -> ResultKind:
    """The kind of a result dataset, from its ``kind`` attribute (paths, trajectories, sweeps,
    state catalogues) or, for a map, its ``quantity`` attribute; ``unknown`` otherwise."""
    found = ds.attrs.get("kind")
    if found is not None:
        try:
            return ResultKind(str(found))
        except ValueError:
            return ResultKind.unknown
    return _MAP_KINDS.get(str(ds.attrs.get("quantity")), ResultKind.unknown)


def describe_result(ds: Any) -> str:
    """What a result dataset is, in words (``"a state catalogue"``, ``"a path result"``,
    ``"a map (stability_count)"``…)."""
    kind = result_kind(ds)
    if kind is ResultKind.states:
        return "a state catalogue"
    found = ds.attrs.get("kind")
    if found:
        return f"a {found} result"
    if "quantity" in ds.attrs:
        return f"a map ({ds.attrs['quantity']})"
    return "a file without a result kind"
