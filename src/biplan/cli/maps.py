"""``biplan map {design,stability,plot}``: the paper's design and stability maps at scale.

* ``biplan map design CONFIG --b START:STOP:N --C START:STOP:N --out DIR`` — the
  force-controlled design map (terminal u_z/l₀, u_r/l₀ and loss of stability under the ramp
  F = Ḟ t) over (b, C);
* ``biplan map stability CONFIG --displacement START:STOP:N --C START:STOP:N --out DIR`` — the
  number of stable equilibria over (C, U/l₀) at fixed ``--b`` (default 0.58);
* ``biplan map plot DIR`` — the figures of a finished map (``DIR/*.png``).

Chunks run in this process (``--workers 1``, default) on ``--threads`` threads (default 0:
one per available core; chunks run concurrently, the kernels compiled once), on a loopback
Dask ``LocalCluster`` (``--workers N``, N > 1) or on a user's scheduler (``--scheduler
ADDRESS``). Finished chunks are
stored under ``DIR/chunks``; ``--resume`` continues a killed run without recomputing them. The
merged map is ``DIR/map.nc`` (netCDF, attributes hold the configuration and settings).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console

if TYPE_CHECKING:
    from biplan.analysis.sweeps import Evaluator, Grid
    from biplan.geometry import Tube

__all__ = ["app", "design", "plot", "run_map", "stability"]

app = typer.Typer(help="Design and stability maps over grids of design parameters.",
                  no_args_is_help=True)  # fmt: skip

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
_Chunk = Annotated[int, typer.Option(help="Points per chunk (and per compiled batch).")]
_Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar or summary.")]


def run_map(
    design: Tube,
    grid: Grid,
    evaluator: Evaluator,
    out: Path,
    *,
    chunk_size: int,
    resume: bool = False,
    workers: int = 1,
    scheduler: str | None = None,
    threads: int = 0,
    quiet: bool = False,
) -> Any:
    """Run a sweep into ``out`` (chunk store + ``map.nc``) with a Rich progress bar."""
    from biplan._errors import check_integer

    check_integer("--threads", threads, low=0, note=" (0: one per available core)")
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from biplan.analysis.scaleout import available_cores, dask_runner, thread_runner
    from biplan.analysis.sweeps import chunk_indices, sweep
    from biplan.io.config import dump_config
    from biplan.io.sweepstore import ChunkStore, save_map

    description = {
        "config": dump_config(design),
        "quantity": evaluator.name,
        "settings": evaluator.describe(),
        "grid": {a.name: list(a.values) for a in grid.axes},
        "chunk_size": chunk_size,
    }
    n_chunks = len(chunk_indices(grid, chunk_size))
    store = ChunkStore(out, description, n_chunks, resume)
    runner = None
    n_threads = threads or min(available_cores(), n_chunks)
    if scheduler is not None or workers > 1:
        runner = dask_runner(scheduler, workers)
    elif n_threads > 1:
        runner = thread_runner(n_threads)
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
        task = bar.add_task(evaluator.name, total=grid.size, rate="-")

        def progress(done: int, total: int) -> None:
            if not first:
                first.append(done)
            elapsed = time.perf_counter() - start
            new = done - first[0]
            rate = f"{new / elapsed:.2f}" if new and elapsed > 0 else "-"
            bar.update(task, completed=done, rate=rate)

        ds = sweep(design, grid, evaluator, chunk_size=chunk_size, sink=store, runner=runner,
                   progress=progress)  # fmt: skip
    ds.attrs["config"] = description["config"]
    save_map(ds, store.map_path)
    elapsed = time.perf_counter() - start
    Console(quiet=quiet, highlight=False).print(
        f"{grid.size} points ({ds.attrs['n_failed']} failed) in {elapsed:.1f} s; "
        f"wrote {store.map_path}"
    )
    return ds


@app.command("design")
def design(
    config: _Config,
    b: Annotated[str, typer.Option("--b", help="b values: START:STOP:N or a,b,c.")],
    c: Annotated[str, typer.Option("--C", help="C values: START:STOP:N or a,b,c.")],
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
    quiet: _Quiet = False,
) -> None:
    """Force-controlled design map over (b, C): terminal u_z/l0, u_r/l0, loss of stability."""
    import biplan
    from biplan.analysis.design_map import ForceRamp, ResponseEvaluator
    from biplan.analysis.sweeps import Grid, parse_axis

    tube = biplan.load_config(config)
    grid = Grid((parse_axis("b", b), parse_axis("C", c)))
    ramp = ForceRamp(rate=rate, duration=duration, n_steps=steps, after_snap=after_snap)
    ev = ResponseEvaluator(ramp)
    run_map(tube, grid, ev, out, chunk_size=chunk_size, resume=resume, workers=workers,
            scheduler=scheduler, threads=threads, quiet=quiet)  # fmt: skip


@app.command("stability")
def stability(
    config: _Config,
    displacement: Annotated[
        str, typer.Option(help="U/l0 values (normalised end displacement): START:STOP:N.")
    ],
    c: Annotated[str, typer.Option("--C", help="C values: START:STOP:N or a,b,c.")],
    out: _Out = Path("stability_map"),
    b: Annotated[float, typer.Option("--b", help="Geometric ratio b (set through β).")] = 0.58,
    max_equilibria: Annotated[int, typer.Option(help="Equilibria kept per point.")] = 8,
    seeding: Annotated[
        str,
        typer.Option(
            help="Fixed seeds: 'subsets' (every subset of open circular folds, up to 8 folds) "
            "or 'patterns' (3 N_c - 2 patterns, earlier versions)."
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
    quiet: _Quiet = False,
) -> None:
    """Displacement-controlled stability map over (C, U/l0) at fixed b: count of stable
    equilibria (1 mono, 2 bi, ≥3 multi) and the transition band."""
    import biplan
    from biplan.analysis.stability_map import (
        StabilityEvaluator,
        StabilitySearch,
        stability_chunk_size,
    )
    from biplan.analysis.sweeps import Grid, apply_values, parse_axis

    tube = apply_values(biplan.load_config(config), {"b": b})
    grid = Grid((parse_axis("C", c), parse_axis("displacement", displacement)))
    ev = StabilityEvaluator(StabilitySearch(max_equilibria=max_equilibria, seeding=seeding))
    size = chunk_size or stability_chunk_size(grid.shape[1])
    ds = run_map(tube, grid, ev, out, chunk_size=size, resume=resume, workers=workers,
                 scheduler=scheduler, threads=threads, quiet=True)  # fmt: skip
    if not quiet:
        counts = {k: int((ds["regime"].values == v).sum()) for k, v in
                  (("mono", 1), ("bi", 2), ("multi", 3))}  # fmt: skip
        Console(highlight=False).print(
            f"b = {b:g}: {counts} points, {int(ds['transition'].sum())} in the transition band;"
            f" wrote {out / 'map.nc'}"
        )


@app.command("plot")
def plot(
    directory: Annotated[Path, typer.Argument(help="Map directory (holding map.nc).")],
) -> None:
    """Figures of a finished map: u_z.png and u_r.png (design) or stability.png."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from biplan.io.sweepstore import load_map
    from biplan.plot.maps import design_map, stability_map
    from biplan.plot.response import COLUMN_FIGSIZE

    ds = load_map(directory)
    folder = directory if directory.is_dir() else directory.parent
    jobs: list[tuple[str, Any]] = []
    if "regime" in ds:
        jobs.append(("stability", lambda ax: stability_map(ds, ax=ax)))
    else:
        for var in ("u_z", "u_r"):
            jobs.append((var, lambda ax, v=var: design_map(ds, v, ax=ax)))
    for name, draw in jobs:
        fig, ax = plt.subplots(figsize=COLUMN_FIGSIZE, layout="constrained")
        try:
            draw(ax)
            fig.savefig(folder / f"{name}.png", dpi=300)
        finally:
            plt.close(fig)
    Console(highlight=False).print("wrote " + ", ".join(str(folder / f"{n}.png") for n, _ in jobs))
