"""``biplan plot RESULT --kind KIND --out FILE``: a picture of any result file.

RESULT is a netCDF file written by the other commands: a path (``kind = "path"``, dim
``step``), a trajectory (``"trajectory"``, dim ``time``), a stable-branch sweep (``"stable-branch
sweep"``, dim ``step``) or a state catalogue (``"states"``, dim ``state``); its ``config``
attribute rebuilds the model. Kinds:

* ``response`` — force against load-point displacement (unstable stretches dashed, snaps of a
  stable-branch sweep dotted);
* ``development`` — the planar development of one state (``--step``, default the last);
* ``tube`` — the 3D tube of one state; with ``--out`` ending in ``.vtu`` the state, and with
  ``.pvd`` the whole series (every ``--stride``-th state), are exported for ParaView instead;
* ``animation`` — GIF or MP4 of a path, trajectory or sweep (development, tube, F–U marker);
* ``gallery`` — 3D thumbnails of all states of a catalogue, in hierarchy order;
* ``energy``, ``eigenvalue``, ``phases`` — energy by fold set, smallest eigenvalue and open
  fraction of every fold along a path, trajectory or sweep (a stable-branch sweep's phase map
  shows its folds snapping open one by one).

A kind that does not apply to the file (``response`` of a state catalogue, any kind of a map,
which ``biplan map plot`` draws) is refused after the file is read and before anything is
drawn; the message names the kinds that apply to it (:func:`kinds_for`).

Static figures are written in the format of the ``--out`` suffix (PNG, PDF, SVG, … — every
format matplotlib writes); animations as ``.gif`` or ``.mp4``. A file name without a suffix,
or with one the kind cannot be written as, is refused (the message lists the valid ones), as
are an output location that cannot be written and a non-finite ``--elev``, ``--azim``,
``--fps`` or ``--dpi``, before the result is read.
"""

from __future__ import annotations

import enum
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Annotated, Any, cast

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape

from biplan._errors import ConfigError, check_finite
from biplan.cli._checks import figure_suffixes, output_file

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from biplan.model.assembly import Model

__all__ = ["Kind", "kinds_for", "plot", "suffixes"]


class Kind(enum.StrEnum):
    """What ``biplan plot`` draws."""

    response = "response"
    development = "development"
    tube = "tube"
    animation = "animation"
    gallery = "gallery"
    energy = "energy"
    eigenvalue = "eigenvalue"
    phases = "phases"


class ColorBy(enum.StrEnum):
    """Fold colouring."""

    elongation = "elongation"
    phase = "phase"


def suffixes(kind: Kind) -> frozenset[str]:
    """The ``--out`` suffixes (lower case, with the dot) a kind can be written as."""
    if kind is Kind.animation:
        return frozenset((".gif", ".mp4"))
    static = figure_suffixes()
    return static | {".vtu", ".pvd"} if kind is Kind.tube else static


def _load(file: Path) -> Any:
    """The result dataset of ``file``; unreadable files are a usage error."""
    from biplan.io.results import load_result

    try:
        return load_result(file)
    except (OSError, ValueError) as err:
        raise typer.BadParameter(f"cannot read {file}: {err}", param_hint="RESULT") from None


def _model(dataset: Any) -> Model:
    from biplan.io.results import model_of

    return model_of(dataset)


def kinds_for(dataset: Any) -> tuple[Kind, ...]:
    """The kinds that apply to a result dataset (:func:`~biplan.io.results.result_kind`):
    every kind for a path, trajectory or stable-branch sweep; development, tube and gallery for
    a state catalogue; none for anything else (a map, a hierarchy)."""
    from biplan.io.results import ResultKind, result_kind

    found = result_kind(dataset)
    if found in (ResultKind.path, ResultKind.trajectory, ResultKind.sweep):
        return tuple(k for k in Kind if k is not Kind.gallery)
    if found is ResultKind.states:
        return (Kind.development, Kind.tube, Kind.gallery)
    return ()


def _check_kind(dataset: Any, kind: Kind, file: Path) -> None:
    """Refuse a ``--kind`` that does not apply to ``dataset``, naming those that do."""
    from biplan.io.results import describe_result

    kinds = kinds_for(dataset)
    if kind in kinds:
        return
    what = f"{describe_result(dataset)} ({file})"
    if kinds:
        valid = f"one of {', '.join(k.value for k in kinds)} for {what}"
    elif "quantity" in dataset.attrs:
        valid = f"nothing `biplan plot` draws for {what}: `biplan map plot` draws a map"
    else:
        valid = f"nothing `biplan plot` draws for {what}"
    raise ConfigError("--kind", kind.value, valid)


def _root(ax: Any) -> Figure:
    """The figure an Axes belongs to."""
    return cast("Figure", ax.get_figure(root=True))


def _state(dataset: Any, step: int) -> np.ndarray:
    q = np.asarray(dataset["q"].values, dtype=float)
    if not -len(q) <= step < len(q):
        raise typer.BadParameter(f"{step} outside 0..{len(q) - 1}", param_hint="--step")
    return q[step]


