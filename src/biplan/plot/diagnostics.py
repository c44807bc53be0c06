"""Diagnostics along a path, trajectory or stable-branch sweep: energy by fold set, smallest
eigenvalue, phases.

Every function takes a result ``xarray.Dataset`` (:func:`biplan.io.results.load_result`; dims
``step`` for a path, ``time`` for a trajectory, ``fold``, ``phase``) and an optional ``ax``,
and returns the Axes. The horizontal axis is chosen with ``x``: ``"displacement"`` (the
load-point displacement U [mm]), ``"step"``, ``"time"`` [s] or any other 1D variable; by
default U for a path and t for a trajectory. :func:`measured_band` adds a measured median ±
SD band (e.g. of specimen force–displacement curves) to an Axes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.plot.response import (
    COLUMN_FIGSIZE,
    FONT_SIZE,
    _new_axes,
    _runs,
    _style,
    cell_edges,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["energy_by_fold_set", "measured_band", "min_eigenvalue", "phase_fractions"]

#: Okabe–Ito colours: helical (vermillion), circular (blue), total (black), kinetic (green).
SET_COLORS = {"helical": "#D55E00", "circular": "#0072B2", "total": "0.1", "kinetic": "#009E73"}
AXIS_LABELS = {"displacement": r"$U$ [mm]", "step": "step", "time": r"$t$ [s]"}


def _dim(dataset: Any) -> str:
    return "time" if "time" in dataset.dims else "step"


def abscissa(dataset: Any, x: str | None = None) -> tuple[np.ndarray, str]:
    """Values and axis label of the horizontal axis ``x`` (see module docstring).

    Raises
    ------
    ValueError
        If ``x`` names nothing of the dataset.
    """
    dim = _dim(dataset)
    x = x or ("time" if dim == "time" else "displacement")
    if x == dim:
        n = dataset.sizes[dim]
        values = dataset[dim].values if dim in dataset.coords else np.arange(n)
        return np.asarray(values, dtype=float), AXIS_LABELS[x]
    if x not in dataset:
        raise ValueError(f"x must be 'step', 'time' or a variable of the result, got {x!r}")
    units = dataset[x].attrs.get("units")
    label = AXIS_LABELS.get(x, f"{x} [{units}]" if units else x)
    return np.asarray(dataset[x].values, dtype=float), label


def _finish(ax: Axes, xlabel: str, ylabel: str, legend: bool = False) -> Axes:
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if legend:
        ax.legend(fontsize=FONT_SIZE - 1, frameon=False, loc="best")
    _style(ax)
    return ax


def _stability_line(ax: Axes, xs: np.ndarray, ys: np.ndarray, stable: np.ndarray) -> None:
    """Stable runs solid, unstable runs dashed (joined to their neighbours), one colour."""
    color = SET_COLORS["circular"]
    for i, j in _runs(stable):
        ax.plot(xs[i:j], ys[i:j], "-", color=color, lw=1.1)
    for i, j in _runs(~stable):
        lo, hi = max(i - 1, 0), min(j + 1, len(xs))
        ax.plot(xs[lo:hi], ys[lo:hi], "--", color=color, lw=1.1, gid="unstable")


def energy_by_fold_set(dataset: Any, *, ax: Axes | None = None, x: str | None = None) -> Axes:
    """Strain energy of the helical and the circular fold set and in total [N·mm].

    Trajectories also show the kinetic energy and, where present, the energy balance
    ``total_energy`` (dotted, constant for an exact undamped integration).

    Parameters
    ----------
    dataset : xarray.Dataset
        Path or trajectory with ``helical_energy``, ``circular_energy`` and ``energy``.
    ax : Axes, optional
    x : str, optional
        Horizontal axis (see module docstring).

    Returns
    -------
    Axes
    """
    xs, xlabel = abscissa(dataset, x)
    ax = _new_axes(ax, COLUMN_FIGSIZE)
    curves = [
        ("helical_energy", "helical folds", SET_COLORS["helical"], "-"),
        ("circular_energy", "circular folds", SET_COLORS["circular"], "-"),
        ("energy", "total strain", SET_COLORS["total"], "-"),
        ("kinetic_energy", "kinetic", SET_COLORS["kinetic"], "--"),
        ("total_energy", "energy balance", "0.5", ":"),
    ]
    for name, label, color, style in curves:
        if name in dataset:
            ax.plot(xs, dataset[name].values, style, color=color, lw=1.1, label=label)
    return _finish(ax, xlabel, r"energy [N$\cdot$mm]", legend=True)


def min_eigenvalue(
    dataset: Any, *, ax: Axes | None = None, x: str | None = None, symlog: bool = False
) -> Axes:
    """Smallest eigenvalue λ_min of the reduced Hessian along the path [N·mm per unit q²; q in
    mm and rad].

    Unstable stretches (``stable`` = 0) are dashed, as in :func:`biplan.plot.force_displacement`
    (a path may turn back in U, so stretches are not shaded as U intervals); contact-locked
    states (λ_min = +∞) and failed steps are left out of the line.

    Parameters
    ----------
    dataset : xarray.Dataset
        With ``min_eigenvalue`` and ``stable``.
    ax : Axes, optional
    x : str, optional
        Horizontal axis (see module docstring).
    symlog : bool
        Symmetric-log vertical axis (linear within ±1 % of max |λ_min|), for λ_min spanning
        decades.

    Returns
    -------
    Axes
    """
    xs, xlabel = abscissa(dataset, x)
    min_eig = np.asarray(dataset["min_eigenvalue"].values, dtype=float)
    ax = _new_axes(ax, COLUMN_FIGSIZE)
    stable = dataset["stable"].values if "stable" in dataset else np.ones(len(min_eig))
    shown = np.where(np.isfinite(min_eig), min_eig, np.nan)
    _stability_line(ax, xs, shown, np.asarray(stable, dtype=bool))
    ax.axhline(0.0, color="0.4", lw=0.6, zorder=1)
    if symlog and np.isfinite(shown).any():
        ax.set_yscale("symlog", linthresh=max(1e-2 * float(np.nanmax(np.abs(shown))), 1e-12))
    return _finish(ax, xlabel, r"$\lambda_{\min}$ [N$\cdot$mm]")


def phase_fractions(
    dataset: Any, *, ax: Axes | None = None, phase: str = "open", x: str | None = None
) -> Axes:
    """Fraction of every fold's length on one branch of its law, as a fold × path map.

    Parameters
    ----------
    dataset : xarray.Dataset
        With ``phase_fraction(step|time, fold, phase)``.
    ax : Axes, optional
    phase : {"open", "spinodal", "closed"}
        The branch shown.
    x : str, optional
        Horizontal axis; default the step index of a path (a path may turn back in U), the
        time of a trajectory, the displacement U of a stable-branch sweep. Must be monotonic.

    Returns
    -------
    Axes
        Folds from the base (bottom) up; colour 0–1 (cividis) with a colorbar.

    Raises
    ------
    ValueError
        For an unknown phase or a non-monotonic ``x``.
    """
    phases = [str(p) for p in dataset["phase"].values]
    if phase not in phases:
        raise ValueError(f"phase must be one of {phases}, got {phase!r}")
    from biplan.analysis.response.quasistatic import SWEEP_KIND

    if x is None:  # a sweep's U only grows; a path's may turn back at limit points
        x = "displacement" if dataset.attrs.get("kind") == SWEEP_KIND else _dim(dataset)
    xs, xlabel = abscissa(dataset, x)
    steps = np.diff(xs)
    if len(xs) > 1 and not (np.all(steps > 0) or np.all(steps < 0)):
        raise ValueError(f"x = {x!r} is not monotonic along the result; use x='step'")
    frac = np.asarray(dataset["phase_fraction"].sel(phase=phase).values, dtype=float)
    folds = [str(f) for f in dataset["fold"].values]
    edges = cell_edges(xs)
    ax = _new_axes(ax, (COLUMN_FIGSIZE[0], COLUMN_FIGSIZE[1] + 0.02 * len(folds)))
    mesh = ax.pcolormesh(edges, np.arange(len(folds) + 1) - 0.5, frac.T, cmap="cividis")
    mesh.set(clim=(0.0, 1.0), gid="phase-fractions", rasterized=True)
    ax.set_yticks(np.arange(len(folds)), labels=folds)
    cb = ax.figure.colorbar(mesh, ax=ax, aspect=30)
    cb.set_label(f"{phase} fraction [–]", fontsize=FONT_SIZE)
    cb.ax.tick_params(labelsize=FONT_SIZE)
    _finish(ax, xlabel, "")
    ax.tick_params(axis="y", labelsize=FONT_SIZE - 1)
    return ax


def measured_band(
    displacement: np.ndarray,
    median: np.ndarray,
    sd: np.ndarray,
    *,
    ax: Axes | None = None,
    label: str = r"measured median $\pm$ SD",
) -> Axes:
    """A measured median force curve [N] with a shaded ± 1 SD band over displacement [mm].

    Drawn behind everything else (zorder 0–1), so it can go under
    :func:`biplan.plot.force_displacement` in the same Axes.

    Raises
    ------
    ValueError
        For arrays of different shapes.
    """
    u, m, s = (np.asarray(a, dtype=float) for a in (displacement, median, sd))
    if not u.shape == m.shape == s.shape:
        raise ValueError(f"shapes differ: {u.shape}, {m.shape}, {s.shape}")
    ax = _new_axes(ax, COLUMN_FIGSIZE)
    ax.fill_between(u, m - s, m + s, color="0.8", lw=0, zorder=0, label=label)
    ax.plot(u, m, "-", color="0.45", lw=0.9, zorder=1)
    return _finish(ax, r"$U$ [mm]", r"$F$ [N]")
