"""The figure files of ``biplan respond`` and ``biplan demo``, written through
:func:`biplan.plot.files.figure_file` (Agg, 300 dpi, closed in every case).

* :func:`response_figure` — ``response.png``: the force (under pressure control the pressure
  [kPa]) against the load-point displacement z_p [mm], unstable stretches dashed, located
  limit points marked, snaps drawn as dotted jumps; a trajectory adds F(t) and z_p(t) in a
  second panel;
* :func:`sweep_figures` — the demo's stable-branch sweep: ``force_displacement.png`` with the
  snapshot states marked, ``development.png`` (their deformed developments, folds coloured by
  w [mm], one frame for all) and ``cylinder.png`` (the snapshots wrapped onto the cylinder,
  side by side);
* :func:`ramp_and_path_figure` — the demo's ``response.png``: the displacement-controlled
  equilibrium path and the force ramp in one force–displacement plane;
* :func:`ramp_animation` — the demo's ``ramp.gif`` (about :data:`ANIMATION_FRAMES` frames).
"""

from __future__ import annotations

import types
from collections.abc import Mapping
from pathlib import Path as FilePath
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.plot.files import figure_file
from biplan.plot.response import (
    COLUMN_FIGSIZE,
    FONT_SIZE,
    LINE_COLOR,
    SNAP_COLOR,
    force_displacement,
    legend_above,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from biplan.analysis.response.quasistatic import QuasiStaticPath
    from biplan.model.assembly import Model
    from biplan.solvers.newton import Solution
    from biplan.solvers.path_results import EquilibriumPath
    from biplan.solvers.trajectory_results import Trajectory

__all__ = [
    "ANIMATION_FRAMES",
    "ramp_and_path_figure",
    "ramp_animation",
    "response_figure",
    "sweep_figures",
]

#: Frames of the demo's ramp animation (about).
ANIMATION_FRAMES = 50
#: Colour of the displacement against time (right axis of the time panel).
DISPLACEMENT_COLOR = "#D55E00"


def response_figure(
    result: QuasiStaticPath | EquilibriumPath | Trajectory, file: str | FilePath
) -> FilePath:
    """Write ``file``: F (p [kPa] under pressure control) against z_p [mm]; a trajectory adds
    F and z_p against time in a second panel (twice as wide). Returns ``file``."""
    from biplan.solvers.results import display_units

    control = getattr(result, "control", None)
    pressure = control is not None and control.kind.value == "pressure"
    shown: Any = result
    if control is not None and pressure:  # the load parameter (kPa) in place of the force
        kpa = display_units(control)[0]
        flags = {n: getattr(result, n) for n in ("switched", "is_event") if hasattr(result, n)}
        shown = types.SimpleNamespace(
            displacement=result.displacement,
            force=kpa * np.asarray(result.load_parameter),  # type: ignore[union-attr]
            stable=result.stable,
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
            _time_panel(axes[1], result)  # type: ignore[arg-type]
    return FilePath(file)


def _time_panel(ax: Axes, result: Trajectory) -> None:
    """F(t) (left axis) and z_p(t) (right axis, dashed) of a trajectory."""
    t = np.asarray(result.time)
    ax.plot(t, result.force, color=LINE_COLOR, lw=1.2)
    ax.set_xlabel(r"time $t$ [s]", fontsize=FONT_SIZE)
    ax.set_ylabel(r"$F$ [N]", fontsize=FONT_SIZE, color=LINE_COLOR)
    right = ax.twinx()
    right.plot(t, result.displacement, color=DISPLACEMENT_COLOR, lw=1.0, ls="--")
    right.set_ylabel(r"$z_p$ [mm] (dashed)", fontsize=FONT_SIZE, color=DISPLACEMENT_COLOR)
    for a in (ax, right):
        a.tick_params(labelsize=FONT_SIZE)
    ax.set_xlim(float(t[0]), float(t[-1]))


def sweep_figures(
    model: Model,
    start: Solution,
    path: QuasiStaticPath,
    snapshots: Mapping[str, int],
    out: FilePath,
) -> list[FilePath]:
    """Write the demo's PNGs of a stable-branch sweep into the folder ``out``.

    Parameters
    ----------
    model : Model
    start : Solution
        The relaxed reference the sweep started from (joined to its first step).
    path : QuasiStaticPath
    snapshots : mapping of str to int
        Panel name (``"B.1"``…) → step index of the snapshot states
        (:func:`biplan.reproduction.facts.snapshot_steps`).
    out : pathlib.Path
        Output folder (it must exist).

    Returns
    -------
    list of pathlib.Path
        ``force_displacement.png``, then ``development.png`` and ``cylinder.png`` when there
        is a snapshot.
    """
    files = [out / f"{n}.png" for n in ("force_displacement", "development", "cylinder")]
    _sweep_curve(start, path, snapshots, files[0])
    if not snapshots:
        return files[:1]
    states = [path.solutions[k].q for k in snapshots.values()]
    titles = [
        f"({key}) $U$ = {path.displacement[k]:.2f} mm, $F$ = {path.force[k]:.2f} N"
        for key, k in snapshots.items()
    ]
    _developments(model, states, titles, files[1])
    _cylinders(model, states, list(snapshots), files[2])
    return files


def _sweep_curve(
    start: Solution, path: QuasiStaticPath, snapshots: Mapping[str, int], file: FilePath
) -> None:
    """F against U, joined to the relaxed reference, the snapshots marked and named."""
    with figure_file(file, figsize=COLUMN_FIGSIZE) as (_, ax):
        force_displacement(path, ax=ax)
        if np.isfinite(path.force[0]) and path.stable[0]:  # join the relaxed reference
            u0, f0 = [start.displacement, path.displacement[0]], [start.force, path.force[0]]
            ax.plot(u0, f0, "-", lw=1.2, color=LINE_COLOR, zorder=2)
        ax.set_xlim(0.0, 1.04 * float(np.nanmax(path.displacement)))
        ax.margins(y=0.1)
        for key, k in snapshots.items():
            u, f = path.displacement[k], path.force[k]
            ax.plot(u, f, "s", ms=3.5, color=SNAP_COLOR, zorder=4)
            ax.annotate(
                f"({key})",
                (u, f),
                textcoords="offset points",
                xytext=(0, 5),
                ha="center",
                fontsize=FONT_SIZE,
            )
        legend_above(ax)


def _developments(model: Model, states: list[Any], titles: list[str], file: FilePath) -> None:
    """The deformed developments side by side, one colour scale and one frame for all."""
    from biplan.plot.tube import development, elongation_norm

    n = len(states)
    with figure_file(file, ncols=n, squeeze=False, figsize=(7.0, 3.9)) as (_, grid):
        axes = grid[0]
        norm = elongation_norm(model, states)
        for i, (title, q) in enumerate(zip(titles, states, strict=True)):
            development(model, q, ax=axes[i], norm=norm, colorbar=i == n - 1)
            axes[i].set_title(title, fontsize=FONT_SIZE)
        # One frame for all panels, so that the states compare at equal scale.
        xlim = min(a.get_xlim()[0] for a in axes), max(a.get_xlim()[1] for a in axes)
        ylim = min(a.get_ylim()[0] for a in axes), max(a.get_ylim()[1] for a in axes)
        for i, a in enumerate(axes):
            a.set(xlim=xlim, ylim=ylim)
            if i:
                a.set_ylabel("")
                a.tick_params(labelleft=False)


def _cylinders(model: Model, states: list[Any], keys: list[str], file: FilePath) -> None:
    """The states wrapped onto the cylinder, side by side across the screen, each named."""
    from biplan.plot.cylinder import cylinder

    with figure_file(file, figsize=(3.4, 3.6), subplot_kw={"projection": "3d"}) as (_, ax3):
        azim, spacing = -60.0, 5.0 * model.tube.development.radius
        side = np.radians(azim + 90.0)  # screen-horizontal direction at this azimuth
        for i, (key, q) in enumerate(zip(keys, states, strict=True)):
            x, y = i * spacing * np.cos(side), i * spacing * np.sin(side)
            cylinder(model, q, ax=ax3, azim=azim, offset=(x, y))
            ax3.text(
                x,
                y,
                -0.12 * model.tube.initial_length,
                f"({key})",
                ha="center",
                va="top",
                fontsize=FONT_SIZE,
            )


def ramp_and_path_figure(path: EquilibriumPath, ramp: Trajectory, file: str | FilePath) -> FilePath:
    """Write ``file``: the displacement-controlled equilibrium ``path`` and the force ``ramp``
    (dynamic) in the force–displacement plane. Returns ``file``."""
    with figure_file(file, figsize=COLUMN_FIGSIZE) as (_, ax):
        force_displacement(path, ax=ax, label="equilibrium path (displacement control)")
        ax.plot(
            ramp.displacement,
            ramp.force,
            "-",
            color=SNAP_COLOR,
            lw=1.0,
            label="force ramp 0.8 N/s (dynamic)",
        )
        ax.set_xlabel(r"load-point displacement $z_p$ [mm]")
        legend_above(ax, fontsize=6, ncol=1)
    return FilePath(file)


def ramp_animation(ramp: Trajectory, model: Model, file: str | FilePath) -> FilePath:
    """Write the animation of ``ramp`` (GIF: planar development, 3D tube, F–z_p marker) at
    12 frames per second, about :data:`ANIMATION_FRAMES` frames."""
    from biplan.io.results import dataset
    from biplan.plot.animation import animate

    stride = max(1, len(ramp.time) // ANIMATION_FRAMES)
    return animate(dataset(ramp), model, file, fps=12, stride=stride)
