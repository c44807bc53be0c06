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
:func:`biplan.calibration.config.read_calibration_config`).
"""

from __future__ import annotations

import enum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape
from rich.table import Table

from biplan.cli._checks import figure_suffixes, options_named, output_file

if TYPE_CHECKING:
    from biplan.calibration.calibrate import Calibration

__all__ = ["FIT_OPTIONS", "FORMAT_OPTIONS", "app", "format_changes", "linear", "trilinear"]


app = typer.Typer(
    help="Calibrate fold laws from measured Circular Folded Tube curves (CSV, one per specimen).",
    no_args_is_help=True,
)


class BreakpointChoice(enum.StrEnum):
    """Trilinear breakpoints (:class:`~biplan.calibration.calibrate.Breakpoints`): the measured
    stability limits, or fitted."""

    measured = "measured"
    free = "free"


class FoldSet(enum.StrEnum):
    """The fold set whose law block is written."""

    circular = "circular"
    helical = "helical"


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
#: Fields of CalibrationOptions both commands set → their Python parameter names.
_BOOTSTRAP = {"n_bootstrap": "bootstrap", "confidence": "confidence", "seed": "seed"}


def _summary(result: Calibration) -> Table:
    """The estimates and their bootstrap intervals as a Rich table."""
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


def format_changes(options: dict[str, object]) -> dict[str, object]:
    """SpecimenFormat fields from a command's column/unit options (its ``locals()``)."""
    return {
        **{q: options[f"{q}_column"] for q in ("displacement", "force", "pressure", "segment")},
        **{f"{q}_unit": options[f"{q}_unit"] for q in ("displacement", "force", "pressure")},
        "min_points": options["min_points"],
    }


def _run(kind: str, options: dict[str, Any], fit: dict[str, object]) -> None:
    """Check the output files, set up and run the calibration, write the law block, table and
    figure, then print the summary (unless ``--quiet``), the caveats and the files written.
    ``options``: the command's ``locals()``; ``fit``: its own fields of
    :class:`~biplan.calibration.calibrate.CalibrationOptions`."""
    from biplan.calibration.runs import (
        LawKind,
        calibrate_directory,
        calibration_setup,
        write_law,
        write_table,
    )
    from biplan.plot.calibration import write_calibration_band

    out, data_dir, quiet = options["out"], options["data_dir"], options["quiet"]
    output_file(out)
    figure = options["figure"] or out.with_suffix(".png")
    table_path = options["table"] or out.with_suffix(".csv")
    output_file(figure, "--figure", suffixes=figure_suffixes())
    output_file(table_path, "--table")
    with options_named({**FORMAT_OPTIONS, **FIT_OPTIONS}):
        setup = calibration_setup(
            options["config"],
            geometry={"radius": options["radius"], "n_folds": options["n_folds"]},
            fmt=format_changes(options),
            options={**fit, **{k: options[o] for k, o in _BOOTSTRAP.items()}},
        )
    result = calibrate_directory(LawKind(kind), data_dir, setup)
    try:
        text = write_law(result, options["fold_set"].value, out, source=str(data_dir))
        write_table(result, table_path)
        write_calibration_band(result, figure)
    except OSError as err:
        raise typer.BadParameter(f"cannot write {out}: {err}", param_hint="--out") from None
    console = Console(highlight=False)
    if not quiet:
        console.print(_summary(result))
        console.print(text, markup=False, soft_wrap=True)
    warn = Console(stderr=True, highlight=False)
    for caveat in result.caveats:  # also with --quiet
        warn.print(f"[yellow]warning:[/] {escape(caveat.message)}", soft_wrap=True)
    console.print(
        f"{kind} law from {result.band.n_specimens} specimens, RMS residual "
        f"{result.fit.rms:.4g} N; wrote {escape(str(out))}, {escape(str(figure))}, "
        f"{escape(str(table_path))}",
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
    _run("trilinear", dict(locals()), {"breakpoints": breakpoints.value})


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
    _run("linear", dict(locals()), {"offset": offset})
