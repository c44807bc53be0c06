"""Read a state catalogue (``states.nc`` of ``biplan states``) back, checked against a tube.

:func:`read_catalogue` opens the file and refuses, before anything is built or solved, a
file that is missing, unreadable, not a state catalogue, or the catalogue of another tube: a
different layout (number of modules, base fold, bistable folds, coordinates) or other laws or
geometry (its states would not be equilibria of this tube). Every refusal is a
:class:`~biplan.ConfigError` whose parameter is ``"catalogue"`` (the CLI names its option).
:func:`load_catalogue` turns the checked dataset into a
:class:`~biplan.analysis.states.catalogue.StateCatalogue` for the tube's model.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from biplan._errors import ConfigError
from biplan.analysis.states.labels import bistable_folds

if TYPE_CHECKING:
    from biplan.analysis.states.catalogue import StateCatalogue
    from biplan.model.assembly import Model
    from biplan.model.tube import Tube

__all__ = ["CATALOGUE_VARIABLES", "load_catalogue", "read_catalogue", "same_tube"]

#: Variables a catalogue file must hold to give the catalogue back (``to_dataset``).
CATALOGUE_VARIABLES = (
    "label",
    "bits",
    "energy",
    "u_z",
    "u_r",
    "theta",
    "min_eigenvalue",
    "seeds",
    "q",
    "z",
    "phase_fraction",
    "seed_outcome",
    "seed_state",
    "seed_reached",
    "seed_min_eigenvalue",
)
_WHAT = "a state catalogue (states.nc of `biplan states`)"


def _numbers_close(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return len(a) == len(b) and all(
        math.isclose(x, y, rel_tol=1e-12, abs_tol=1e-15) for x, y in zip(a, b, strict=True)
    )


def same_tube(a: Tube, b: Tube) -> bool:
    """Whether two tubes are the same structure with the same geometry and laws (numbers
    equal to 1e-12 relative, so that a TOML round trip compares equal); the name is ignored."""
    dev_a, dev_b = a.development, b.development
    geometry = (dev_a.radius, dev_a.pitch, dev_a.helical_angle, a.surface_density)
    if a.layout != b.layout or not _numbers_close(
        geometry, (dev_b.radius, dev_b.pitch, dev_b.helical_angle, b.surface_density)
    ):
        return False
    laws_a = (*a.helical_laws, *a.circular_laws)
    laws_b = (*b.helical_laws, *b.circular_laws)
    return all(
        type(x) is type(y) and _numbers_close(x.coefficients, y.coefficients)
        for x, y in zip(laws_a, laws_b, strict=True)
    )


def _describe(n_modules: int, n_bits: int) -> str:
    return f"{n_modules} modules and {n_bits} bistable folds"


def read_catalogue(path: str | Path, tube: Tube, states: Mapping[str, str] | None = None) -> Any:
    """The dataset of a catalogue file of ``tube`` (loaded into memory), checked.

    Parameters
    ----------
    path : str or Path
        A ``states.nc`` written by ``biplan states`` (:meth:`StateCatalogue.to_dataset` with
        the tube's configuration in ``attrs["config"]``).
    tube : Tube
        The tube the catalogue must belong to.
    states : mapping of str to str, optional
        State names the catalogue must hold, by the parameter an error names (``{"START":
        "2A"}``).

    Raises
    ------
    ConfigError
        Parameter ``"catalogue"``: the file is missing or unreadable, is not a state
        catalogue, lacks a variable, or belongs to another tube (the message says how the
        tubes differ); a parameter of ``states``: a state the catalogue does not hold (the
        message lists those it holds).
    """
    import xarray as xr

    from biplan.io.config import load_config_text

    p = Path(path)
    if not p.is_file():
        raise ConfigError("catalogue", str(path), f"{_WHAT}: an existing file")
    try:
        with xr.open_dataset(p, engine="h5netcdf") as ds:
            dataset = ds.load()
    except (OSError, ValueError) as err:
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise ConfigError("catalogue", str(path), f"{_WHAT} (cannot read it: {reason})") from None
    kind = dataset.attrs.get("kind")
    if kind != "states":
        found = f"a {kind} result" if kind else "a file without a result kind"
        raise ConfigError("catalogue", str(path), f"{_WHAT} (it is {found})")
    missing = [v for v in CATALOGUE_VARIABLES if v not in dataset.variables]
    missing += [a for a in ("folds", "config") if a not in dataset.attrs]
    if missing:
        raise ConfigError("catalogue", str(path), f"{_WHAT} (it lacks {', '.join(missing)})")
    try:
        theirs = load_config_text(str(dataset.attrs["config"]), source=f"{p} (attrs['config'])")
    except ConfigError as err:
        raise ConfigError("catalogue", str(path), f"{_WHAT} ({err})") from None
    n_bits = len(json.loads(dataset.attrs["folds"]))
    ours_bits = len(bistable_folds(tube))
    if theirs.layout != tube.layout or n_bits != ours_bits:
        raise ConfigError(
            "catalogue",
            str(path),
            f"the catalogue of this tube (it holds the states of a tube with "
            f"{_describe(theirs.n_modules, n_bits)}; the configuration has "
            f"{_describe(tube.n_modules, ours_bits)})"
            if (theirs.n_modules, n_bits) != (tube.n_modules, ours_bits)
            else "the catalogue of this tube (its base fold or options differ)",
        )
    if not same_tube(theirs, tube):
        raise ConfigError(
            "catalogue",
            str(path),
            "the catalogue of this tube (its geometry or fold laws differ from the "
            "configuration's: its states are not equilibria of this tube)",
        )
    held = [str(n) for n in dataset["state"].values]
    for parameter, name in (states or {}).items():
        if name not in held:
            raise ConfigError(parameter, name, f"a stable state of {path}: {', '.join(held)}")
    return dataset


def load_catalogue(dataset: Any, model: Model) -> StateCatalogue:
    """The :class:`StateCatalogue` of a dataset checked by :func:`read_catalogue`, for the
    model of its tube."""
    from biplan.analysis.states.catalogue import StateCatalogue

    return StateCatalogue.from_dataset(dataset, model)
