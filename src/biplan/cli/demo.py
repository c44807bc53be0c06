"""``biplan demo``: the displacement-controlled extension of the semi-bistable MFT.

Builds the validated semi-bistable design (SI Table calib) or a tube from a TOML file, relaxes
it, sweeps the prescribed end displacement U from 0 (exclusive) to 9 mm with
:func:`~biplan.analysis.response.quasistatic.displacement_sweep`, prints a table and a summary, and
writes into ``--out``:

* ``force_displacement.png`` — F [N] against U [mm], snapshot states marked B.1–B.3;
* ``development.png`` — deformed developments of the snapshots, folds coloured by w [mm];
* ``cylinder.png`` — the snapshots wrapped onto the cylinder, side by side;
* ``demo.csv`` — one row per step: displacement [mm], force [N], u_z [mm], u_r [mm],
  theta [rad], energy [N·mm], min_eigenvalue, stable (1/0), status, switched (1/0)
  (:func:`biplan.io.results.save_sweep_csv`).

Snapshots: the paper's Fig. 3 B panels, as ``biplan reproduce`` draws them
(:func:`biplan.reproduction.facts.snapshot_steps`): B.1 the phase-1 state whose force is
nearest half the phase-1 peak force, B.2 the step midway between the first and the last snap,
B.3 the last converged state when it follows the last snap. Only the panels that exist are
drawn (a sweep without a snap has B.1 alone); without any, ``development.png`` and
``cylinder.png`` are not written.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from biplan.cli._checks import output_directory
from biplan.reproduction.facts import snapshot_steps

if TYPE_CHECKING:
    from biplan.analysis.response.quasistatic import QuasiStaticPath
    from biplan.model.assembly import Model
    from biplan.model.tube import Tube
    from biplan.solvers import Solution
    from biplan.solvers.path_results import Snap

__all__ = ["MAX_DISPLACEMENT", "demo", "phase_one"]

#: Final prescribed end displacement of the demo sweep [mm].
MAX_DISPLACEMENT = 9.0
#: Print every TABLE_STRIDE-th step in the table (and the last one).
TABLE_STRIDE = 5


def _tube(config: Path | None) -> Tube:
    """The design to run: a TOML configuration, or the semi-bistable MFT."""
    import biplan

    if config is None:
        return biplan.designs.semi_bistable()
    return biplan.load_config(config)


def _sweep(
    model: Model, targets: np.ndarray, start: Solution, advance: Callable[[], object]
) -> QuasiStaticPath:
    """The displacement sweep, advancing a progress bar after every step."""
    from biplan.analysis.response.quasistatic import displacement_sweep

    return displacement_sweep(model, targets, start=start, progress=lambda *_: advance())


def phase_one(path: QuasiStaticPath) -> slice:
    """Steps of phase 1: from the start up to (excluding) the first step that failed, is
    unstable, switched branch (the first snap) or whose force fell along stable states
    (:func:`biplan.analysis.response.summary.phase_one_end`)."""
    from biplan.analysis.response.summary import phase_one_end

    return slice(0, phase_one_end(path.force, path.stable, path.switched))


def _snapshots(path: QuasiStaticPath) -> dict[str, int]:
    """Step indices of the snapshot states B.1–B.3 that exist (see module docstring)."""
    import biplan

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


def _summary(path: QuasiStaticPath, seconds: float, peak: Snap | None) -> str:
    """The summary line: the located phase-1 peak (``peak``,
    :func:`~biplan.analysis.response.loadcontrol.first_snap`), snaps, failures and time."""
    first = phase_one(path)
    n_failed = int(np.sum(~np.isfinite(path.force)))
    n_snaps = int(np.sum(path.switched))
    if first.stop == 0:
        head = "No regular phase 1 (the first step snapped, failed or is unstable)"
    elif peak is None:
        k = int(np.argmax(path.force[first]))
        head = (
            f"Phase 1: largest force {path.force[k]:.4f} N at U = {path.displacement[k]:.3f} mm "
            "(no loss of stability under force control found)"
        )
    else:
        head = (
            f"Phase 1 peak force {peak.force:.4f} ± {peak.tolerance:.1g} N at z_p = "
            f"{peak.displacement_before:.3f} mm (located first loss of stability)"
        )
    tail = f"{n_snaps} snaps, {n_failed} failed of {len(path.force)} steps, {seconds:.1f} s"
    return f"{head} ({tail})"


def _figures(
    model: Model, start: Solution, path: QuasiStaticPath, snaps: dict[str, int], out: Path
) -> list[Path]:
    """Write the PNGs (``start``: the relaxed reference); returns their paths."""
    from biplan.plot import cylinder, development, elongation_norm, force_displacement
    from biplan.plot.files import figure_file
    from biplan.plot.response import (
        COLUMN_FIGSIZE,
        FONT_SIZE,
        LINE_COLOR,
        SNAP_COLOR,
        legend_above,
    )

    def title(key: str) -> str:
        k = snaps[key]
        return f"({key}) $U$ = {path.displacement[k]:.2f} mm, $F$ = {path.force[k]:.2f} N"

    files = [out / f"{n}.png" for n in ("force_displacement", "development", "cylinder")]
    states = [path.solutions[k].q for k in snaps.values()]

    with figure_file(files[0], figsize=COLUMN_FIGSIZE) as (_, ax):
        force_displacement(path, ax=ax)
        if np.isfinite(path.force[0]) and path.stable[0]:  # join the relaxed reference
            u0, f0 = [start.displacement, path.displacement[0]], [start.force, path.force[0]]
            ax.plot(u0, f0, "-", lw=1.2, color=LINE_COLOR, zorder=2)
        ax.set_xlim(0.0, 1.04 * float(np.nanmax(path.displacement)))
        ax.margins(y=0.1)
        for key, k in snaps.items():
            u, f = path.displacement[k], path.force[k]
            ax.plot(u, f, "s", ms=3.5, color=SNAP_COLOR, zorder=4)
            ax.annotate(
                f"({key})",
                (u, f),
                textcoords="offset points",
                xytext=(0, 5),
                ha="center",
                fontsize=FONT_SIZE,
            )
        legend_above(ax)
    if not snaps:
        return files[:1]

    n = len(snaps)
    with figure_file(files[1], ncols=n, squeeze=False, figsize=(7.0, 3.9)) as (_, grid):
        axes = grid[0]
        norm = elongation_norm(model, states)
        for i, (key, q) in enumerate(zip(snaps, states, strict=True)):
            development(model, q, ax=axes[i], norm=norm, colorbar=i == n - 1)
            axes[i].set_title(title(key), fontsize=FONT_SIZE)
        # One frame for all panels, so that the states compare at equal scale.
        xlim = min(a.get_xlim()[0] for a in axes), max(a.get_xlim()[1] for a in axes)
        ylim = min(a.get_ylim()[0] for a in axes), max(a.get_ylim()[1] for a in axes)
        for i, a in enumerate(axes):
            a.set(xlim=xlim, ylim=ylim)
            if i:
                a.set_ylabel("")
                a.tick_params(labelleft=False)

    with figure_file(files[2], figsize=(3.4, 3.6), subplot_kw={"projection": "3d"}) as (_, ax3):
        azim, spacing = -60.0, 5.0 * model.tube.development.radius
        side = np.radians(azim + 90.0)  # screen-horizontal direction at this azimuth
        for i, (key, q) in enumerate(zip(snaps, states, strict=True)):
            x, y = i * spacing * np.cos(side), i * spacing * np.sin(side)
            cylinder(model, q, ax=ax3, azim=azim, offset=(x, y))
            ax3.text(
                x,
                y,
                -0.12 * model.tube.initial_length,
                f"({key})",
                ha="center",
                va="top",
                fontsize=FONT_SIZE,
            )
    return files


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

    console = Console(highlight=False)
    interactive = console.is_terminal and not quiet
    t0 = time.perf_counter()
    output_directory(out)
    model = biplan.Model(_tube(config))  # validate the input before creating anything
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise typer.BadParameter(f"cannot create {out}: {err}", param_hint="--out") from None
    relaxing = "Relaxing the reference state (compiles on first use)…"
    with console.status(relaxing) if interactive else contextlib.nullcontext():
        ref = biplan.relaxed_reference(model, throw=True)
    targets = np.linspace(MAX_DISPLACEMENT / steps, MAX_DISPLACEMENT, steps)
    progress = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=console,
        transient=True,
        disable=not interactive,
    )
    with progress:
        task = progress.add_task("Sweeping U", total=steps)
        path = _sweep(model, targets, ref, lambda: progress.advance(task))
    from biplan.analysis.response.loadcontrol import first_snap

    with console.status("Locating the phase-1 peak…") if interactive else contextlib.nullcontext():
        peak = first_snap(model)
    seconds = time.perf_counter() - t0

    if not quiet:
        console.print(_table(path))
    console.print(_summary(path, seconds, peak), soft_wrap=True)
    try:
        from biplan.io.results import save_sweep_csv

        save_sweep_csv(path, out / "demo.csv")  # first: kept even if no step converged
        files = _figures(model, ref, path, _snapshots(path), out)
    except OSError as err:
        raise typer.BadParameter(f"cannot write into {out}: {err}", param_hint="--out") from None
    from biplan.cli._demo_response import run_response

    with (
        console.status("Force ramp (dynamic) and equilibrium path…")
        if interactive
        else (contextlib.nullcontext())
    ):
        lines, more = run_response(model, out, animate=animate, peak=peak)
    for line in lines:
        console.print(escape(line), soft_wrap=True)
    if not quiet:
        for f in [*files, out / "demo.csv", *more]:
            console.print(f"wrote {escape(str(f))}")