def _figure(dataset: Any, kind: Kind, step: int, color_by: str, guides: bool, view: dict) -> Figure:
    from biplan import plot
    from biplan.plot import diagnostics
    from biplan.plot.gallery import gallery

    if kind is Kind.gallery:
        return gallery(dataset, _model(dataset), color_by=color_by, **view)
    if kind in (Kind.development, Kind.tube):
        model = _model(dataset)
        q = _state(dataset, step)
        if kind is Kind.development:
            return _root(plot.development(model, q, color_by=color_by, guides=guides))
        return _root(plot.cylinder(model, q, color_by=color_by, colorbar=True, **view))
    if kind is Kind.response:
        n = dataset["force"].size
        stable = dataset["stable"].values if "stable" in dataset else np.ones(n)
        switched = dataset["switched"].values if "switched" in dataset else np.zeros(n)
        # under pressure control the curve shows the controlled pressure [kPa], as respond's
        pressure = dataset.attrs.get("control") == "pressure" and "load_parameter" in dataset
        curve = SimpleNamespace(
            displacement=dataset["displacement"].values,
            force=dataset["load_parameter" if pressure else "force"].values,
            stable=np.asarray(stable, dtype=bool),
            switched=np.asarray(switched, dtype=bool),
        )
        if "limit_point" in dataset:
            curve.limit_point = np.asarray(dataset["limit_point"].values, dtype=bool)
        ax = plot.force_displacement(cast("Any", curve))
        if pressure:
            unit = dataset["load_parameter"].attrs.get("units", "kPa")
            ax.set_ylabel(f"pressure $p$ [{unit}]")
        return _root(ax)
    draw = {
        Kind.energy: diagnostics.energy_by_fold_set,
        Kind.eigenvalue: diagnostics.min_eigenvalue,
        Kind.phases: diagnostics.phase_fractions,
    }[kind]
    return _root(draw(dataset))


def plot(
    result: Annotated[
        Path,
        typer.Argument(
            help="Result file (netCDF) of a path, trajectory, sweep or state catalogue.",
            exists=True,
            dir_okay=False,
            show_default=False,
        ),
    ],
    kind: Annotated[Kind, typer.Option("--kind", "-k", help="What to draw.")],
    out: Annotated[
        Path,
        typer.Option(
            "--out", "-o", help="Output file; its suffix picks the format (.png, .gif, .mp4, .vtu)."
        ),
    ],
    step: Annotated[
        int, typer.Option("--step", "-s", help="State drawn by development/tube (-1: last).")
    ] = -1,
    color_by: Annotated[
        ColorBy, typer.Option("--color-by", help="Fold colouring.")
    ] = ColorBy.elongation,
    guides: Annotated[
        bool, typer.Option("--guides", help="development: draw guides and rotation centres.")
    ] = False,
    fps: Annotated[float, typer.Option("--fps", min=0.1, help="animation: frames/s.")] = 15.0,
    stride: Annotated[
        int, typer.Option("--stride", min=1, help="animation, .pvd: every n-th saved step.")
    ] = 1,
    dpi: Annotated[
        float | None,
        typer.Option("--dpi", min=10, help="Dots per inch; default 300 (animation: 100)."),
    ] = None,
    elev: Annotated[float, typer.Option("--elev", help="3D view elevation in degrees.")] = 20.0,
    azim: Annotated[float, typer.Option("--azim", help="3D view azimuth in degrees.")] = -60.0,
) -> None:
    """Draw a result file: response, development, tube, animation, gallery, diagnostics."""
    from biplan.plot.files import pyplot

    pyplot()  # every figure of this command goes to a file
    output_file(out, suffixes=suffixes(kind))
    view = {"elev": check_finite("--elev", elev), "azim": check_finite("--azim", azim)}
    check_finite("--fps", fps)
    if dpi is not None:
        check_finite("--dpi", dpi)
    dataset = _load(result)
    _check_kind(dataset, kind, result)
    suffix = out.suffix.lower()
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        if kind is Kind.animation:
            from biplan.plot.animation import animate

            model = _model(dataset)
            animate(
                dataset,
                model,
                out,
                fps=fps,
                stride=stride,
                dpi=dpi or 100,
                color_by=color_by.value,
                elev=elev,
                azim=azim,
            )
        elif kind is Kind.tube and suffix in (".vtu", ".pvd"):
            from biplan.io.vtk import export_result

            _state(dataset, step)
            export_result(dataset, _model(dataset), out, stride=stride, index=step)
        else:
            from biplan.plot.files import DPI, save

            save(_figure(dataset, kind, step, color_by.value, guides, view), out, dpi=dpi or DPI)
    except OSError as err:
        raise typer.BadParameter(f"cannot write {out}: {err}", param_hint="--out") from None
    Console(highlight=False).print(f"wrote {escape(str(out))}")
