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
drawn; the message names the kinds that apply to it (:func:`kinds_for`); so is a ``--step``
that is not a state of the file. The pictures are drawn by :mod:`biplan.plot.results`.

Static figures are written in the format of the ``--out`` suffix (PNG, PDF, SVG, … — every
format matplotlib writes); animations as ``.gif`` or ``.mp4``. A file name without a suffix,
or with one the kind cannot be written as, is refused (the message lists the valid ones), as
are an output location that cannot be written and a non-finite ``--elev``, ``--azim``,
``--fps`` or ``--dpi``, before the result is read.
"""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape

from biplan._errors import ConfigError, check_finite
from biplan.cli._checks import figure_suffixes, output_file

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


def _check_step(dataset: Any, step: int) -> None:
    """Refuse a ``--step`` that is not a state of ``dataset`` (from its end when negative)."""
    n = dataset["q"].shape[0]
    if not -n <= step < n:
        raise typer.BadParameter(f"{step} outside 0..{n - 1}", param_hint="--step")


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
    from biplan.plot.results import write_result

    pyplot()  # every figure of this command goes to a file
    output_file(out, suffixes=suffixes(kind))
    check_finite("--elev", elev)
    check_finite("--azim", azim)
    check_finite("--fps", fps)
    if dpi is not None:
        check_finite("--dpi", dpi)
    dataset = _load(result)
    _check_kind(dataset, kind, result)
    if kind in (Kind.development, Kind.tube):
        _check_step(dataset, step)
    try:
        write_result(dataset, kind.value, out, step=step, color_by=color_by.value, guides=guides,
                     fps=fps, stride=stride, dpi=dpi, elev=elev, azim=azim)  # fmt: skip
    except OSError as err:
        raise typer.BadParameter(f"cannot write {out}: {err}", param_hint="--out") from None
    Console(highlight=False).print(f"wrote {escape(str(out))}")
