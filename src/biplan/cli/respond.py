"""``biplan respond CONFIG --control {force,displacement,pressure} [--dynamic] --out DIR``.

Runs :func:`biplan.analysis.response.run.respond`: quasi-static, ``--method stable`` (the
default) is what a test under that control does (under force or pressure control the stable
branches with each snap located and landed, ``--stop-at-snap`` ending at the first; under
displacement control the stable-branch sweep, ``--step`` mm per step); ``--method arclength``
and ``--method stepping`` are numerical paths; ``--dynamic`` integrates the equations of motion
under the ramp Λ(t) = ``--rate`` · t for 0 ≤ t ≤ ``--duration`` (default the paper's 0.8 N/s
for 2 s), then holds for ``--hold`` seconds. Writes into DIR ``response.nc`` and
``response.csv`` (:func:`biplan.io.response_files.save_response`) and ``response.png``
(:func:`biplan.plot.response_figures.response_figure`), and prints the summary, whose
phase-1 peak force is the located first loss of stability under force control. A stable run
that ends short of ``--stop`` (a sweep: every step failed) writes its files and exits with
status 1, saying why; a sweep that went on past failed steps warns, naming the first one's U
and the solver's reason.

Units: force N, displacement mm, pressure **kPa** on the command line and in the files and
figures (MPa = N/mm² in the library).

Every option is checked before the tube is loaded: a value out of range, an output location
that cannot be written (:mod:`biplan.cli._checks`) and an option the chosen mode would ignore
(``--rate``, ``--duration``, ``--hold``, ``--time-step``, ``--damping-ratio`` without
``--dynamic``; ``--stop``, ``--method``, ``--step``, ``--max-step``, ``--max-steps`` with it;
``--max-step`` with ``--control displacement --method stable``; ``--stop-at-snap`` except
with ``--method stable`` under force or pressure control) are refused with a one-line error.
"""

from __future__ import annotations

import enum
import math
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from biplan._errors import ConfigError, check_finite, check_integer, check_range
from biplan.analysis.response.settings import Method, QuasiStatic, Ramp
from biplan.cli._checks import given, output_directory, refuse_unused

__all__ = ["EXIT_SHORT", "Method", "bifurcation_note", "respond"]

#: Exit status of a stable run that ended short of --stop (its files are written).
EXIT_SHORT = 1

#: Default stop values per control (quasi-static): F [N], U [mm], p [kPa].
DEFAULT_STOP = {"force": 2.5, "displacement": 9.0, "pressure": 200.0}
#: Default ramp rates per control (dynamic): N/s, mm/s, kPa/s (paper: 0.8 N/s).
DEFAULT_RATE = {"force": 0.8, "displacement": 4.5, "pressure": 64.0}
#: Units of --stop per control.
UNITS = {"force": "N", "displacement": "mm", "pressure": "kPa"}
#: The files written into --out.
OUTPUT_FILES = ("response.nc", "response.csv", "response.png")
#: Options of dynamic runs only (Python name → option), refused without --dynamic.
DYNAMIC_OPTIONS = {
    "rate": "--rate",
    "duration": "--duration",
    "hold": "--hold",
    "time_step": "--time-step",
    "damping_ratio": "--damping-ratio",
}
#: Options of quasi-static runs only, refused with --dynamic.
QUASI_STATIC_OPTIONS = {
    "stop": "--stop",
    "method": "--method",
    "step": "--step",
    "max_step": "--max-step",
    "max_steps": "--max-steps",
    "stop_at_snap": "--stop-at-snap",
}


class ControlName(enum.StrEnum):
    """Values of ``--control`` (those of :class:`biplan.solvers.ControlKind`, which imports
    JAX)."""

    force = "force"
    displacement = "displacement"
    pressure = "pressure"


