"""``biplan states CONFIG --out DIR``: every stable state of a tube.

Enumerates the stable states from the 2ⁿ binary fold-state seeds (``--search exhaustive``) or
from single-fold changes of the all-closed seed (``--search neighbourhood``) and writes into
DIR (``--out`` is checked before anything is computed):

* ``states.csv`` — one row per distinct stable equilibrium (``name,label,bits,energy,u_z,u_r,
  theta,Theta,min_eigenvalue,n_open_helical,n_open_circular,seeds``; mm, rad, N·mm,
  N·mm per unit q²);
* ``seeds.csv`` — one row per seed: the bits it reached, stable/unstable/failed, the state;
* ``states.nc`` — the catalogue as a labelled dataset (coordinates q of every state);
* ``hierarchy.nc`` — slope branches, sub-branches, distributions (Fig. 4 C);
* ``transitions.graphml`` — the Hamming-1 graph (with barriers when ``--barriers``);
* ``transitions.png`` (pathways highlighted), ``endpoint_space.png``, ``distributions.png``.

Files: :mod:`biplan.io.states` and :func:`biplan.plot.states.write_state_figures`. An
exhaustive search streams its finished chunks of seeds to ``DIR/seeds/`` (``--resume``
continues a killed run; Ctrl-C says how many chunks were kept) and runs them on a Dask cluster
with ``--workers N`` (a local one) or ``--scheduler ADDRESS``. :func:`enumerate_with_progress`
and :func:`annotate_with_status` are shared with ``biplan path``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console

from biplan._errors import ConfigError, check_integer
from biplan.cli._checks import options_named, output_directory

if TYPE_CHECKING:
    import networkx as nx

    from biplan.analysis.states.catalogue import StateCatalogue
    from biplan.model.assembly import Model

__all__ = ["annotate_with_status", "enumerate_with_progress", "states"]


def enumerate_with_progress(model: Model, quiet: bool, **search: Any) -> StateCatalogue:
    """:func:`~biplan.analysis.states.search.enumerate_states` with a progress bar and an ETA
    on stderr (hidden when ``quiet`` or not a terminal); ``search``: its keyword arguments."""
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


def annotate_with_status(model: Model, catalogue: StateCatalogue, graph: nx.Graph, quiet: bool,
                         edges: Any = None, departure: bool = False) -> None:  # fmt: skip
    """:func:`~biplan.analysis.states.transitions.annotate_barriers` (every edge, or
    ``edges``) under a status line on stderr (unless ``quiet``)."""
    from biplan.analysis.states.transitions import annotate_barriers

    n = graph.number_of_edges() if edges is None else len(edges)
    with Console(stderr=True, quiet=quiet).status(f"computing {n} edge barriers (NEB)…"):
        annotate_barriers(graph, model, catalogue, edges=edges, departure=departure)


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
        bool, typer.Option("--yes", help="Run an exhaustive search of more than 65,536 seeds.")
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
    threads: Annotated[
        int,
        typer.Option(
            help="In this process: chunks of seeds at once, one thread each (0: one per core)."
        ),
    ] = 0,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress or summary.")] = False,
) -> None:
    """Enumerate the stable states of a tube; write states.csv/.nc, transitions.graphml and
    the transition, endpoint-space and distribution figures. An exhaustive search streams
    its finished chunks of seeds to --out/seeds/ (``--resume`` continues a killed run) and runs
    them on a Dask cluster with ``--workers N`` (a local one) or ``--scheduler ADDRESS``."""
    import biplan
    from biplan.analysis.states.catalogue import Enumeration, Outcome
    from biplan.analysis.states.labels import require_bistable_folds
    from biplan.analysis.states.seeding import Search
    from biplan.analysis.states.transitions import transition_graph
    from biplan.io.states import STATE_DATA_FILES, seed_store, write_state_files
    from biplan.plot.states import STATE_FIGURES, write_state_figures

    try:
        method = Search(search)
    except ValueError:
        valid = " or ".join(repr(m.value) for m in Search)
        raise ConfigError("--search", search, valid) from None
    check_integer("--workers", workers, low=1)
    check_integer("--threads", threads, low=0)
    if threads and (workers > 1 or scheduler is not None):
        raise ConfigError(
            "--threads", threads, "0 with --workers or --scheduler (Dask runs the chunks)"
        )
    if method is not Search.EXHAUSTIVE:
        for flag, used in (("--resume", resume), ("--workers", workers > 1),
                           ("--scheduler", scheduler)):  # fmt: skip
            if used:
                raise ConfigError(flag, "with --search neighbourhood", "an exhaustive search")
    output_directory(out, files=STATE_DATA_FILES + STATE_FIGURES)
    tube = biplan.load_config(config)
    require_bistable_folds(tube, "CONFIG", str(config))
    model = biplan.Model(tube)
    with options_named({"search": "--search", "model": "CONFIG", "out": "--out"}):
        sink = seed_store(model, out, method, confirm=yes, resume=resume)
    if sink is not None and resume:
        _report_resume(sink, out, quiet)
    runner = None
    if scheduler is not None or workers > 1:
        from biplan.analysis.scaleout import dask_runner

        runner = dask_runner(scheduler, workers)
    try:
        catalogue = enumerate_with_progress(
            model,
            quiet,
            settings=Enumeration(threads=threads),
            search=method,
            sink=sink,
            confirm=yes,
            runner=runner,
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
        annotate_with_status(model, catalogue, graph, quiet)
    write_state_files(catalogue, graph, out)
    write_state_figures(catalogue, graph, out)
    failed = sum(s.outcome is Outcome.FAILED for s in catalogue.seeds)
    Console(quiet=quiet, highlight=False).print(
        f"[green]{len(catalogue)} stable states[/] from {len(catalogue.seeds)} seeds "
        f"({len(catalogue.mismatched_seeds)} reached other bits, "
        f"{len(catalogue.unstable_eigenvalues)} unstable equilibria, {failed} failed) in "
        f"{catalogue.elapsed:.1f} s; {graph.number_of_edges()} single-fold transitions\n"
        f"states: {_listed(catalogue.names)}\nwrote {out}/"
    )


#: Most state names the summary lists (the rest are in states.csv).
LISTED_NAMES = 100
#: Most damaged chunks a resumed search names (the others are counted).
LISTED_DAMAGED = 5


def _report_resume(sink: Any, out: Path, quiet: bool) -> None:
    """How much of a killed search is reused: the chunks it computes again and why, on
    stderr (also when ``quiet``), and the chunks reused."""
    from rich.markup import escape

    err = Console(stderr=True, highlight=False)
    damaged = sorted(sink.damaged.items())
    for chunk, why in damaged[:LISTED_DAMAGED]:
        err.print(
            f"[yellow]warning:[/] chunk {chunk} of {escape(str(out))}/seeds: {escape(why)}; "
            "computing it again"
        )
    if len(damaged) > LISTED_DAMAGED:
        err.print(f"[yellow]warning:[/] {len(damaged) - LISTED_DAMAGED} more chunks computed again")
    Console(quiet=quiet, highlight=False).print(
        f"{sink.reused} of {sink.n_chunks} chunks of seeds reused from {escape(str(out))}/seeds"
    )


def _listed(names: tuple[str, ...]) -> str:
    if len(names) <= LISTED_NAMES:
        return " ".join(names)
    return f"{' '.join(names[:LISTED_NAMES])} … ({len(names) - LISTED_NAMES:,} more in states.csv)"
