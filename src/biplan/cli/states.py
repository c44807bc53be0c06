"""``biplan states CONFIG --out DIR`` and ``biplan path CONFIG START TARGET``.

``states`` enumerates every stable state from the 2ⁿ binary fold-state seeds and writes into
DIR:

* ``states.csv`` — one row per distinct stable equilibrium (``name,label,bits,energy,u_z,u_r,
  theta,Theta,min_eigenvalue,n_open_helical,n_open_circular,seeds``; mm, rad, N·mm,
  N·mm per unit q²);
* ``seeds.csv`` — one row per seed: the bits it reached, stable/unstable/failed, the state;
* ``states.nc`` — the catalogue as a labelled dataset (coordinates q of every state);
* ``hierarchy.nc`` — slope branches, sub-branches, distributions (Fig. 4 C);
* ``transitions.graphml`` — the Hamming-1 graph (with barriers when ``--barriers``);
* ``transitions.png`` (pathways highlighted), ``endpoint_space.png``, ``distributions.png``.

``path`` prints the pathway between two states (fewest fold switches, or least barrier with
``--weight barrier``) and each step's barrier and fold, named as in the result files
(``helical 2``, ``circular 1|2``: modules count from 1 at the base). START and TARGET are
state names: the hexadecimal label (any case, exactly the digits of the tube's bistable folds,
e.g. ``2a`` for seven folds), with the ``.2``, ``.3``… suffix of a repeated label; they are
checked against the tube before anything is enumerated. ``--states FILE`` reads the states
from a catalogue written by ``states`` instead of enumerating them again; the file is checked
first (a catalogue of the same tube, holding START and TARGET). ``states`` checks ``--out``
before it starts.
"""

from __future__ import annotations

import csv
import itertools
import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console

from biplan._errors import ConfigError, check_integer
from biplan.cli._checks import options_named, output_directory

if TYPE_CHECKING:
    from biplan.analysis.states.catalogue import StateCatalogue
    from biplan.model.tube import Tube

__all__ = ["path", "state_name", "states", "write_states"]

#: The paper's pathways (SI transition section): p1 2A → 66, p2 2A → 1B, p3 → 00.
PAPER_PATHWAYS = (("2A", "66"), ("2A", "1B"), ("66", "00"))
#: The files ``states`` writes into --out.
STATE_FILES = (
    "states.csv",
    "seeds.csv",
    "states.nc",
    "hierarchy.nc",
    "transitions.graphml",
    "transitions.png",
    "endpoint_space.png",
    "distributions.png",
)
_STATE_NAME = re.compile(r"^([0-9A-Fa-f]+)(?:\.([0-9]+))?$")


def state_name(argument: str, text: str, tube: Tube) -> str:
    """The state name ``text`` (the argument ``argument``, e.g. START) checked against the
    tube's bistable folds: hexadecimal digits in any case, as many as the folds need, below
    2^n_folds, optionally followed by ``.k`` (k ≥ 2, a repeated label); returned upper case.

    Raises
    ------
    ConfigError
        Naming ``argument``, ``text`` and the valid form.
    """
    from biplan.analysis.states.labels import bistable_folds, label_to_bits

    n_bits = len(bistable_folds(tube))
    digits = (n_bits + 3) // 4
    if n_bits == 0:
        raise ConfigError(argument, text, "a state of a tube with bistable folds (it has none)")
    valid = (
        f"{digits} hexadecimal digit{'s' if digits > 1 else ''} from {0:0{digits}X} to "
        f"{2**n_bits - 1:0{digits}X} ({n_bits} bistable folds, any case), optionally followed "
        "by .2, .3, … (a repeated label)"
    )
    match = _STATE_NAME.match(text.strip())
    if match is None or (match[2] is not None and int(match[2]) < 2):
        raise ConfigError(argument, text, valid)
    try:
        label_to_bits(match[1].upper(), n_bits)
    except ConfigError:
        raise ConfigError(argument, text, valid) from None
    return match[1].upper() + ("" if match[2] is None else f".{match[2]}")


