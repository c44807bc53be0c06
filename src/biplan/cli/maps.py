"""``biplan map {design,instability,stability,plot}``: the paper's maps at scale.

* ``biplan map design CONFIG --b START:STOP:N --C START:STOP:N --out DIR`` — the
  force-controlled design map (terminal u_z/l₀, u_r/l₀ and loss of stability under the ramp
  F = Ḟ t) over (b, C);
* ``biplan map instability CONFIG --b START:STOP:N --C START:STOP:N --out DIR`` — the end
  force F* and displacement U* of the first loss of stability under force control (up to
  ``--up-to`` N) over (b, C);
* ``biplan map stability CONFIG --displacement START:STOP:N --C START:STOP:N --out DIR`` — the
  number of stable equilibria over (C, U/l₀) at fixed ``--b`` (default 0.58);
* ``biplan map plot DIR`` — the figures of a finished map (``DIR/*.png``).

Chunks run in this process (``--workers 1``, default) on ``--threads`` threads (default 0:
one per available core; chunks run concurrently, the kernels compiled once), on a loopback
Dask ``LocalCluster`` (``--workers N``, N > 1) or on a user's scheduler (``--scheduler
ADDRESS``). Finished chunks are
stored under ``DIR/chunks``; ``--resume`` continues a killed run without recomputing them
(a chunk file that is missing or unreadable is reported and computed again; a directory
with chunk files but no ``manifest.json`` is refused). The merged map is ``DIR/map.nc``
(netCDF, attributes hold the configuration and settings).

Every option, the grid and the output directory are checked before anything is computed
(``--workers`` ≥ 1; ``--workers``/``--threads`` with ``--scheduler``, and ``--threads`` with
``--workers`` > 1, are refused: they would be ignored). A grid of more than ``--max-points``
points (default :data:`MAX_POINTS`) is refused with its estimated run time; a grid estimated
to run longer than :data:`WARN_SECONDS` gets a one-line warning with the estimate
(:mod:`biplan.analysis.maps.cost`: measured points per second and core). Points that failed are
counted on stderr (also with ``--quiet``); a map in which every point failed is written, then
the command exits with status 2.

The work is the library's: :class:`~biplan.analysis.maps.execution.Execution` (where chunks
run), :func:`biplan.io.sweepstore.open_map` (the chunk store; its
:class:`~biplan.analysis.maps.runs.MapJob` sweeps and writes ``map.nc``) and
:func:`biplan.plot.maps.write_map_figures`.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, cast

import typer
from rich.console import Console
from rich.markup import escape

from biplan._errors import ConfigError, ConvergenceError, check_integer
from biplan.cli._checks import options_named, output_directory, refuse_unused

if TYPE_CHECKING:
    from biplan.analysis.maps.execution import Execution
    from biplan.analysis.maps.sweeps import Evaluator, Grid
    from biplan.model.tube import Tube

__all__ = ["MAX_POINTS", "WARN_SECONDS", "app", "check_size", "design", "instability", "plot",
           "stability"]  # fmt: skip


app = typer.Typer(help="Design and stability maps over grids of design parameters.",
                  no_args_is_help=True)  # fmt: skip

_C_HELP = "C values: START:STOP:N, START:STOP:Nlog (log-spaced) or a,b,c."
_Config = Annotated[Path, typer.Argument(help="Tube configuration (TOML).", exists=True)]
_Out = Annotated[Path, typer.Option("--out", help="Output directory.")]
_Workers = Annotated[int, typer.Option(help="Worker processes (1: in this process).")]
_Scheduler = Annotated[
    str | None, typer.Option(help="Dask scheduler address of an existing cluster.")
]
_Threads = Annotated[
    int,
    typer.Option(help="In-process threads running chunks (0: one per available core)."),
]
_Resume = Annotated[bool, typer.Option("--resume", help="Continue a killed run in --out.")]
_Chunk = Annotated[int, typer.Option(help="Points per chunk (the unit of work and of --resume).")]
_Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar or summary.")]
#: Default of ``--max-points``: the largest grid run without being asked for explicitly
#: (a design map of this size takes about 30 min on two cores, a stability map about 6 h).
MAX_POINTS = 100_000
#: A grid estimated to run longer than this [s] is warned of before it starts.
WARN_SECONDS = 600.0
_MaxPoints = Annotated[
    int,
    typer.Option(
        "--max-points",
        help="Largest grid to run (points); a larger grid is refused with its estimated time.",
    ),
]
#: Internal names of grid values → the option they come from.
_GRID_OPTIONS = {
    "b": "--b",
    "grid.b": "--b",
    "C": "--C",
    "grid.C": "--C",
    "displacement": "--displacement",
    "grid.displacement": "--displacement",
}


def check_size(
    grid: Grid,
    tube: Tube,
    evaluator: Evaluator,
    max_points: int,
    cores: int,
    options: tuple[str, ...],
) -> float | None:
    """Refuse a grid of more than ``max_points`` points, and warn (stderr, one line) of one
    estimated to run longer than :data:`WARN_SECONDS` on ``cores`` cores; returns the
    estimate [s] (None without a measured rate). ``options`` name the grid's axes
    (``("--b", "--C")``).

    Raises
    ------
    ConfigError
        Naming ``--max-points``, with the grid's size and estimated time.
    """
    from biplan.analysis.maps.cost import duration, map_seconds

    check_integer("--max-points", max_points, low=1)
    seconds = map_seconds(evaluator.name, grid.size, tube.n_modules, cores)
    shape = " × ".join(f"{n} {o}" for n, o in zip(grid.shape, options, strict=True))
    where = "" if seconds is None else f"; about {duration(seconds)} on {cores} core(s)"
    if grid.size > max_points:
        raise ConfigError(
            "--max-points",
            max_points,
            f"at least the grid's {grid.size} points ({shape} values{where}) to run a grid "
            "this large",
        )
    if seconds is not None and seconds > WARN_SECONDS:
        _warn(f"{grid.size} points ({shape} values): about {duration(seconds)} on {cores} "
              "core(s), at the measured rate of this machine class (docs/maps.md)")  # fmt: skip
    return seconds


def _warn(text: str) -> None:
    Console(stderr=True, highlight=False).print(f"[yellow]warning:[/] {text}", soft_wrap=True)


def _execution(
    ctx: typer.Context,
    out: Path,
    chunk_size: int | None,
    workers: int,
    scheduler: str | None,
    threads: int,
) -> Execution:
    """The checks of the options every map command shares, before anything is computed."""
    from biplan.analysis.maps.execution import Execution

    output_directory(out)
    with options_named({"workers": "--workers", "threads": "--threads"}):
        execution = Execution(workers, scheduler, threads)
    if chunk_size is not None:
        check_integer("--chunk-size", chunk_size, low=1)
    if scheduler is not None:
        refuse_unused(ctx, {"workers": "--workers", "threads": "--threads"}, "with --scheduler")
    elif workers > 1:
        refuse_unused(ctx, {"threads": "--threads"}, "with --workers > 1")
    return execution


def _run(config: Path, grid: Grid, ev: Evaluator, out: Path, execution: Execution, *,
         chunk_size: int, resume: bool, max_points: int, quiet: bool,
         values: dict[str, float] | None = None) -> Any:  # fmt: skip
    """Load the tube, check the grid and its size, then run the map into ``out`` with a
    progress bar; damaged chunks and failed points are reported on stderr (also when
    ``quiet``), the summary unless ``quiet``. Returns the map dataset.

    Raises
    ------
    ConvergenceError
        Every point of the map failed (after ``map.nc`` is written).
    """
    import biplan
    from biplan.analysis.maps.sweeps import apply_values, check_grid
    from biplan.io.sweepstore import open_map

    tube = biplan.load_config(config)
    with options_named(_GRID_OPTIONS):
        tube = apply_values(tube, values) if values else tube
        check_grid(tube, grid, ev)
    axes = tuple(_GRID_OPTIONS[a.name] for a in grid.axes)
    check_size(grid, tube, ev, max_points, execution.cores, axes)
    with options_named({"out": "--out"}):
        job = open_map(tube, grid, ev, out, chunk_size=chunk_size, resume=resume)
    for chunk, why in job.damaged.items():
        _warn(f"chunk {chunk} of {escape(str(out))}: {escape(why)}; computing it again")
    with _progress_bar(ev.name, grid.size, quiet) as progress:
        run = job.run(execution, progress)
    where = escape(str(run.path))
    if run.all_failed:
        raise ConvergenceError(
            f"every one of the {run.n_points} points of the map failed (their status is in "
            f"{run.path})"
        )
    if run.n_failed:
        first = run.failed_points()
        more = f" (the first {len(first)})" if run.n_failed > len(first) else ""
        _warn(
            f"{run.n_failed} of {run.n_points} points failed (status ≠ 0 in {where}){more}: "
            f"{escape('; '.join(first))}"
        )
    reused = f", {run.reused} of {run.n_chunks} chunks reused" if resume else ""
    Console(quiet=quiet, highlight=False).print(
        f"{run.n_points} points ({run.n_failed} failed{reused}) in {run.seconds:.1f} s; "
        f"wrote {where}",
        soft_wrap=True,
    )
    return run.dataset


@contextmanager
def _progress_bar(name: str, total: int, quiet: bool) -> Iterator[Callable[[int, int], None]]:
    """A Rich progress bar on stderr (hidden when ``quiet`` or not a terminal) with the rate
    of the points computed in this run; yields the sweep's ``progress(done, total)``."""
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    console = Console(quiet=quiet or not sys.stderr.isatty(), stderr=True)
    start = time.perf_counter()
    first: list[int] = []
    with Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]} points/s"),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=console,
    ) as bar:
        task = bar.add_task(name, total=total, rate="-")

        def progress(done: int, total: int) -> None:
            if not first:
                first.append(done)  # chunks reused from an earlier run do not count
            elapsed = time.perf_counter() - start
            new = done - first[0]
            rate = f"{new / elapsed:.2f}" if new and elapsed > 0 else "-"
            bar.update(task, completed=done, rate=rate)

        yield progress


