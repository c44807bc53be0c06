"""``biplan calibrate {trilinear,linear} DATA_DIR --out law.toml``: fold laws from CFT specimens.

Reads every ``*.csv`` in DATA_DIR (one specimen each, format in :mod:`biplan.calibration.files`),
computes the median ± 1 SD band, fits the law at the fold-field level (specimen geometry from
``--radius``/``--n-folds`` or ``--config``, default R = 2 mm, one fold), bootstraps confidence
intervals over specimens and writes

* ``--out`` (``law.toml``): a ``[laws.circular]`` / ``[laws.helical]`` block that drops into a
  tube config, with the intervals and residuals as comments;
* ``--figure`` (default: ``--out`` with ``.png``): specimens, median ± SD band, fitted law;
* ``--table`` (default: ``--out`` with ``.csv``): the band and the fit on the common grid —
  displacement [mm], phase, count, median [N], std [N], fitted [N], residual [N].

Statistics that mean little (bootstrap intervals from fewer than five specimens, a linear law
fitted to bistable data, a poor fit: :attr:`Calibration.caveats`) are printed as warnings on
stderr, also with ``--quiet``, and written as ``# warning:`` comments into ``--out``.

Options given on the command line override those of ``--config`` (schema:
:func:`biplan.calibration.files.read_calibration_config`).
"""

from __future__ import annotations

import csv
import enum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from biplan.cli._checks import figure_suffixes, options_named, output_file

if TYPE_CHECKING:
    from biplan.calibration.calibrate import Calibration

__all__ = ["app", "linear", "trilinear", "write_table"]


app = typer.Typer(
    help="Calibrate fold laws from measured Circular Folded Tube curves (CSV, one per specimen).",
    no_args_is_help=True,
)


class FoldSet(enum.StrEnum):
    """The fold set whose law block is written."""

    circular = "circular"
    helical = "helical"


class BreakpointChoice(enum.StrEnum):
    """Trilinear breakpoints: the measured stability limits, or fitted."""

    measured = "measured"
    free = "free"


DataDir = Annotated[
    Path,
    typer.Argument(
        help="Directory of specimen CSV files.", exists=True, file_okay=False, show_default=False
    ),
]
Out = Annotated[Path, typer.Option("--out", "-o", help="TOML law block to write.")]
Figure = Annotated[
    Path | None, typer.Option("--figure", help="Figure to write (default: --out with .png).")
]
TablePath = Annotated[
    Path | None, typer.Option("--table", help="CSV of band and fit (default: --out with .csv).")
]
Config = Annotated[
    Path | None,
    typer.Option(
        "--config",
        help="TOML with tables geometry (radius, n_folds), columns and units.",
        exists=True,
    ),
]
Radius = Annotated[float | None, typer.Option("--radius", help="CFT radius R in mm (default 2).")]
NFolds = Annotated[
    int | None, typer.Option("--n-folds", help="Circular folds in series (default 1).", min=1)
]
Bootstrap = Annotated[int, typer.Option("--bootstrap", help="Bootstrap resamples.", min=0)]
Confidence = Annotated[float, typer.Option("--confidence", help="Interval level in (0, 1).")]
Seed = Annotated[int, typer.Option("--seed", help="Bootstrap seed.")]
Column = Annotated[str | None, typer.Option(help="Column name (default: the quantity's name).")]
Unit = Annotated[str | None, typer.Option(help="Unit of the column.")]
MinPoints = Annotated[int | None, typer.Option("--min-points", help="Minimum rows per segment.")]
Quiet = Annotated[bool, typer.Option("--quiet", "-q", help="Only the summary line.")]
#: Parameters of SpecimenFormat → the options they come from (also used by ``validate``).
FORMAT_OPTIONS = {
    **{f"{q} column": f"--{q}-column" for q in ("displacement", "force", "pressure", "segment")},
    **{f"{q}_unit": f"--{q}-unit" for q in ("displacement", "force", "pressure")},
    "min_points": "--min-points",
}
#: Parameters of CftGeometry and CalibrationOptions → the options they come from.
FIT_OPTIONS = {
    "radius": "--radius",
    "n_folds": "--n-folds",
    "n_bootstrap": "--bootstrap",
    "confidence": "--confidence",
    "seed": "--seed",
}