def _progress_enumeration(model: Any, quiet: bool, **search: Any) -> StateCatalogue:
    """:func:`~biplan.analysis.states.search.enumerate_states` with a progress bar and an ETA
    (``search``: its keyword arguments)."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

    from biplan.analysis.states.search import enumerate_states

    with Progress(
        "[bold]relaxing seeds",
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        disable=quiet or not sys.stderr.isatty(),
        console=Console(stderr=True),
    ) as bar:
        task = bar.add_task("seeds", total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        return enumerate_states(model, progress=update, **search)


def _pathways(graph: Any) -> tuple[list[list[str]], list[str]]:
    from biplan.analysis.states.transitions import pathway

    paths: list[list[str]] = []
    names: list[str] = []
    for k, (a, b) in enumerate(PAPER_PATHWAYS):
        if a in graph and b in graph:
            try:
                paths.append([str(n) for n in pathway(graph, a, b)])
                names.append(f"p{k + 1}: {a}→{b}")
            except Exception:
                continue
    return paths, names


def write_states(catalogue: StateCatalogue, graph: Any, out: Path) -> list[Path]:
    """Write the files of ``biplan states`` for a catalogue and its graph; returns the paths."""
    from biplan.analysis.states.catalogue import CSV_COLUMNS
    from biplan.analysis.states.hierarchy import hierarchy
    from biplan.analysis.states.transitions import write_graphml
    from biplan.io.config import dump_config
    from biplan.plot.files import pyplot, save
    from biplan.plot.states import distributions, endpoint_space, transition_diagram

    pyplot()  # the figures below go to files
    out.mkdir(parents=True, exist_ok=True)
    files = [out / n for n in ("states.csv", "seeds.csv", "states.nc", "hierarchy.nc")]
    with open(files[0], "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(CSV_COLUMNS))
        writer.writeheader()
        writer.writerows(catalogue.rows())
    with open(files[1], "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(
            [
                "seed",
                "seed_bits",
                "reached_bits",
                "outcome",
                "state",
                "min_eigenvalue",
                "residual",
                "message",
            ]
        )
        for s in catalogue.seeds:
            w.writerow(
                [
                    s.seed,
                    "".join(map(str, s.seed_bits)),
                    "".join(map(str, s.reached_bits)),
                    s.outcome.value,
                    s.state or "",
                    s.min_eigenvalue,
                    s.residual,
                    s.message,
                ]
            )
    ds = catalogue.to_dataset()
    ds.attrs["config"] = dump_config(catalogue.model.tube)
    ds.to_netcdf(files[2], engine="h5netcdf")
    hier = hierarchy(catalogue)
    hier.to_netcdf(files[3], engine="h5netcdf")
    files.append(write_graphml(graph, out / "transitions.graphml"))
    paths, names = _pathways(graph)
    figures = {
        "transitions.png": lambda: transition_diagram(graph, pathways=paths, names=names).figure,
        "endpoint_space.png": lambda: endpoint_space(ds).figure,
        "distributions.png": lambda: distributions(hier)[0].figure,
    }
    for name, draw in figures.items():
        save(draw(), out / name)
        files.append(out / name)
    return files


def states(
    config: Annotated[Path, typer.Argument(help="Tube configuration (TOML).", exists=True)],
    out: Annotated[Path, typer.Option("--out", help="Output directory.")] = Path("states"),
    barriers: Annotated[
        bool, typer.Option("--barriers", help="Also compute the energy barrier of every edge.")
    ] = False,
    search: Annotated[
        str,
        typer.Option(
            "--search",
            help="'exhaustive' (every 2^n seed) or 'neighbourhood' (single-fold changes from "
            "the all-closed seed).",
        ),
    ] = "exhaustive",
    yes: Annotated[
        bool, typer.Option("--yes", help="Run an exhaustive search of more than 4096 seeds.")
    ] = False,
    resume: Annotated[
        bool, typer.Option("--resume", help="Continue a killed exhaustive search in --out.")
    ] = False,
    workers: Annotated[
        int, typer.Option(help="Exhaustive search: Dask worker processes (1: in this process).")
    ] = 1,
    scheduler: Annotated[
        str | None,
        typer.Option(help="Exhaustive search: Dask scheduler address of an existing cluster."),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress or summary.")] = False,
) -> None:
    """Enumerate the stable states of a tube; write states.csv/.nc, transitions.graphml and
    the transition, endpoint-space and distribution figures. An exhaustive search streams
    its finished chunks of seeds to --out/seeds/ (``--resume`` continues a killed run) and runs
    them on a Dask cluster with ``--workers N`` (a local one) or ``--scheduler ADDRESS``."""
    import biplan
    from biplan.analysis.states.catalogue import Outcome
    from biplan.analysis.states.seeding import Search
    from biplan.analysis.states.transitions import transition_graph

    try:
        method = Search(search)
    except ValueError:
        valid = " or ".join(repr(m.value) for m in Search)
        raise ConfigError("--search", search, valid) from None
    check_integer("--workers", workers, low=1)
    if method is not Search.EXHAUSTIVE:
        for flag, used in (
            ("--resume", resume),
            ("--workers", workers > 1),
            ("--scheduler", scheduler),
        ):
            if used:
                raise ConfigError(flag, "with --search neighbourhood", "an exhaustive search")
    output_directory(out, files=STATE_FILES)
    model = biplan.Model(biplan.load_config(config))
    sink = _seed_store(model, out, method, yes, resume)
    runner = None
    if scheduler is not None or workers > 1:
        from biplan.analysis.scaleout import dask_runner

        runner = dask_runner(scheduler, workers)
    try:
        catalogue = _progress_enumeration(
            model, quiet, search=method, sink=sink, confirm=yes, runner=runner
        )
    except KeyboardInterrupt:
        if sink is not None:
            where = f"{len(sink.finished)} finished chunks kept in {out}/seeds; rerun with --resume"
        else:
            where = "nothing kept (the neighbourhood search is not streamed to disk)"
        Console(stderr=True, highlight=False).print(f"[yellow]interrupted:[/] {where}")
        raise typer.Exit(130) from None
    graph = transition_graph(catalogue)
    if barriers:
        _annotate(model, catalogue, graph, quiet)
    write_states(catalogue, graph, out)
    n_seeds = len(catalogue.seeds)
    mismatched = len(catalogue.mismatched_seeds)
    failed = sum(s.outcome is Outcome.FAILED for s in catalogue.seeds)
    Console(quiet=quiet, highlight=False).print(
        f"[green]{len(catalogue)} stable states[/] from {n_seeds} seeds "
        f"({mismatched} reached other bits, {len(catalogue.unstable_eigenvalues)} unstable "
        f"equilibria, {failed} failed) in {catalogue.elapsed:.1f} s; "
        f"{graph.number_of_edges()} single-fold transitions\n"
        f"states: {' '.join(catalogue.names)}\nwrote {out}/"
    )


def _seed_store(model: Any, out: Path, method: Any, yes: bool, resume: bool) -> Any:
    """The chunk store of an exhaustive search in ``out/seeds`` (None for the neighbourhood
    search), after the request's size is checked."""
    from biplan.analysis.states import seeding
    from biplan.analysis.states.catalogue import Enumeration
    from biplan.analysis.states.labels import bistable_folds
    from biplan.analysis.states.search import MAX_FOLDS
    from biplan.io.config import dump_config
    from biplan.io.sweepstore import ChunkStore

    n_folds = len(bistable_folds(model.tube))
    if n_folds == 0:
        raise ConfigError("config", model.tube.name, "a tube with at least one bistable fold law")
    with options_named({"search": "--search", "model": "CONFIG"}):
        seeding.check_size(n_folds, model.tube.n_modules, method, yes, MAX_FOLDS)
    if method is not seeding.Search.EXHAUSTIVE:
        return None
    settings = Enumeration()
    description = {
        "config": dump_config(model.tube),
        "settings": repr(settings),
        "search": method.value,
    }
    n_chunks = -(-(2**n_folds) // settings.chunk)
    with options_named({"out": "--out"}):
        return ChunkStore(out / "seeds", description, n_chunks, resume)


def _annotate(
    model: Any, catalogue: Any, graph: Any, quiet: bool, edges: Any = None, departure: bool = False
) -> None:
    from biplan.analysis.states.transitions import annotate_barriers

    n = graph.number_of_edges() if edges is None else len(edges)
    with Console(stderr=True, quiet=quiet).status(f"computing {n} edge barriers (NEB)…"):
        annotate_barriers(graph, model, catalogue, edges=edges, departure=departure)


def _catalogue_file(file: Path, tube: Tube, names: dict[str, str]) -> Any:
    """The checked dataset of ``--states FILE`` holding the states ``names`` (argument →
    state name)."""
    from biplan.io.catalogue import read_catalogue

    with options_named({"catalogue": "--states"}):
        dataset = read_catalogue(file, tube)
    held = [str(n) for n in dataset["state"].values]
    for argument, name in names.items():
        if name not in held:
            raise ConfigError(argument, name, f"a stable state of {file}: {', '.join(held)}")
    return dataset


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
    from biplan.analysis.states.transitions import pathway, transition_graph
    from biplan.io.catalogue import load_catalogue

    if weight not in ("switches", "barrier"):
        raise ConfigError("--weight", weight, "'switches' or 'barrier'")
    tube = biplan.load_config(config)
    start, target = state_name("START", start, tube), state_name("TARGET", target, tube)
    dataset = None
    if states_file is not None:
        dataset = _catalogue_file(states_file, tube, {"START": start, "TARGET": target})
    model = biplan.Model(tube)
    if dataset is None:
        catalogue = _progress_enumeration(model, quiet)
    else:
        catalogue = load_catalogue(dataset, model)
    graph = transition_graph(catalogue)
    if weight == "barrier":
        _annotate(model, catalogue, graph, quiet)
    with options_named({"start": "START", "target": "TARGET"}):
        found = pathway(
            graph,
            start,
            target,
            all_paths=all_paths,
            weight=None if weight == "switches" else "barrier",
        )
    paths: list[list[str]] = found if all_paths else [found]  # type: ignore[assignment,list-item]
    on_paths = {tuple(e) for p in paths for e in itertools.pairwise(p)}
    missing = [e for e in on_paths if "saddle_energy" not in graph.edges[e]]
    if missing:
        _annotate(model, catalogue, graph, quiet, edges=missing, departure=True)
    console = Console(highlight=False)
    for p in paths:
        console.print(" → ".join(p))
        for u, v in itertools.pairwise(p):
            d = graph.edges[u, v]
            up = d.get("saddle_energy", float("nan")) - graph.nodes[u]["energy"]
            force = d.get("departure_force", float("nan"))
            force_text = f", departure force {force:.4g} N" if d.get("forward_from") == u else ""
            console.print(
                f"  {u} → {v}: fold {d['fold_name']}, barrier {up:.4g} N·mm "
                f"({d.get('mep_status', '?')}){force_text}"
            )
