"""Pictures of a result file (``biplan plot``): a path, trajectory, stable-branch sweep or state
catalogue read back by :func:`biplan.io.results.load_result`, its ``config`` attribute
rebuilding the model (:func:`~biplan.io.results.model_of`).

* :func:`result_figure` — one static figure of a kind: ``response`` (force, or the controlled
  pressure [kPa], against the load-point displacement), ``development`` or ``tube`` (one
  state), ``gallery`` (every state of a catalogue), ``energy``, ``eigenvalue``, ``phases``
  (diagnostics along the result);
* :func:`write_result` — a kind written to a file: an animation (``.gif``, ``.mp4``), a
  ParaView export of the tube (``.vtu`` one state, ``.pvd`` the series), else the static
  figure in the format of the suffix.

The kinds are strings (``biplan.cli.plot.Kind`` lists them); which apply to which result is the
command's check.
"""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from biplan.io.results import model_of
from biplan.plot import diagnostics
from biplan.plot.cylinder import cylinder
from biplan.plot.files import DPI, save
from biplan.plot.gallery import gallery
from biplan.plot.response import force_displacement
from biplan.plot.tube import development

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["ANIMATION_DPI", "result_figure", "write_result"]

#: Default resolution of an animation [dots per inch] (static figures: :data:`DPI`).
ANIMATION_DPI = 100
_DIAGNOSTICS = {
    "energy": diagnostics.energy_by_fold_set,
    "eigenvalue": diagnostics.min_eigenvalue,
    "phases": diagnostics.phase_fractions,
}


def _root(ax: Any) -> Figure:
    """The figure an Axes belongs to."""
    return cast("Figure", ax.get_figure(root=True))


def _response(dataset: Any) -> Figure:
    """Force (or the controlled pressure [kPa]) against load-point displacement: unstable
    stretches dashed, snaps of a stable-branch sweep dotted, limit points marked."""
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
    ax = force_displacement(cast("Any", curve))
    if pressure:
        unit = dataset["load_parameter"].attrs.get("units", "kPa")
        ax.set_ylabel(f"pressure $p$ [{unit}]")
    return _root(ax)


def result_figure(
    dataset: Any, kind: str, step: int, color_by: str, guides: bool, view: dict[str, Any]
) -> Figure:
    """The static figure of ``kind`` for a result dataset.

    Parameters
    ----------
    dataset : xarray.Dataset
        A path, trajectory, stable-branch sweep or state catalogue.
    kind : str
        ``response``, ``development``, ``tube``, ``gallery``, ``energy``, ``eigenvalue`` or
        ``phases``.
    step : int
        The state drawn by ``development`` and ``tube`` (an index of ``q``; -1: the last).
    color_by : {"elongation", "phase"}
        Fold colouring of ``development``, ``tube`` and ``gallery``.
    guides : bool
        ``development``: draw guides and rotation centres.
    view : dict
        ``elev`` and ``azim`` [deg] of the 3D views (``tube``, ``gallery``).
    """
    if kind == "gallery":
        return gallery(dataset, model_of(dataset), color_by=color_by, **view)
    if kind in ("development", "tube"):
        model = model_of(dataset)
        q = np.asarray(dataset["q"].values, dtype=float)[step]
        if kind == "development":
            return _root(development(model, q, color_by=color_by, guides=guides))
        return _root(cylinder(model, q, color_by=color_by, colorbar=True, **view))
    if kind == "response":
        return _response(dataset)
    return _root(_DIAGNOSTICS[kind](dataset))


def write_result(
    dataset: Any,
    kind: str,
    out: Path,
    *,
    step: int = -1,
    color_by: str = "elongation",
    guides: bool = False,
    fps: float = 15.0,
    stride: int = 1,
    dpi: float | None = None,
    elev: float = 20.0,
    azim: float = -60.0,
) -> None:
    """Write ``kind`` of a result dataset to ``out`` (its folder created).

    ``animation``: a GIF or MP4 at ``fps`` frames/s of every ``stride``-th state
    (:func:`~biplan.plot.animation.animate`); ``tube`` to ``.vtu`` (state ``step``) or ``.pvd``
    (every ``stride``-th state): a ParaView export (:func:`~biplan.io.vtk.export_result`);
    anything else: :func:`result_figure` in the format of the suffix. ``dpi`` defaults to
    :data:`~biplan.plot.files.DPI` (animations: :data:`ANIMATION_DPI`); ``elev``, ``azim``
    [deg] orient the 3D views.
    """
    from biplan.io.vtk import export_result
    from biplan.plot.animation import animate

    out.parent.mkdir(parents=True, exist_ok=True)
    if kind == "animation":
        animate(dataset, model_of(dataset), out, fps=fps, stride=stride,
                dpi=dpi or ANIMATION_DPI, color_by=color_by, elev=elev, azim=azim)  # fmt: skip
    elif kind == "tube" and out.suffix.lower() in (".vtu", ".pvd"):
        export_result(dataset, model_of(dataset), out, stride=stride, index=step)
    else:
        view = {"elev": elev, "azim": azim}
        save(result_figure(dataset, kind, step, color_by, guides, view), out, dpi=dpi or DPI)