@app.command("design")
def design(
    ctx: typer.Context,
    config: _Config,
    b: Annotated[str, typer.Option("--b", help="b values: START:STOP:N or a,b,c.")],
    c: Annotated[str, typer.Option("--C", help=_C_HELP)],
    out: _Out = Path("design_map"),
    rate: Annotated[float, typer.Option(help="Force rate Ḟ [N/s].")] = 0.8,
    duration: Annotated[float, typer.Option(help=r"Ramp duration \[s].")] = 2.0,
    steps: Annotated[int, typer.Option(help="Load steps on the ramp.")] = 16,
    after_snap: Annotated[
        str,
        typer.Option(
            "--after-snap",
            help="After a failed load step (a snap): 'dynamic' finishes the ramp with "
            "generalized-α dynamics, 'stop' records the point as not converged.",
        ),
    ] = "dynamic",
    chunk_size: _Chunk = 16,
    workers: _Workers = 1,
    scheduler: _Scheduler = None,
    threads: _Threads = 0,
    resume: _Resume = False,
    max_points: _MaxPoints = MAX_POINTS,
    quiet: _Quiet = False,
) -> None:
    """Force-controlled design map over (b, C): terminal u_z/l0, u_r/l0, loss of stability."""
    from biplan.analysis.maps.design_map import ForceRamp, ResponseEvaluator
    from biplan.analysis.maps.sweeps import Grid, parse_axis

    execution = _execution(ctx, out, chunk_size, workers, scheduler, threads)
    names = {**_GRID_OPTIONS, "ramp.rate": "--rate", "ramp.duration": "--duration",
             "ramp.n_steps": "--steps", "ramp.after_snap": "--after-snap"}  # fmt: skip
    with options_named(names):
        grid = Grid((parse_axis("b", b), parse_axis("C", c)))
        ramp = ForceRamp(rate=rate, duration=duration, n_steps=steps, after_snap=after_snap)
    _run(config, grid, ResponseEvaluator(ramp), out, execution, chunk_size=chunk_size,
         resume=resume, max_points=max_points, quiet=quiet)  # fmt: skip


