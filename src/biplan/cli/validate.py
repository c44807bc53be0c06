"""``biplan validate CONFIG MEASURED_DIR``: a design's prediction against measured specimens.

Reads the measured MFT specimens (every ``*.csv`` in MEASURED_DIR; pressure columns convert
with the tube's end area πR², R from CONFIG), computes their median ± 1 SD band, runs the
design CONFIG under displacement control
(:func:`~biplan.analysis.response.quasistatic.displacement_sweep`
from the relaxed reference, ``--steps`` steps up to ``--max-displacement``, default the largest
measured displacement; the MFT's end displacement is the load-point axial displacement),
overlays the predicted force–displacement curve on the band (paper Fig. 3 A.2) and reports the
RMS error and the displacement intervals where the prediction leaves the band. Writes into
``--out``:

* ``validation.png`` — specimens, median ± 1 SD band, prediction, points outside the band;
* ``validation.csv`` — per band grid point: displacement [mm], phase, count, median [N],
  std [N], predicted [N], residual [N], outside (1/0);
* ``prediction.csv`` — per sweep step: displacement [mm], force [N], stable (1/0).
"""

from __future__ import annotations

import contextlib
import csv
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape

from biplan._errors import check_range
from biplan.cli._checks import options_named, output_directory
from biplan.cli.calibrate import FORMAT_OPTIONS, Column, MinPoints, Quiet, Unit, format_changes

if TYPE_CHECKING:
    from biplan.analysis.response.quasistatic import QuasiStaticPath
    from biplan.calibration.validation import BandComparison

__all__ = ["summary", "validate"]


def _write_prediction(path: QuasiStaticPath, file: Path) -> None:
    with file.open("w", newline="") as fh:
        out = csv.writer(fh)
        out.writerow(["displacement", "force", "stable"])
        for u, f, s in zip(path.displacement, path.force, path.stable, strict=True):
            out.writerow([f"{u:.8g}", f"{f:.8g}", int(bool(s))])


def summary(result: BandComparison, path: QuasiStaticPath) -> list[str]:
    """Lines reporting the RMS error, the intervals outside the band and the phase-1 peaks."""
    band = result.band
    lines = [
        f"RMS error {result.rms:.4g} N over {result.n_compared} grid points; "
        f"{result.fraction_outside:.0%} of them outside the median ± 1 SD band."
    ]
    if result.intervals:
        spans = ", ".join(f"[{a:.3g}, {b:.3g}]" for a, b in result.intervals)
        lines.append(f"Prediction leaves the band at U = {spans} mm.")
    else:
        lines.append("Prediction stays inside the band wherever both exist.")
    (ua, fa) = band.limits[0, 1]
    from biplan.analysis.response.summary import phase_one_end

    stop = phase_one_end(path.force, path.stable, path.switched)
    if stop:
        k = int(np.argmax(path.force[:stop]))
        lines.append(
            f"Phase-1 peak: predicted {path.force[k]:.4g} N at U = {path.displacement[k]:.3g} mm; "
            f"measured instability (median) {fa:.4g} N at u = {ua:.3g} mm."
        )
    return lines


def _figure(result: BandComparison, file: Path) -> None:
    from biplan.plot import validation_band
    from biplan.plot.files import figure_file
    from biplan.plot.response import COLUMN_FIGSIZE

    with figure_file(file, figsize=COLUMN_FIGSIZE) as (_, ax):
        validation_band(result, ax=ax)


def validate(
    config: Annotated[
        Path,
        typer.Argument(help="TOML tube configuration.", exists=True, dir_okay=False),
    ],
    measured_dir: Annotated[
        Path,
        typer.Argument(help="Directory of measured specimen CSV files.", file_okay=False),
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output directory (created if missing).")
    ] = Path("biplan-validate"),
    steps: Annotated[int, typer.Option("--steps", "-n", min=2, help="Displacement steps.")] = 80,
    max_displacement: Annotated[
        float | None,
        typer.Option(
            "--max-displacement", help="Largest prescribed U in mm (default: the largest measured)."
        ),
    ] = None,
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
    """Run a design and compare its force–displacement curve with measured specimens."""
    options = dict(locals())
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn

    import biplan
    from biplan.analysis.response.quasistatic import displacement_sweep
    from biplan.calibration.band import band_statistics
    from biplan.calibration.config import with_overrides
    from biplan.calibration.files import SpecimenFormat, read_specimens
    from biplan.calibration.validation import compare_to_band, write_comparison

    console = Console(highlight=False)
    interactive = console.is_terminal and not quiet
    output_directory(out, files=("validation.png", "validation.csv", "prediction.csv"))
    if max_displacement is not None:
        check_range("--max-displacement", max_displacement, low=0.0, unit="mm")
    with options_named(FORMAT_OPTIONS):
        fmt = with_overrides(
            SpecimenFormat(),
            **format_changes(options),
        )
    tube = biplan.load_config(config)
    specimens = read_specimens(measured_dir, fmt, radius=tube.development.radius)
    band = band_statistics(specimens)
    top = max_displacement
    if top is None:
        top = max(float(sp.segments[-1].displacement[-1]) for sp in specimens)
    if not (np.isfinite(top) and top > 0):
        raise typer.BadParameter(f"must be > 0 mm, got {top}", param_hint="--max-displacement")
    model = biplan.Model(tube)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise typer.BadParameter(f"cannot create {out}: {err}", param_hint="--out") from None
    relaxing = "Relaxing the reference state (compiles on first use)…"
    with console.status(relaxing) if interactive else contextlib.nullcontext():
        ref = biplan.relaxed_reference(model, throw=True)
    targets = np.linspace(top / steps, top, steps)
    progress = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        console=console,
        transient=True,
        disable=not interactive,
    )
    with progress:
        task = progress.add_task("Sweeping U", total=steps)
        path = displacement_sweep(
            model, targets, start=ref, progress=lambda *_: progress.advance(task)
        )
    u = np.concatenate([[ref.displacement], path.displacement])
    f = np.concatenate([[ref.force], path.force])
    result = compare_to_band(band, u, f)
    files = [out / "validation.png", out / "validation.csv", out / "prediction.csv"]
    try:
        _figure(result, files[0])
        write_comparison(result, files[1])
        _write_prediction(path, files[2])
    except OSError as err:
        raise typer.BadParameter(f"cannot write into {out}: {err}", param_hint="--out") from None
    for line in summary(result, path):
        console.print(escape(line), soft_wrap=True)
    if not quiet:
        for file in files:
            console.print(f"wrote {escape(str(file))}")
