"""The labelled form shared by the results of path following and time integration.

:class:`~biplan.solvers.path_results.EquilibriumPath` (one entry per equilibrium step) and
:class:`~biplan.solvers.trajectory_results.Trajectory` (one entry per saved time) share the
observables of :class:`~biplan.solvers.observation.Observation` (:data:`OBSERVABLES`, built by
:func:`observables`) and convert to an ``xarray.Dataset`` with
:meth:`LabelledResult.to_dataset` (dims ``step`` or ``time``; ``coordinate``, ``fold``,
``phase``; units in each variable's ``units`` attribute, :data:`UNITS`). The same content in
plain arrays, :class:`Labelled` (:meth:`LabelledResult.labelled`), is what the ``biplan``
command writes (:func:`biplan.io.netcdf.write_labelled`): a file written without importing
xarray, which reads back as the same dataset.
:func:`biplan.io.results.dataset` adds the tube's TOML configuration to the attributes, so that
a saved file can be re-opened as a model (:func:`biplan.io.results.model_of`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from biplan.model.assembly import Model
from biplan.solvers.control import Control
from biplan.solvers.observation import STABILITY_TOL, Observation

__all__ = [
    "ENERGY_BALANCE",
    "OBSERVABLES",
    "PHASES",
    "RESPONSE_VARIABLES",
    "UNITS",
    "Labelled",
    "LabelledResult",
    "display_units",
    "fold_names",
    "observables",
]

PHASES = ("closed", "spinodal", "open")

#: The load parameter, load-point and endpoint displacements and energies of each state: the
#: leading variables of every result and of its CSV form (:data:`biplan.io.results.CSV_COLUMNS`).
RESPONSE_VARIABLES = (
    "load_parameter",
    "force",
    "displacement",
    "u_z",
    "u_r",
    "theta",
    "energy",
    "helical_energy",
    "circular_energy",
)
#: The observables of every result (:func:`observables`), in the order of its variables.
OBSERVABLES = (
    *RESPONSE_VARIABLES,
    "fold_energy",
    "phase_fraction",
    "min_eigenvalue",
    "stable",
    "constraint_residual",
)
#: The energy balance of a trajectory [N·mm], after its observables.
ENERGY_BALANCE = ("kinetic_energy", "external_work", "dissipated_energy", "total_energy")

UNITS = {
    "force": "N",
    "displacement": "mm",
    "u_z": "mm",
    "u_r": "mm",
    "theta": "rad",
    "energy": "N mm",
    "helical_energy": "N mm",
    "circular_energy": "N mm",
    "fold_energy": "N mm",
    "phase_fraction": "1",
    "min_eigenvalue": "N mm",  # per unit q² (q mixes mm and rad): N·mm on rotations
    "stable": "1",
    "q": "mm or rad",
    "constraint_residual": "mm",
    "kinetic_energy": "N mm",
    "external_work": "N mm",
    "dissipated_energy": "N mm",
    "total_energy": "N mm",
    "velocity": "mm/s or rad/s",
    "time": "s",
    "arclength": "1",
}


def fold_names(model: Model) -> list[str]:
    """'helical 1'…'helical N' then the circular folds 'circular 0|1' (base fold) … (the names
    of :meth:`~biplan.geometry.TubeLayout.fold_name`)."""
    return list(model.layout.fold_names)


def observables(model: Model, obs: Observation, control_value: np.ndarray) -> dict[str, np.ndarray]:
    """The :data:`OBSERVABLES` of the states observed in ``obs`` (one row per state), with the
    load parameter Λ ``control_value`` [N, mm or MPa]: name → array (NumPy)."""
    min_eig = np.asarray(obs.min_eigenvalue, dtype=float)
    n_h = model.layout.n_modules
    fe = np.asarray(obs.fold_energy)
    return {
        "force": np.asarray(obs.force, float),
        "displacement": np.asarray(obs.displacement, float),
        "u_z": np.asarray(obs.u_z, float),
        "u_r": np.asarray(obs.u_r, float),
        "theta": np.asarray(obs.theta, float),
        "energy": np.asarray(obs.energy, float),
        "helical_energy": fe[:, :n_h].sum(axis=1),
        "circular_energy": fe[:, n_h:].sum(axis=1),
        "fold_energy": fe,
        "phase_fraction": np.asarray(obs.phase_fraction, float),
        "min_eigenvalue": min_eig,
        "stable": (min_eig > STABILITY_TOL),
        "constraint_residual": np.asarray(obs.constraint_residual, float),
        "load_parameter": np.asarray(control_value, float),
    }


def display_units(control: Control) -> tuple[float, str]:
    """Scale and unit of the load parameter in files and figures: pressure in kPa (the
    library's MPa × 1000), force and displacement as they are."""
    if control.kind.value == "pressure":
        return 1e3, "kPa"
    return 1.0, control.kind.unit


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("biplan")
    except PackageNotFoundError:  # pragma: no cover
        return "0.0.0+unknown"


@dataclass(frozen=True)
class Labelled:
    """A labelled result in plain arrays: the arguments of ``xarray.Dataset(variables,
    coords=coords, attrs=attrs)``.

    Attributes
    ----------
    variables : dict
        Data variables in order: name → (dims, array, attributes).
    coords : dict
        Coordinates in order: name → values (a dimension coordinate of the same name) or
        (dims, array, attributes).
    attrs : dict
        Global attributes (numbers and strings).
    """

    variables: dict[str, tuple[tuple[str, ...], np.ndarray, dict[str, Any]]]
    coords: dict[str, Any]
    attrs: dict[str, Any]

    def to_dataset(self) -> Any:
        """The ``xarray.Dataset`` of these arrays."""
        import xarray as xr

        return xr.Dataset(self.variables, coords=self.coords, attrs=self.attrs)

    def with_attrs(self, **attrs: Any) -> Labelled:
        """A copy with ``attrs`` added to the global attributes."""
        return replace(self, attrs={**self.attrs, **attrs})

    def values(self, name: str) -> np.ndarray:
        """The array of variable or coordinate ``name``."""
        if name in self.variables:
            return np.asarray(self.variables[name][1])
        coord = self.coords[name]
        return np.asarray(coord[1] if isinstance(coord, tuple) else coord)

    def units(self, name: str) -> str:
        """The ``units`` attribute of variable or coordinate ``name`` ("" when it has none)."""
        entry = self.variables.get(name, self.coords.get(name))
        return str(entry[2].get("units", "")) if isinstance(entry, tuple) else ""


class LabelledResult:
    """The conversion to an ``xarray.Dataset`` shared by
    :class:`~biplan.solvers.path_results.EquilibriumPath` and
    :class:`~biplan.solvers.trajectory_results.Trajectory` (see the module docstring)."""

    model: Model
    control: Control
    q: np.ndarray
    _dim: str = "step"

    def _variables(self) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def _attrs(self) -> dict[str, Any]:
        raise NotImplementedError

    def to_dataset(self) -> Any:
        """The result as an ``xarray.Dataset`` (see module docstring)."""
        return self.labelled().to_dataset()

    def labelled(self) -> Labelled:
        """The result's variables, coordinates and attributes in plain arrays."""
        dim = self._dim
        scale, shown_unit = display_units(self.control)
        data: dict[str, Any] = {}
        for name, v in self._variables().items():
            v = np.asarray(v)
            if name in ("fold_energy",):
                dims: tuple[str, ...] = (dim, "fold")
            elif name == "phase_fraction":
                dims = (dim, "fold", "phase")
            elif name in ("q", "velocity"):
                dims = (dim, "coordinate")
            else:
                dims = (dim,)
            if v.dtype == bool:
                v = v.astype(np.int8)
            unit = UNITS.get(name, "1")
            if name == "load_parameter":
                v, unit = v * scale, shown_unit
            data[name] = (dims, v, {"units": unit})
        n = len(next(iter(self._variables().values())))
        coords: dict[str, Any] = {
            "fold": fold_names(self.model),
            "phase": list(PHASES),
            "coordinate": np.arange(self.q.shape[1]),
        }
        if dim == "step":
            coords["step"] = np.arange(n)
        attrs: dict[str, Any] = {
            "kind": "path" if dim == "step" else "trajectory",
            "control": self.control.kind.value,
            "control_unit": shown_unit,
            "control_stop": self.control.stop * scale,
            "initial_length": self.model.tube.initial_length,
            "biplan_version": _version(),
            **self._attrs(),
        }
        return Labelled(data, coords, attrs)