@app.command("instability")
def instability(
    ctx: typer.Context,
    config: _Config,
    b: Annotated[str, typer.Option("--b", help="b values: START:STOP:N or a,b,c.")],
    c: Annotated[str, typer.Option("--C", help=_C_HELP)],
    out: _Out = Path("instability_map"),
    up_to: Annotated[float, typer.Option(help=r"Highest end force of the search \[N].")] = 3.0,
    chunk_size: _Chunk = 16,
    workers: _Workers = 1,
    scheduler: _Scheduler = None,
    threads: _Threads = 0,
    resume: _Resume = False,
    max_points: _MaxPoints = MAX_POINTS,
    quiet: _Quiet = False,
) -> None:
    """First-instability map over (b, C): the end force F* [N] and displacement U* [mm] at
    which a force-controlled test first loses stability (NaN where it does not below
    --up-to)."""
    from biplan.analysis.maps.instability_map import InstabilityEvaluator
    from biplan.analysis.maps.sweeps import Grid, parse_axis

    execution = _execution(ctx, out, chunk_size, workers, scheduler, threads)
    with options_named({**_GRID_OPTIONS, "up_to": "--up-to"}):
        grid = Grid((parse_axis("b", b), parse_axis("C", c)))
        ev = InstabilityEvaluator(up_to=up_to)
    _run(config, grid, ev, out, execution, chunk_size=chunk_size, resume=resume,
         max_points=max_points, quiet=quiet)  # fmt: skip


