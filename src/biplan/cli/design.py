"""``biplan design CONFIG --target T [--target T …] --vary NAME [--vary NAME …] --out DIR``.

Inverse design (:func:`~biplan.analysis.sensitivity.inverse.inverse_design`): varies the named
design
parameters of the tube in CONFIG, within their valid ranges, until its response meets every
target. A target is ``OBSERVABLE[/l0]=VALUE[@F=FORCE | @U=DISPLACEMENT | @state=LABEL]``
(``u_z/l0=0.06@F=1.6``, ``u_r=-0.2@U=3``, ``limit_force=1.5``, ``u_z/l0=0.9@state=66`` for a
named stable state of a tube with bistable folds;
:class:`~biplan.analysis.sensitivity.inverse.Target`); a
parameter is named as in the configuration (``laws.helical.stiffness``, ``geometry.helical_angle``,
``laws.circular.transitions[0]``, …; :mod:`biplan.analysis.sensitivity.parameters`).

Writes into DIR:

* ``design.toml`` — the best design found, a complete configuration;
* ``design.csv`` — one row per target: ``target, wanted, achieved, met``;
* ``design_sensitivity.csv`` — ∂y/∂p of every target's observable with respect to every varied
  parameter in that design: ``target, parameter, value``.

Exits with status 1 (after writing the files) when a target is not met. The targets, the
parameter names, ``--starts`` (1 to :data:`MAX_STARTS`) and ``--tolerance`` (in (0, 0.1)) are
checked before anything is solved; a malformed or unknown one is a one-line error, status 2.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console

from biplan._errors import ConfigError, check_integer, check_range
from biplan.cli._checks import options_named, output_directory

if TYPE_CHECKING:
    from biplan.analysis.sensitivity.inverse import DesignResult

__all__ = ["EXIT_NOT_MET", "MAX_STARTS", "design"]

#: Exit status when a target is not met (the best design is written).
EXIT_NOT_MET = 1
#: Most starts.
MAX_STARTS = 20
#: The files written into --out.
OUTPUT_FILES = ("design.toml", "design.csv", "design_sensitivity.csv")


def design(
    config: Annotated[
        Path, typer.Argument(help="Starting tube configuration (TOML).", exists=True)
    ],
    target: Annotated[
        list[str],
        typer.Option(
            help="OBSERVABLE\\[/l0]=VALUE\\[@F=FORCE|@U=DISPLACEMENT|@state=LABEL] (repeatable)."
        ),
    ],
    vary: Annotated[
        list[str], typer.Option(help="Design parameter to vary, e.g. laws.helical.stiffness.")
    ],
    out: Annotated[Path, typer.Option("--out", help="Output directory.")] = Path("design"),
    starts: Annotated[int, typer.Option(help="Most starts (the given design first).")] = 3,
    tolerance: Annotated[float, typer.Option(help="Relative tolerance of a met target.")] = 1e-6,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress or summary.")] = False,
) -> None:
    """Find the design parameters that meet the targets; writes design.toml, design.csv and
    design_sensitivity.csv."""
    import biplan
    from biplan.analysis.sensitivity.inverse import Target, check_targets, inverse_design
    from biplan.analysis.sensitivity.parameters import design_parameters
    from biplan.io.config import dump_config

    check_integer("--starts", starts, low=1, high=MAX_STARTS)
    check_range("--tolerance", tolerance, low=0.0, high=0.1)
    with options_named({"target": "--target"}):
        targets = tuple(Target.parse(t) for t in target)
    output_directory(out, files=OUTPUT_FILES)
    model = biplan.Model(biplan.load_config(config))
    with options_named({"target": "--target"}):
        check_targets(model.tube, targets)
    names = design_parameters(model, biplan.Load.of_force(0.0)).names[:-1]
    for k, name in enumerate(vary):
        if name not in names:
            raise ConfigError("--vary", name, f"one of {', '.join(names)}")
        if name in vary[:k]:
            raise ConfigError("--vary", name, "given once")
    console = Console(quiet=quiet or not sys.stdout.isatty(), highlight=False)
    with console.status(f"[bold]{model.tube.name}[/]: designing…"):
        result = inverse_design(model, targets, tuple(vary), starts=starts, tolerance=tolerance)
    out.mkdir(parents=True, exist_ok=True)
    (out / "design.toml").write_text(dump_config(result.tube), encoding="utf-8")
    lines = ["target,wanted,achieved,met"]
    lines += [
        f'"{t.label}",{float(t.value)!r},{float(y)!r},{bool(ok)}'
        for t, y, ok in zip(result.targets, result.achieved, result.met, strict=True)
    ]
    (out / "design.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    rows = ["target,parameter,value"]
    rows += [
        f'"{t.label}",{name},{float(result.jacobian[i, j])!r}'
        for i, t in enumerate(result.targets)
        for j, name in enumerate(result.names)
    ]
    (out / "design_sensitivity.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    if not quiet:
        Console(highlight=False).print(_report(result, out))
    if not result.success:
        Console(stderr=True, highlight=False).print(
            f"[red]error:[/] {int((~result.met).sum())} of {len(result.targets)} targets not met "
            f"(best design written to {out}/design.toml): {result.message}",
            soft_wrap=True,
        )
        raise typer.Exit(EXIT_NOT_MET)


def _report(r: DesignResult, out: Path) -> str:
    """Targets reached, parameters found, evaluations."""
    lines = [
        f"{'met' if ok else 'NOT met'}: {t.label} (achieved {y:.8g})"
        for t, y, ok in zip(r.targets, r.achieved, r.met, strict=True)
    ]
    lines += [
        f"{name} = {v:.8g} (from {v0:.8g})"
        for name, v, v0 in zip(r.names, r.values, r.start, strict=True)
    ]
    lines.append(
        f"{r.iterations} evaluations, {r.starts} start(s); "
        f"wrote {out}/design.toml, design.csv, design_sensitivity.csv"
    )
    return "\n".join(lines)
