"""``biplan demo``: the displacement-controlled extension of the semi-bistable MFT, and the
paper's force ramp.

Builds the validated semi-bistable design (SI Table calib) or a tube from a TOML file, relaxes
it, sweeps the prescribed end displacement U from 0 (exclusive) to 9 mm
(:func:`biplan.analysis.response.demo.demo_sweep`), locates the phase-1 peak, prints a table
and a summary, and writes into ``--out``:

* ``force_displacement.png``, ``development.png``, ``cylinder.png`` — the sweep and its
  snapshot states B.1–B.3, the paper's Fig. 3 B panels as ``biplan reproduce`` chooses them
  (:func:`biplan.reproduction.facts.snapshot_steps`;
  :func:`biplan.plot.response_figures.sweep_figures`); without a snapshot only the first;
* ``demo.csv`` — one row per step (:func:`biplan.io.results.save_sweep_csv`);
* ``ramp.nc``/``ramp.csv``, ``path.nc``/``path.csv``, ``response.png`` and ``ramp.gif`` — the
  force ramp (dynamic) and the displacement-controlled equilibrium path
  (:func:`biplan.analysis.response.demo.ramp_and_path`), with their summary lines.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from biplan.cli._checks import output_directory

if TYPE_CHECKING:
    from biplan.analysis.response.quasistatic import QuasiStaticPath
    from biplan.model.tube import Tube

__all__ = ["demo"]

#: Print every TABLE_STRIDE-th step in the table (and the last one).
TABLE_STRIDE = 5


def _tube(config: Path | None) -> Tube:
    """The design to run: a TOML configuration, or the semi-bistable MFT."""
    import biplan

    if config is None:
        return biplan.designs.semi_bistable()
    return biplan.load_config(config)


def _snapshots(path: QuasiStaticPath) -> dict[str, int]:
    """Step indices of the snapshot states B.1–B.3 that exist."""
    import biplan
    from biplan.reproduction.facts import snapshot_steps

    if not np.any(np.isfinite(path.force)):
        raise biplan.ConvergenceError("no step of the displacement sweep converged")
    return snapshot_steps(path.force, path.stable, path.switched)


def _table(path: QuasiStaticPath) -> Table:
    table = Table(title="Displacement-controlled sweep", title_style="bold", min_width=60)
    for name in ("step", "U [mm]", "F [N]", "u_z [mm]", "u_r [mm]", "θ [°]"):
        table.add_column(escape(name), justify="right", no_wrap=True)
    table.add_column("state")
    n = len(path.displacement)
    for k in range(n):
        if (k + 1) % TABLE_STRIDE and k != n - 1 and not path.switched[k]:
            continue
        if not np.isfinite(path.force[k]):
            state = f"[red]failed ({path.status[k].name})[/]"
        elif path.switched[k]:
            state = "[yellow]snap → stable[/]"
        else:
            state = "stable" if path.stable[k] else "[red]unstable[/]"
        table.add_row(
            str(k + 1),
            f"{path.displacement[k]:.3f}",
            f"{path.force[k]:.4f}",
            f"{path.u_z[k]:.3f}",
            f"{path.u_r[k]:.3f}",
            f"{np.degrees(path.theta[k]):.3f}",
            state,
        )
    return table


def demo(
    config: Annotated[
        Path | None,
        typer.Argument(
            help="TOML tube configuration; default: the semi-bistable MFT (SI Table calib).",
            exists=True,
            dir_okay=False,
            show_default=False,
        ),
    ] = None,
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output directory (created if missing).")
    ] = Path("biplan-demo"),
    steps: Annotated[
        int, typer.Option("--steps", "-n", min=2, help="Displacement steps from 0 to 9 mm.")
    ] = 120,
    quiet: Annotated[
        bool, typer.Option("--quiet", "-q", help="No progress bar and no table.")
    ] = False,
    animate: Annotated[
        bool, typer.Option("--animate/--no-animate", help="Write the ramp animation (GIF).")
    ] = True,
) -> None:
    """Stretch a tube to U = 9 mm under displacement control, and load it with the paper's
    force ramp (0.8 N/s for 2 s); write plots, data and the ramp animation.

    Writes force_displacement.png, development.png, cylinder.png, demo.csv, ramp.nc/csv,
    path.nc/csv, response.png and ramp.gif into --out.
    """
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    import biplan
    from biplan.analysis.response.demo import demo_sweep, ramp_and_path, sweep_summary
    from biplan.analysis.response.loadcontrol import first_snap
    from biplan.io.response_files import save_response
    from biplan.io.results import save_sweep_csv
    from biplan.plot import response_figures as figures

    console = Console(highlight=False)
    interactive = console.is_terminal and not quiet

    def status(text: str) -> contextlib.AbstractContextManager[object]:
        return console.status(text) if interactive else contextlib.nullcontext()

    t0 = time.perf_counter()
    output_directory(out)
    model = biplan.Model(_tube(config))  # validate the input before creating anything
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise typer.BadParameter(f"cannot create {out}: {err}", param_hint="--out") from None
    with status("Relaxing the reference state (compiles on first use)…"):
        ref = biplan.relaxed_reference(model, throw=True)
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn(), TimeRemainingColumn())  # fmt: skip
    progress = Progress(*columns, console=console, transient=True, disable=not interactive)
    with progress:
        task = progress.add_task("Sweeping U", total=steps)
        path = demo_sweep(model, steps, ref, lambda *_: progress.advance(task))
    with status("Locating the phase-1 peak…"):
        peak = first_snap(model)
    seconds = time.perf_counter() - t0

    if not quiet:
        console.print(_table(path))
    console.print(sweep_summary(path, seconds, peak), soft_wrap=True)
    try:
        save_sweep_csv(path, out / "demo.csv")  # first: kept even if no step converged
        files = figures.sweep_figures(model, ref, path, _snapshots(path), out)
    except OSError as err:
        raise typer.BadParameter(f"cannot write into {out}: {err}", param_hint="--out") from None
    with status("Force ramp (dynamic) and equilibrium path…"):
        response = ramp_and_path(model, ref, peak=peak)
        more = [
            *save_response(response.ramp, out / "ramp"),
            *save_response(response.path, out / "path"),
        ]
        more.append(
            figures.ramp_and_path_figure(response.path, response.ramp, out / "response.png")
        )
        if animate:
            more.append(figures.ramp_animation(response.ramp, model, out / "ramp.gif"))
    for line in response.lines:
        console.print(escape(line), soft_wrap=True)
    if not quiet:
        for f in [*files, out / "demo.csv", *more]:
            console.print(f"wrote {escape(str(f))}")