@app.command("stability")
def stability(
    ctx: typer.Context,
    config: _Config,
    displacement: Annotated[
        str, typer.Option(help="U/l0 values (normalised end displacement): START:STOP:N.")
    ],
    c: Annotated[str, typer.Option("--C", help=_C_HELP)],
    out: _Out = Path("stability_map"),
    b: Annotated[float, typer.Option("--b", help="Geometric ratio b (set through β).")] = 0.58,
    max_equilibria: Annotated[int, typer.Option(help="Equilibria kept per point.")] = 8,
    seeding: Annotated[
        str,
        typer.Option(
            help="Fixed seeds: 'subsets' (every subset of open circular folds, up to 8 folds) "
            "or 'patterns' (3 N_c - 2 patterns next to the base or the free end)."
        ),
    ] = "subsets",
    chunk_size: Annotated[
        int | None,
        typer.Option(help="Points per chunk (default: whole rows of displacements, ≥ 128 points)."),
    ] = None,
    workers: _Workers = 1,
    scheduler: _Scheduler = None,
    threads: _Threads = 0,
    resume: _Resume = False,
    max_points: _MaxPoints = MAX_POINTS,
    quiet: _Quiet = False,
) -> None:
    """Displacement-controlled stability map over (C, U/l0) at fixed b: count of stable
    equilibria (1 mono, 2 bi, ≥3 multi) and the transition band."""
    from biplan.analysis.maps.stability_map import StabilityEvaluator, stability_chunk_size
    from biplan.analysis.maps.stability_search import StabilitySearch
    from biplan.analysis.maps.stability_seeds import Seeding
    from biplan.analysis.maps.sweeps import Grid, parse_axis

    execution = _execution(ctx, out, chunk_size, workers, scheduler, threads)
    names = {**_GRID_OPTIONS, "search.max_equilibria": "--max-equilibria",
             "search.seeding": "--seeding"}  # fmt: skip
    with options_named(names):
        grid = Grid((parse_axis("C", c), parse_axis("displacement", displacement)))
        ev = StabilityEvaluator(StabilitySearch(max_equilibria, seeding=cast(Seeding, seeding)))
    size = chunk_size or stability_chunk_size(grid.shape[1])
    ds = _run(config, grid, ev, out, execution, chunk_size=size, resume=resume,
              max_points=max_points, quiet=quiet, values={"b": b})  # fmt: skip
    if not quiet:
        counts = {k: int((ds["regime"].values == v).sum()) for k, v in
                  (("mono", 1), ("bi", 2), ("multi", 3))}  # fmt: skip
        Console(highlight=False).print(
            f"b = {b:g}: {counts} points, {int(ds['transition'].sum())} in the transition band"
        )


@app.command("plot")
def plot(
    directory: Annotated[Path, typer.Argument(help="Map directory (holding map.nc).")],
) -> None:
    """Figures of a finished map: u_z.png and u_r.png (design), force.png (instability) or
    stability.png."""
    from biplan.io.sweepstore import load_map
    from biplan.plot.maps import map_figures, write_map_figures

    with options_named({"map": "DIRECTORY"}):
        ds = load_map(directory)
    folder = directory if directory.is_dir() else directory.parent
    output_directory(folder, "DIRECTORY", files=[f"{n}.png" for n in map_figures(ds)])
    files = write_map_figures(ds, folder)
    Console(highlight=False).print("wrote " + ", ".join(str(f) for f in files))