def respond(
    ctx: typer.Context,
    config: Annotated[Path, typer.Argument(help="Tube configuration (TOML).", exists=True)],
    out: Annotated[Path, typer.Option("--out", help="Output directory.")] = Path("response"),
    control: Annotated[ControlName, typer.Option(help="Controlled quantity.")] = ControlName.force,
    dynamic: Annotated[bool, typer.Option("--dynamic", help="Integrate in time.")] = False,
    stop: Annotated[
        float | None,
        typer.Option(help="Quasi-static end value: N, mm or kPa (default 2.5 N, 9 mm, 200 kPa)."),
    ] = None,
    method: Annotated[
        Method,
        typer.Option(
            help="Quasi-static method: stable (what a test under this control does: stable "
            "branches, each snap located and landed), arclength (a numerical method: the "
            "equilibrium path through unstable states) or stepping (load steps, stopping at "
            "the first limit point)."
        ),
    ] = Method.STABLE,
    stop_at_snap: Annotated[
        bool,
        typer.Option(
            "--stop-at-snap", help="Force/pressure, --method stable: end at the first snap."
        ),
    ] = False,
    step: Annotated[
        float,
        typer.Option(
            help="Initial path step (arclength units); --control displacement --method stable: "
            "mm per step."
        ),
    ] = 0.05,
    max_step: Annotated[
        float,
        typer.Option(
            help="Largest path step (finer than the API's ArcLength/LoadStepping default, 0.25, "
            "for smooth curves in the figure and files)."
        ),
    ] = 0.1,
    max_steps: Annotated[int, typer.Option(help="Most path steps.")] = 2000,
    rate: Annotated[
        float | None, typer.Option(help="Dynamic ramp rate: N/s, mm/s or kPa/s (default 0.8 N/s).")
    ] = None,
    duration: Annotated[float, typer.Option(help=r"Ramp duration \[s].")] = 2.0,
    hold: Annotated[float, typer.Option(help=r"Hold after the ramp \[s].")] = 0.0,
    time_step: Annotated[float, typer.Option(help=r"Time step \[s].")] = 0.01,
    damping_ratio: Annotated[
        float,
        typer.Option(help="Rayleigh damping as a first-mode damping ratio ζ (0: undamped)."),
    ] = 0.05,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress or summary.")] = False,
) -> None:
    """Force-, displacement- or pressure-controlled response of a tube (quasi-static or
    dynamic); writes response.nc, response.csv and response.png."""
    import biplan
    from biplan.analysis.response.run import respond as run_response
    from biplan.io.response_files import save_response
    from biplan.plot.response_figures import response_figure

    output_directory(out, files=OUTPUT_FILES)
    kind = control.value
    scale = 1e-3 if kind == "pressure" else 1.0  # kPa → MPa
    settings: QuasiStatic | Ramp
    if dynamic:
        _check_dynamic(ctx, rate, duration, hold, time_step, damping_ratio)
        ramp_rate = (DEFAULT_RATE[kind] if rate is None else rate) * scale
        settings = Ramp(ramp_rate, duration, hold, time_step, damping_ratio)
    else:
        _check_quasi_static(ctx, method, stop, step, max_step, max_steps, kind)
        if stop_at_snap and (method is not Method.STABLE or control is ControlName.displacement):
            raise ConfigError(
                "--stop-at-snap", True, "used with --method stable under force or pressure control"
            )
        value = (DEFAULT_STOP[kind] if stop is None else stop) * scale
        settings = QuasiStatic(value, method, step, max_step, max_steps, stop_at_snap)
    console = Console(quiet=quiet or not sys.stdout.isatty(), highlight=False)
    tube = biplan.load_config(config)
    model = biplan.Model(tube)
    sweep = not dynamic and method is Method.STABLE and kind == "displacement"
    doing = "stable-branch sweep" if sweep else "integrating" if dynamic else "tracing"
    with console.status(f"[bold]{tube.name}[/]: {doing}…"):
        run = run_response(model, kind, settings)
    out.mkdir(parents=True, exist_ok=True)
    save_response(run.result, out / "response", model)
    response_figure(run.result, out / "response.png")
    report = Console(quiet=quiet, highlight=False)
    report.print(f"[{'green' if run.complete else 'yellow'}]{run.headline}[/]")
    for line in run.snap_lines():
        report.print(line)
    report.print("\n".join(run.summary.lines()) + f"\nwrote {out}/response.{{nc,csv,png}}")
    note = bifurcation_note(run.result)
    if note and method is Method.ARCLENGTH:
        report.print(f"[yellow]note:[/] {note}")
    errors = Console(stderr=True, highlight=False)
    if run.short:
        errors.print(
            f"[red]error:[/] the response ended short of --stop: {run.message}", soft_wrap=True
        )
        raise typer.Exit(EXIT_SHORT)
    if run.failed_steps:  # a sweep that went on past failed steps
        errors.print(
            f"[yellow]warning:[/] {run.message}. The failed steps' rows hold NaN and their "
            "solver status.",
            soft_wrap=True,
        )


