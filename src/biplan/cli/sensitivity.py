"""``biplan sensitivity CONFIG (--force F | --displacement U | --limit-point) --out DIR``.

Design sensitivities of one state of the tube by implicit differentiation of its KKT system
(:mod:`biplan.analysis.sensitivity.equilibrium`): with ``--force F`` the state a force-controlled
test
reaches at F from the relaxed reference (the stable response, snaps included), with
``--displacement U`` the state of the stable-branch displacement sweep at U
(:func:`~biplan.analysis.response.reached.reached_state`); with ``--limit-point`` the first
instability
under force control, located (:mod:`biplan.analysis.sensitivity.limit_point`), and the derivatives
of its
force F* and displacement U*.

Writes into DIR:

* ``sensitivity.csv`` — one row per (observable, parameter): ``observable, parameter, value,
  unit, elasticity, observable_value, parameter_value`` (``value`` = ∂y/∂p in ``unit``,
  ``elasticity`` = (p / y) ∂y/∂p);
* ``sensitivity.png`` — one panel per observable: bars of the elasticities.

Parameters are named as in the TOML configuration (``geometry.radius``,
``laws.circular.stiffness[1]``, …; :mod:`biplan.analysis.sensitivity.parameters`); ``--angle b``
varies
b instead of β (R and l then at fixed b); ``--per-fold`` names every fold's law separately.

Every option is checked before the tube is loaded: exactly one of ``--force``,
``--displacement``, ``--limit-point``; F and U finite with |F| ≤ :data:`MAX_FORCE` N and
|U| ≤ :data:`MAX_DISPLACEMENT` mm; an output location that can be written. A failed solve
(the response ends short of F, a sweep step fails, no limit point) is reported in one line
saying where and why, exit status 2.
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

from biplan._errors import ConfigError, check_range
from biplan.cli._checks import output_directory

if TYPE_CHECKING:
    from biplan.analysis.sensitivity.equilibrium import Sensitivity
    from biplan.model.assembly import Model

__all__ = ["MAX_DISPLACEMENT", "MAX_FORCE", "sensitivity"]

#: Largest |F| [N] (the bound of the first-instability search).
MAX_FORCE = 100.0
#: Largest |U| [mm].
MAX_DISPLACEMENT = 100.0
#: The files written into --out.
OUTPUT_FILES = ("sensitivity.csv", "sensitivity.png")


class AngleName(enum.StrEnum):
    helical_angle = "helical_angle"
    b = "b"


def sensitivity(
    config: Annotated[Path, typer.Argument(help="Tube configuration (TOML).", exists=True)],
    out: Annotated[Path, typer.Option("--out", help="Output directory.")] = Path("sensitivity"),
    force: Annotated[
        float | None, typer.Option(help=r"State at this end force \[N] (force control).")
    ] = None,
    displacement: Annotated[
        float | None,
        typer.Option(help=r"State at this load-point displacement \[mm] (displacement control)."),
    ] = None,
    limit_point: Annotated[
        bool,
        typer.Option("--limit-point", help="The first instability under force control: F* and U*."),
    ] = False,
    angle: Annotated[
        AngleName, typer.Option(help="Crease-angle parameter: helical_angle (β) or b.")
    ] = AngleName.helical_angle,
    per_fold: Annotated[
        bool, typer.Option("--per-fold", help="Every fold's law as its own parameters.")
    ] = False,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress or summary.")] = False,
) -> None:
    """Design sensitivities of a state (or of the first limit point) by implicit
    differentiation; writes sensitivity.csv and sensitivity.png."""
    import biplan

    _check_request(force, displacement, limit_point)
    output_directory(out, files=OUTPUT_FILES)
    console = Console(quiet=quiet or not sys.stdout.isatty(), highlight=False)
    model = biplan.Model(biplan.load_config(config))
    with console.status(f"[bold]{model.tube.name}[/]: solving…"):
        result = _run(model, force, displacement, limit_point, angle.value, per_fold)
    out.mkdir(parents=True, exist_ok=True)
    result.to_dataframe().to_csv(out / "sensitivity.csv", index=False)
    _figure(result, out / "sensitivity.png")
    if not quiet:
        Console(highlight=False).print(_summary(result, out))


def _check_request(force: float | None, displacement: float | None, limit_point: bool) -> None:
    """Exactly one state, and its value in range."""
    chosen = [n for n, v in (("--force", force), ("--displacement", displacement)) if v is not None]
    chosen += ["--limit-point"] if limit_point else []
    if len(chosen) != 1:
        raise ConfigError(
            "state", " ".join(chosen) or "none", "exactly one of --force, --displacement, "
            "--limit-point",
        )  # fmt: skip
    if force is not None:
        check_range("--force", force, low=-MAX_FORCE, high=MAX_FORCE, low_open=False,
                    high_open=False, unit="N")  # fmt: skip
    if displacement is not None:
        check_range("--displacement", displacement, low=-MAX_DISPLACEMENT,
                    high=MAX_DISPLACEMENT, low_open=False, high_open=False, unit="mm")  # fmt: skip


def _run(
    model: Model,
    force: float | None,
    displacement: float | None,
    limit_point: bool,
    angle: str,
    per_fold: bool,
) -> Sensitivity:
    """The sensitivities asked for."""
    from biplan import Load
    from biplan.analysis.response.reached import reached_state
    from biplan.analysis.sensitivity.equilibrium import sensitivity as state_sensitivity
    from biplan.analysis.sensitivity.limit_point import limit_point_sensitivity, locate_limit_point

    if limit_point:
        found = locate_limit_point(model)
        return limit_point_sensitivity(model, found, angle=angle, per_fold=per_fold)
    load = Load.of_force(force) if force is not None else Load.of_displacement(displacement or 0.0)
    state = reached_state(model, load)
    return state_sensitivity(model, state, angle=angle, per_fold=per_fold)


def _figure(result: Sensitivity, file: Path) -> None:
    """sensitivity.png: one panel of elasticity bars per observable."""
    from biplan.plot.files import figure_file
    from biplan.plot.response import COLUMN_FIGSIZE
    from biplan.plot.sensitivity import elasticities

    n = len(result.observables)
    cols = min(n, 3)
    rows = math.ceil(n / cols)
    height = max(COLUMN_FIGSIZE[1], 0.18 * len(result.parameters) + 0.8)
    size = (COLUMN_FIGSIZE[0] * cols, height * rows)
    with figure_file(file, dpi=200, nrows=rows, ncols=cols, figsize=size, squeeze=False) as (
        _,
        axes,
    ):
        for k, ax in enumerate(axes.ravel()):
            if k < n:
                elasticities(result, observable=result.observables[k], ax=ax)
            else:
                ax.set_visible(False)


def _summary(result: Sensitivity, out: Path) -> str:
    """The largest elasticity of each observable, and the files."""
    lines = []
    el = result.elasticities
    for i, obs in enumerate(result.observables):
        if np.isnan(el[i]).all():  # y is zero: no relative change
            lines.append(f"{obs.value} = {result.values[i]:.6g} {obs.unit}: zero here, no "
                         "elasticity (sensitivity.csv holds dy/dp)")  # fmt: skip
            continue
        j = int(np.nanargmax(np.abs(el[i])))
        lines.append(
            f"{obs.value} = {result.values[i]:.6g} {obs.unit}: most sensitive to "
            f"{result.parameters[j].name} (elasticity {el[i, j]:+.3g})"
        )
    notes = [f"note: {why}" for why in result.left_out]
    return "\n".join([*lines, *notes, f"wrote {out}/sensitivity.{{csv,png}}"])
