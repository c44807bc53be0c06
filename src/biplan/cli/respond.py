"""``biplan respond CONFIG --control {force,displacement,pressure} [--dynamic] --out DIR``.

Quasi-static, ``--method stable`` (the default): what a test under that control does. Under
force or pressure control (:func:`~biplan.analysis.response.loadcontrol.load_response`) the stable
branch up to its first loss of stability, the snap there (located; the landing state found by
a descent at the fixed load), and the stable branch on from there, snap after snap, to
``--stop`` (``--stop-at-snap`` ends at the first); under displacement control the
stable-branch sweep of a testing machine (``--step`` mm per step). ``--method arclength`` is a
numerical method, not a test: the equilibrium path through unstable states by
pseudo-arclength continuation; it never runs back past its start (status ``RETURNED``).
``--method stepping`` steps the load and stops at the first limit point. Dynamic
(``--dynamic``): integrates the equations of motion under the ramp Λ(t) = ``--rate`` · t for
0 ≤ t ≤ ``--duration`` (default the paper's 0.8 N/s for 2 s), then holds for ``--hold``
seconds.

Writes into DIR:

* ``response.nc`` — the labelled result (xarray/netCDF, with the tube configuration);
* ``response.csv`` — one row per step (or time, column ``t`` [s]) with at least
  ``force,u_z,u_r,theta,energy,min_eigenvalue,stable``;
* ``response.png`` — force (pressure, under pressure control) against load-point
  displacement, unstable stretches dashed, located limit points marked, snaps drawn as
  dotted jumps; a dynamic run adds force and displacement against time.

Every run reports the phase-1 peak force as the located first loss of stability under force
control (:func:`~biplan.analysis.response.loadcontrol.first_snap`), with its tolerance. A stable run
that ends short of ``--stop`` writes its files and exits with status 1, saying why.

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
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer
from rich.console import Console

from biplan._errors import ConfigError, check_finite, check_integer, check_range
from biplan.cli._checks import given, output_directory, refuse_unused

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from biplan.analysis.response.summary import ResponseSummary
    from biplan.model.assembly import Model
    from biplan.solvers import Trajectory
    from biplan.solvers.path_results import Path as ResponsePath
    from biplan.solvers.path_results import Snap

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
    force = "force"
    displacement = "displacement"
    pressure = "pressure"


class Method(enum.StrEnum):
    stable = "stable"
    arclength = "arclength"
    stepping = "stepping"


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
    ] = Method.stable,
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
    from biplan.io.results import dataset, save_csv, save_netcdf

    output_directory(out, files=OUTPUT_FILES)
    if dynamic:
        _check_dynamic(ctx, rate, duration, hold, time_step, damping_ratio)
    else:
        _check_quasi_static(ctx, method, stop, step, max_step, max_steps, control.value)
        if stop_at_snap and (method is not Method.stable or control is ControlName.displacement):
            raise ConfigError(
                "--stop-at-snap", True, "used with --method stable under force or pressure control"
            )
    console = Console(quiet=quiet or not sys.stdout.isatty(), highlight=False)
    tube = biplan.load_config(config)
    model = biplan.Model(tube)
    kind = control.value
    scale = 1e-3 if kind == "pressure" else 1.0  # kPa → MPa
    if method is Method.stable and kind == "displacement" and not dynamic:
        with console.status(f"[bold]{tube.name}[/]: stable-branch sweep…"):
            _stable_sweep(model, DEFAULT_STOP[kind] if stop is None else stop, step, out, quiet)
        return
    result: biplan.Path | biplan.Trajectory
    with console.status(f"[bold]{tube.name}[/]: {'integrating' if dynamic else 'tracing'}…"):
        if dynamic:
            result = _dynamic(model, kind, scale, rate, duration, hold, time_step, damping_ratio)
        else:
            value = (DEFAULT_STOP[kind] if stop is None else stop) * scale
            result = _quasi_static(model, kind, value, method, step, max_step, max_steps,
                                   stop_at_snap)  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    save_netcdf(dataset(result), out / "response.nc")
    save_csv(result, out / "response.csv")
    _figure(result, out / "response.png")
    _report(result, _summary(model, result), method, out, quiet)
    if method is Method.stable and not dynamic and not result.completed and not stop_at_snap:
        Console(stderr=True, highlight=False).print(
            f"[red]error:[/] the response ended short of --stop: {result.message}",
            soft_wrap=True,
        )
        raise typer.Exit(EXIT_SHORT)


def _quasi_static(
    model: Model,
    kind: str,
    value: float,
    method: Method,
    step: float,
    max_step: float,
    max_steps: int,
    stop_at_snap: bool,
) -> ResponsePath:
    """The quasi-static response under force or pressure control (or a numerical path)."""
    import biplan
    from biplan.analysis.response.loadcontrol import load_response

    ctl = biplan.Control(biplan.solvers.ControlKind(kind), value)
    if method is Method.stable:
        arc = biplan.ArcLength(initial_step=step, max_step=max_step, max_steps=max_steps)
        return load_response(model, ctl, arc, stop_at_snap=stop_at_snap)
    cls = biplan.ArcLength if method is Method.arclength else biplan.LoadStepping
    stepper = cls(initial_step=step, max_step=max_step, max_steps=max_steps)
    return biplan.trace_path(model, stepper, None, ctl)


def _summary(model: Model, result: object) -> ResponseSummary:
    """The response's summary, its phase-1 peak the located one (:func:`_peak`) when the
    response leaves phase 1 (a dynamic ramp that never does reports no peak)."""
    from biplan.analysis.response.summary import summarize

    l0 = model.tube.initial_length
    plain = summarize(result, initial_length=l0)
    if not (np.isfinite(plain.peak_force) or getattr(result, "snaps", ())):
        return plain
    return summarize(result, initial_length=l0, peak=_peak(model, result))


def _peak(model: Model, result: object) -> Snap | None:
    """The located phase-1 peak: the response's first snap under force control, else
    :func:`~biplan.analysis.response.loadcontrol.first_snap` (the same continuation settings)."""
    from biplan.analysis.response.loadcontrol import PEAK_METHOD, first_snap
    from biplan.solvers import ControlKind

    snaps = getattr(result, "snaps", ())
    control = getattr(result, "control", None)
    if snaps and control is not None and control.kind is ControlKind.FORCE:
        return snaps[0]  # type: ignore[no-any-return]
    return first_snap(model, method=PEAK_METHOD)


def _report(
    result: ResponsePath | Trajectory, summary: ResponseSummary, method: Method, out: Path,
    quiet: bool,
) -> None:  # fmt: skip
    """Print what the run was, how it ended, its snaps and its summary."""
    from biplan.solvers.results import display_units

    report = Console(quiet=quiet, highlight=False)
    level = "green" if result.completed else "yellow"
    what = ""
    if getattr(result, "segment", None) is not None:
        what = "stable response (what a load-controlled test does): "
    elif getattr(result, "method", "") == "ArcLength":
        what = (
            "equilibrium path (pseudo-arclength, a numerical method: unstable states "
            "included, not what a load-controlled test does): "
        )
    report.print(f"[{level}]{what}{result.message}[/]")
    snaps = getattr(result, "snaps", ())
    scale, unit = display_units(result.control)
    for snap in snaps:
        report.print("  " + snap.describe(unit, scale))
    report.print("\n".join(summary.lines()) + f"\nwrote {out}/response.{{nc,csv,png}}")
    note = bifurcation_note(result)
    if note and method is Method.arclength:
        report.print(f"[yellow]note:[/] {note}")


def _stable_sweep(model: Model, stop: float, step: float, out: Path, quiet: bool) -> None:
    """``--method stable``: :func:`~biplan.analysis.response.quasistatic.displacement_sweep` in
    ⌈stop/step⌉ equal steps (checked against ``--max-steps`` before) from the relaxed
    reference."""
    import biplan
    from biplan.analysis.response.quasistatic import displacement_sweep
    from biplan.io.results import save_netcdf, save_sweep_csv, sweep_dataset

    n = _stable_steps(stop, step)
    ref = biplan.relaxed_reference(model, throw=True)
    path = displacement_sweep(model, np.linspace(stop / n, stop, n), start=ref)
    out.mkdir(parents=True, exist_ok=True)
    save_netcdf(sweep_dataset(path, model), out / "response.nc")
    save_sweep_csv(path, out / "response.csv")
    _figure(path, out / "response.png")
    failed = sum(not s.converged for s in path.solutions)
    level = "green" if not failed else "yellow"
    Console(quiet=quiet, highlight=False).print(
        f"[{level}]stable-branch sweep to U = {stop:g} mm: {n} steps, "
        f"{int(path.switched.sum())} snaps to a stable branch, {failed} failed[/]\n"
        + "\n".join(_summary(model, path).lines())
        + f"\nwrote {out}/response.{{nc,csv,png}}"
    )
    if failed == n:
        raise typer.Exit(EXIT_SHORT)


def _stable_steps(stop: float, step: float) -> int:
    """Steps of ``--method stable``: ⌈|stop| / step⌉, at least one."""
    return max(math.ceil(abs(stop) / step), 1)


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
    if method is Method.stable and kind == "displacement":
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


def _dynamic(
    model: object,
    kind: str,
    scale: float,
    rate: float | None,
    duration: float,
    hold: float,
    time_step: float,
    damping_ratio: float,
) -> Trajectory:
    import biplan
    from biplan.analysis.modes import rayleigh_at
    from biplan.solvers import BackwardEuler, ControlKind

    r = (DEFAULT_RATE[kind] if rate is None else rate) * scale
    top = r * duration
    times = (0.0, duration) if hold == 0 else (0.0, duration, duration + hold)
    values = (0.0, top) if hold == 0 else (0.0, top, top)
    history = biplan.LoadHistory(ControlKind(kind), times, values)
    rayleigh = 0.0
    if damping_ratio > 0:
        ref = biplan.relaxed_reference(model, throw=True)  # type: ignore[arg-type]
        probe = biplan.Control(ControlKind(kind), 0.5 * top).load(model, 0.5 * top)  # type: ignore[arg-type]
        rayleigh = rayleigh_at(model, ref, probe, damping_ratio)  # type: ignore[arg-type]
    scheme = BackwardEuler(time_step=time_step, rayleigh=rayleigh)
    return biplan.integrate(model, scheme, t_end=times[-1], load=history)  # type: ignore[arg-type]


def _figure(result: object, file: Path) -> None:
    """response.png: F (p [kPa] under pressure control) against z_p; a trajectory adds F and
    z_p against time in a second panel."""
    import types

    from biplan.plot.files import figure_file
    from biplan.plot.response import COLUMN_FIGSIZE, FONT_SIZE, LINE_COLOR, force_displacement
    from biplan.solvers.results import display_units

    control = getattr(result, "control", None)
    pressure = control is not None and control.kind.value == "pressure"
    shown: object = result
    if pressure:  # the same curve with the load parameter (kPa) in place of the force
        kpa = display_units(control)[0]  # type: ignore[arg-type]
        flags = {n: getattr(result, n) for n in ("switched", "is_event") if hasattr(result, n)}
        shown = types.SimpleNamespace(
            displacement=result.displacement,  # type: ignore[attr-defined]
            force=kpa * np.asarray(result.load_parameter),  # type: ignore[attr-defined]
            stable=result.stable,  # type: ignore[attr-defined]
            **flags,
        )
    time = getattr(result, "time", None)
    width = COLUMN_FIGSIZE[0] * (2.0 if time is not None else 1.0)
    panels = 2 if time is not None else 1
    with figure_file(file, ncols=panels, figsize=(width, COLUMN_FIGSIZE[1])) as (_, axes):
        ax = axes[0] if time is not None else axes
        force_displacement(shown, ax=ax)
        ax.set_xlabel(r"load-point displacement $z_p$ [mm]")
        if pressure:
            ax.set_ylabel(r"pressure $p$ [kPa]")
        if time is not None:
            _time_panel(axes[1], result, FONT_SIZE, LINE_COLOR)  # type: ignore[arg-type]


def _time_panel(ax: Axes, result: Trajectory, font_size: float, color: str) -> None:
    """F(t) (left axis) and z_p(t) (right axis, dashed) of a trajectory."""
    t = np.asarray(result.time)
    ax.plot(t, result.force, color=color, lw=1.2)
    ax.set_xlabel(r"time $t$ [s]", fontsize=font_size)
    ax.set_ylabel(r"$F$ [N]", fontsize=font_size, color=color)
    right = ax.twinx()
    right.plot(t, result.displacement, color="#D55E00", lw=1.0, ls="--")
    right.set_ylabel(r"$z_p$ [mm] (dashed)", fontsize=font_size, color="#D55E00")
    for a in (ax, right):
        a.tick_params(labelsize=font_size)
    ax.set_xlim(float(t[0]), float(t[-1]))
