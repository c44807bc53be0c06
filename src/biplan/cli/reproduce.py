"""``biplan reproduce --out DIR [--quick]``: every panel the paper's models produce, and a report.

Runs the stages of :mod:`biplan.reproduction.stages` (Fig. 3, Fig. 4, the supplement's CFT
calibration and Movie S1, and the interactive pages of ``biplan explore`` beside the figures;
a stage that fails is recorded in the report with its error and the command goes on). Then
``REPRODUCTION.md``: every claim of :data:`biplan.reproduction.claims.CLAIMS` with our value, a
computed verdict and the reason, one table per figure, linking the figures
(:func:`biplan.reproduction.report.run_reproduction`).

``--quick`` runs coarse grids and short runs (minutes cold, each kernel compiles once; see
docs/reproduction.md); the default is the paper's resolution, with a progress bar.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.markup import escape

from biplan._errors import ConfigError
from biplan.cli._checks import output_directory

__all__ = ["TPC_SIGNS", "reproduce"]

#: Values of ``--tpc-sign`` (those of :class:`biplan.options.TpcSign`; the options module is
#: not imported here, it imports JAX).
TPC_SIGNS = ("geometric", "as_printed")


def reproduce(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output directory (created if missing).")
    ] = Path("reproduction"),
    quick: Annotated[
        bool, typer.Option("--quick", help="Coarse grids and short runs (minutes).")
    ] = False,
    measured: Annotated[
        Path | None,
        typer.Option(
            "--measured",
            help="Measured semi-bistable MFT specimens (CSV dir) for Fig. 3 A.2; "
            "default: a synthetic band.",
            exists=True,
            file_okay=False,
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    tpc_sign: Annotated[
        str,
        typer.Option(
            "--tpc-sign",
            help="Sign of a TPC's first field: geometric (MODEL §7) or as_printed (the SI's "
            "Eq. VC_w as printed; docs/fidelity.md).",
        ),
    ] = "geometric",
) -> None:
    """Regenerate the paper's figures (Fig. 3, Fig. 4, the supplement's distributions and
    CFT calibration, Movie S1) and write REPRODUCTION.md with a computed verdict per claim."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from biplan.reproduction.report import run_reproduction
    from biplan.reproduction.settings import Resolution
    from biplan.reproduction.stages import STAGES

    if tpc_sign not in TPC_SIGNS:
        raise ConfigError("--tpc-sign", tpc_sign, f"one of {', '.join(TPC_SIGNS)}")
    output_directory(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise typer.BadParameter(f"cannot create {out}: {err}", param_hint="--out") from None
    command = "biplan reproduce --out DIR" + (" --quick" if quick else "")
    if tpc_sign != "geometric":
        command += f" --tpc-sign {tpc_sign}"
    if measured is not None:
        command += f" --measured {measured}"
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=Console(stderr=True, highlight=False),
        disable=quiet or not sys.stderr.isatty(),
    )
    with progress:
        task = progress.add_task("reproducing", total=len(STAGES))
        started: list[str] = []

        def advance(description: str) -> None:
            if started:
                progress.advance(task)
            started.append(description)
            progress.update(task, description=description)

        done = run_reproduction(
            out,
            Resolution.QUICK if quick else Resolution.FULL,
            command=command,
            tpc_sign=tpc_sign,
            measured=measured,
            stages=STAGES,
            advance=advance,
        )
        progress.advance(task)
    Console(quiet=quiet, highlight=False).print(escape(done.summary()))