def _check_quasi_static(
    ctx: typer.Context,
    method: Method,
    stop: float | None,
    step: float,
    max_step: float,
    max_steps: int,
    kind: str,
) -> None:
    """Refuse quasi-static options out of range, and dynamic ones (they would be ignored)."""
    import biplan

    refuse_unused(ctx, DYNAMIC_OPTIONS, "without --dynamic")
    if stop is not None and check_finite("--stop", stop) == 0:
        raise ConfigError("--stop", stop, f"a non-zero end value [{UNITS[kind]}]")
    check_integer("--max-steps", max_steps, low=1)
    if method is Method.STABLE and kind == "displacement":
        refuse_unused(
            ctx, {"max_step": "--max-step"}, "with --control displacement --method stable"
        )
        check_range("--step", step, low=0.0, unit="mm (the displacement per step)")
        top = DEFAULT_STOP[kind] if stop is None else stop
        ratio = abs(top) / step  # inf for a denormal step
        if ratio > max_steps:
            n = f"{math.ceil(ratio)} steps" if math.isfinite(ratio) else "too many steps"
            raise ConfigError(
                "--step",
                step,
                f"≥ |--stop| / --max-steps = {abs(top) / max_steps:g} mm "
                f"({n} to reach {top:g} mm; at most --max-steps {max_steps})",
            )
        return
    check_range("--step", step, low=biplan.ArcLength.min_step)
    if given(ctx, "max_step"):
        check_range("--max-step", max_step, low=step, low_open=False, unit="(--step)")
    elif step > max_step:
        raise ConfigError(
            "--step", step, f"≤ {max_step:g} (the default --max-step; give a larger one)"
        )


def _check_dynamic(
    ctx: typer.Context,
    rate: float | None,
    duration: float,
    hold: float,
    time_step: float,
    damping_ratio: float,
) -> None:
    """Refuse dynamic options out of range, and quasi-static ones (they would be ignored)."""
    refuse_unused(ctx, QUASI_STATIC_OPTIONS, "with --dynamic")
    if rate is not None and check_finite("--rate", rate) == 0:
        raise ConfigError("--rate", rate, "a non-zero ramp rate")
    check_range("--duration", duration, low=0.0, unit="s")
    check_range("--hold", hold, low=0.0, low_open=False, unit="s")
    total = duration + hold
    check_range("--time-step", time_step, low=0.0, high=total, high_open=False,
                unit="s (at most --duration + --hold)")  # fmt: skip
    check_range("--damping-ratio", damping_ratio, low=0.0, low_open=False)


def bifurcation_note(result: object) -> str | None:
    """A hint when a quasi-static path crossed bifurcations and stayed on its branch (for
    identical folds in series: the symmetric branch), else None."""
    events = [e for e in getattr(result, "events", ()) if e.kind == "bifurcation"]
    if not events:
        return None
    first = events[0]
    return (
        f"the path crossed {len(events)} bifurcation(s), the first at z_p = "
        f"{first.displacement:.3g} mm, F = {first.force:.3g} N, and stayed on its branch. With "
        "identical folds in series that is the symmetric branch, on which they transform "
        "together; a displacement-controlled test leaves it fold by fold. For that "
        "stable-branch response (snaps included) use --control displacement --method stable "
        "(docs/solvers.md)."
    )
