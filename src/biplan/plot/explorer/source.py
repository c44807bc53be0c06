"""The result an explorer page is made of: a result file read and checked
(:func:`read_explorable`), and the page of a checked dataset (:func:`explorer_page`).

``biplan explore`` and ``biplan reproduce`` both go through these two functions.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from biplan._errors import ConfigError

if TYPE_CHECKING:
    from biplan.plot.explorer.page import Page

__all__ = ["ACCEPTS", "GRAPH_FILE", "explorer_page", "read_explorable"]

#: What ``explore`` accepts, in the words of its refusals.
ACCEPTS = (
    "a state catalogue (states.nc of `biplan states`), a design map (map.nc of "
    "`biplan map design`) or a response (response.nc of `biplan respond`)"
)
#: The barrier graph ``biplan states`` writes beside its catalogue.
GRAPH_FILE = "transitions.graphml"


def _refuse(file: Path, why: str) -> ConfigError:
    return ConfigError("RESULT", str(file), f"{ACCEPTS} ({why})")


def read_explorable(file: Path) -> Any:
    """The dataset of ``file``, checked to be a result ``explore`` draws.

    Raises
    ------
    ConfigError
        Naming RESULT and the file: missing or unreadable, another kind of result, a
        catalogue without states, or no tube configuration in its attributes.
    """
    import xarray as xr

    from biplan.io.config import load_config_text
    from biplan.io.results import ResultKind, describe_result, result_kind

    if not file.is_file():
        raise _refuse(file, "no such file")
    try:
        with xr.open_dataset(file, engine="h5netcdf") as ds:
            dataset = ds.load()
    except Exception as err:  # any failure to parse is an unreadable file
        reason = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise _refuse(file, f"cannot read it: {reason}") from None
    kind = result_kind(dataset)
    usable = {
        ResultKind.states: ("q", "bits", "energy", "n_open_helical", "theta"),
        ResultKind.design_map: ("u_z", "u_r", "b", "C", "stability_lost", "time_lost"),
        ResultKind.path: ("force", "displacement", "q"),
        ResultKind.trajectory: ("force", "displacement", "q"),
        ResultKind.sweep: ("force", "displacement", "q"),
    }
    if kind not in usable:
        raise _refuse(file, f"it is {describe_result(dataset)}")
    missing = [v for v in usable[kind] if v not in dataset.variables]
    if missing:
        raise _refuse(file, f"it is {describe_result(dataset)} without {', '.join(missing)}")
    if kind is ResultKind.states and dataset.sizes.get("state", 0) == 0:
        raise _refuse(file, "it is a state catalogue without states")
    text = dataset.attrs.get("config")
    if not text:
        raise _refuse(file, f"it is {describe_result(dataset)} without its tube configuration")
    try:
        load_config_text(str(text), source=f"{file} (attrs['config'])")
    except ConfigError as err:
        raise _refuse(file, f"its tube configuration is invalid: {err}") from None
    return dataset


def _graph(dataset: Any, model: Any, folder: Path) -> Any:
    """The transition graph of a catalogue, with the barriers of ``GRAPH_FILE`` beside it."""
    import networkx as nx

    from biplan.analysis.states.catalogue import StateCatalogue
    from biplan.analysis.states.transitions import transition_graph

    graph = transition_graph(StateCatalogue.from_dataset(dataset, model))
    stored = folder / GRAPH_FILE
    if stored.is_file():
        try:
            saved = nx.read_graphml(stored)
        except Exception as err:  # any failure to parse is an unreadable file
            reason = str(err).splitlines()[0] if str(err) else type(err).__name__
            raise ConfigError(
                GRAPH_FILE,
                str(stored),
                f"the transition graph `biplan states` writes beside its catalogue (cannot read"
                f" it: {reason}; move it away to explore the catalogue without barriers)",
            ) from None
        for u, v, d in saved.edges(data=True):
            if graph.has_edge(u, v) and "saddle_energy" in d:
                graph.edges[u, v]["saddle_energy"] = float(d["saddle_energy"])
    return graph


def explorer_page(dataset: Any, file: Path) -> Page:
    """The explorer page of a dataset checked by :func:`read_explorable` (read from ``file``)."""
    from biplan.io.results import ResultKind, model_of, result_kind
    from biplan.plot import explorer

    kind = result_kind(dataset)
    if kind is ResultKind.states:
        model = model_of(dataset)
        graph = _graph(dataset, model, file.parent)
        return explorer.catalogue_page(dataset, model, graph, source=file.name)
    if kind is ResultKind.design_map:
        from biplan.analysis.maps.ramp_curves import map_designs, map_ramp, ramp_curves
        from biplan.io.config import load_config_text

        design = load_config_text(str(dataset.attrs["config"]), source=str(file))
        designs = map_designs(design, dataset)
        valid = [i for i, t in enumerate(designs) if t is not None]
        # kernel calls of the map's own chunk size: the kernel its run compiled (and stored)
        batch = int(dataset.attrs.get("chunk_size", 16))
        found = ramp_curves([designs[i] for i in valid], map_ramp(dataset), batch)  # type: ignore[misc]
        curves: list[Any] = [None] * len(designs)
        for i, c in zip(valid, found, strict=True):
            curves[i] = c
        return explorer.map_page(dataset, designs, curves, source=file.name)
    return explorer.response_page(dataset, model_of(dataset), source=file.name)
