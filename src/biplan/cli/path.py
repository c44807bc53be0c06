"""``biplan path CONFIG START TARGET``: the transition pathway between two stable states.

Prints the pathway (fewest fold switches, or least barrier with ``--weight barrier``; every
shortest one with ``--all``) and each step's barrier and fold, named as in the result files
(``helical 2``, ``circular 1|2``: modules count from 1 at the base), with the departure force
of each step whose barrier it computed from its start (or why there is none: no loss of
stability up to the end of the force ramp). START and TARGET are state names:
the hexadecimal label (any case, exactly the digits of the tube's bistable folds, e.g. ``2a``
for seven folds), with the ``.2``, ``.3``… suffix of a repeated label; they are checked against
the tube before anything is enumerated (:func:`~biplan.analysis.states.labels.state_name`).
``--states FILE`` reads the states from a catalogue written by ``biplan states`` instead of
enumerating them again; the file is checked first (a catalogue of the same tube, holding START
and TARGET: :func:`~biplan.io.catalogue.read_catalogue`).
"""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from biplan._errors import ConfigError
from biplan.cli._checks import options_named

__all__ = ["Weight", "path"]


class Weight(enum.StrEnum):
    """What a pathway minimises."""

    switches = "switches"  #: fold switches
    barrier = "barrier"  #: total barrier climbed in the direction of travel


def path(
    config: Annotated[Path, typer.Argument(help="Tube configuration (TOML).", exists=True)],
    start: Annotated[str, typer.Argument(help="Start state label, e.g. 2A.")],
    target: Annotated[str, typer.Argument(help="Target state label, e.g. 66.")],
    weight: Annotated[
        str, typer.Option(help="'switches' (fewest fold switches) or 'barrier'.")
    ] = "switches",
    all_paths: Annotated[bool, typer.Option("--all", help="Every shortest pathway.")] = False,
    states_file: Annotated[
        Path | None,
        typer.Option(
            "--states",
            help="State catalogue of this tube (states.nc of `biplan states`): read instead "
            "of enumerating the states again.",
            show_default=False,
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress.")] = False,
) -> None:
    """Print the transition pathway between two stable states and its barriers."""
    import biplan
    from biplan.analysis.states.labels import state_name
    from biplan.analysis.states.transitions import (
        annotate_departures,
        pathway,
        pathway_steps,
        transition_graph,
        unannotated_edges,
        without_departure,
    )
    from biplan.cli.states import annotate_with_status, enumerate_with_progress
    from biplan.io.catalogue import load_catalogue, read_catalogue

    try:
        by = Weight(weight)
    except ValueError:
        raise ConfigError("--weight", weight, "'switches' or 'barrier'") from None
    tube = biplan.load_config(config)
    start, target = state_name("START", start, tube), state_name("TARGET", target, tube)
    dataset = None
    if states_file is not None:
        with options_named({"catalogue": "--states"}):
            dataset = read_catalogue(states_file, tube, {"START": start, "TARGET": target})
    model = biplan.Model(tube)
    if dataset is None:
        catalogue = enumerate_with_progress(model, quiet)
    else:
        catalogue = load_catalogue(dataset, model)
    graph = transition_graph(catalogue)
    if by is Weight.barrier:
        annotate_with_status(model, catalogue, graph, quiet)
    with options_named({"start": "START", "target": "TARGET"}):
        found = pathway(graph, start, target, all_paths=all_paths,
                        weight=None if by is Weight.switches else "barrier")  # fmt: skip
    paths: list[list[str]] = found if all_paths else [found]  # type: ignore[assignment,list-item]
    missing = unannotated_edges(graph, paths)
    if missing:
        annotate_with_status(model, catalogue, graph, quiet, edges=missing, departure=True)
    steps = without_departure(graph, paths)  # barriers of the whole graph, departures not yet
    if steps:
        with Console(stderr=True, quiet=quiet).status(f"computing {len(steps)} departures…"):
            annotate_departures(graph, model, catalogue, steps)
    console = Console(highlight=False)
    for p in paths:
        console.print(" → ".join(p))
        for step in pathway_steps(graph, p):
            departure = step.departure_text()
            force_text = f", {departure}" if departure else ""
            console.print(
                f"  {step.start} → {step.end}: fold {step.fold_name}, barrier "
                f"{step.barrier:.4g} N·mm ({step.mep_status}){force_text}"
            )