def write_table(result: Calibration, file: Path) -> None:
    """Write the band and the fit on the common grid (columns: module docstring)."""
    band = result.band
    u = band.displacement
    fitted = np.interp(u, result.fit.displacement, result.fit.fitted, left=np.nan, right=np.nan)
    on_fit = np.isin(u, result.fit.displacement)
    with file.open("w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["displacement", "phase", "count", "median", "std", "fitted", "residual"])
        for k in range(u.size):
            res = fitted[k] - band.median[k] if on_fit[k] else np.nan
            out.writerow(
                [f"{u[k]:.8g}", band.labels[band.phase[k]], int(band.count[k])]
                + [f"{x:.8g}" for x in (band.median[k], band.std[k], fitted[k], res)]
            )


def _summary(result: Calibration) -> Table:
    opts = result.options
    table = Table(
        title=f"Fitted law ({opts.confidence:.0%} bootstrap intervals)",
        title_style="bold",
    )
    for name in ("parameter", "value", "low", "high", "unit"):
        table.add_column(name, justify="right" if name in ("value", "low", "high") else "left")
    for e in result.estimates:
        if e.name == "offset" and not opts.offset:
            continue
        table.add_row(e.name, f"{e.value:.5g}", f"{e.low:.5g}", f"{e.high:.5g}", escape(e.unit))
    return table


def _figure(result: Calibration, file: Path) -> None:
    from biplan.plot import calibration_band
    from biplan.plot.files import figure_file
    from biplan.plot.response import COLUMN_FIGSIZE

    with figure_file(file, figsize=COLUMN_FIGSIZE) as (_, ax):
        calibration_band(result, ax=ax)


def format_changes(options: dict[str, object]) -> dict[str, object]:
    """SpecimenFormat fields from a command's column/unit options (its ``locals()``)."""
    return {
        **{q: options[f"{q}_column"] for q in ("displacement", "force", "pressure", "segment")},
        **{f"{q}_unit": options[f"{q}_unit"] for q in ("displacement", "force", "pressure")},
        "min_points": options["min_points"],
    }


def _run(
    kind: str,
    data_dir: Path,
    out: Path,
    figure: Path | None,
    table_path: Path | None,
    config: Path | None,
    fold_set: str,
    quiet: bool,
    geometry_changes: dict,
    format_changes: dict,
    options_changes: dict,
) -> None:
    from dataclasses import replace

    from biplan.calibration.calibrate import (
        CalibrationOptions,
        calibrate_linear,
        calibrate_trilinear,
    )
    from biplan.calibration.files import (
        SpecimenFormat,
        calibration_toml,
        read_calibration_config,
        read_specimens,
        with_overrides,
    )
    from biplan.calibration.fits import CftGeometry

    console = Console(highlight=False)
    output_file(out)
    figure = figure or out.with_suffix(".png")
    table_path = table_path or out.with_suffix(".csv")
    output_file(figure, "--figure", suffixes=figure_suffixes())
    output_file(table_path, "--table")
    geometry, fmt = (CftGeometry(), SpecimenFormat())
    if config is not None:
        geometry, fmt = read_calibration_config(config)
    with options_named({**FORMAT_OPTIONS, **FIT_OPTIONS}):
        changes = {k: v for k, v in geometry_changes.items() if v is not None}
        geometry = replace(geometry, **changes)
        fmt = with_overrides(fmt, **format_changes)
        options = CalibrationOptions(**options_changes)
    specimens = read_specimens(data_dir, fmt, radius=geometry.radius)
    run = calibrate_trilinear if kind == "trilinear" else calibrate_linear
    result = run(specimens, geometry, options)
    text = calibration_toml(result, fold_set, source=str(data_dir))
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(text, encoding="utf-8")
        write_table(result, table_path)
        _figure(result, figure)
    except OSError as err:
        raise typer.BadParameter(f"cannot write {out}: {err}", param_hint="--out") from None
    if not quiet:
        console.print(_summary(result))
        console.print(text, markup=False, soft_wrap=True)
    warn = Console(stderr=True, highlight=False)
    for caveat in result.caveats:  # also with --quiet
        warn.print(f"[yellow]warning:[/] {escape(caveat.message)}", soft_wrap=True)
    n = result.band.n_specimens
    console.print(
        f"{kind} law from {n} specimens, RMS residual {result.fit.rms:.4g} N; "
        f"wrote {escape(str(out))}, {escape(str(figure))}, {escape(str(table_path))}",
        soft_wrap=True,
    )


@app.command("trilinear")
def trilinear(
    data_dir: DataDir,
    out: Out = Path("law.toml"),
    figure: Figure = None,
    table: TablePath = None,
    config: Config = None,
    radius: Radius = None,
    n_folds: NFolds = None,
    breakpoints: Annotated[
        BreakpointChoice,
        typer.Option("--breakpoints", help="At the measured stability limits, or fitted."),
    ] = BreakpointChoice.measured,
    fold_set: Annotated[
        FoldSet, typer.Option("--fold-set", help="Fold set of the law block.")
    ] = FoldSet.circular,
    bootstrap: Bootstrap = 200,
    confidence: Confidence = 0.95,
    seed: Seed = 0,
    displacement_column: Column = None,
    force_column: Column = None,
    pressure_column: Column = None,
    segment_column: Column = None,
    displacement_unit: Unit = None,
    force_unit: Unit = None,
    pressure_unit: Unit = None,
    min_points: MinPoints = None,
    quiet: Quiet = False,
) -> None:
    """Fit a trilinear (bistable) law to two-phase CFT specimens; write a TOML law block."""
    options = dict(locals())
    _run(
        "trilinear",
        data_dir,
        out,
        figure,
        table,
        config,
        fold_set.value,
        quiet,
        {"radius": radius, "n_folds": n_folds},
        format_changes(options),
        {
            "breakpoints": breakpoints.value,
            "n_bootstrap": bootstrap,
            "confidence": confidence,
            "seed": seed,
        },
    )


@app.command("linear")
def linear(
    data_dir: DataDir,
    out: Out = Path("law.toml"),
    figure: Figure = None,
    table: TablePath = None,
    config: Config = None,
    radius: Radius = None,
    n_folds: NFolds = None,
    offset: Annotated[
        bool, typer.Option("--offset", help="Fit a free force offset (default: through 0).")
    ] = False,
    fold_set: Annotated[
        FoldSet, typer.Option("--fold-set", help="Fold set of the law block.")
    ] = FoldSet.helical,
    bootstrap: Bootstrap = 200,
    confidence: Confidence = 0.95,
    seed: Seed = 0,
    displacement_column: Column = None,
    force_column: Column = None,
    pressure_column: Column = None,
    segment_column: Column = None,
    displacement_unit: Unit = None,
    force_unit: Unit = None,
    pressure_unit: Unit = None,
    min_points: MinPoints = None,
    quiet: Quiet = False,
) -> None:
    """Fit a linear law to CFT specimens; write a TOML law block (default: helical folds)."""
    options = dict(locals())
    _run(
        "linear",
        data_dir,
        out,
        figure,
        table,
        config,
        fold_set.value,
        quiet,
        {"radius": radius, "n_folds": n_folds},
        format_changes(options),
        {"offset": offset, "n_bootstrap": bootstrap, "confidence": confidence, "seed": seed},
    )
