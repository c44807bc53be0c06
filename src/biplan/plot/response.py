"""Response curves of a quasi-static sweep: force against prescribed displacement.

Contract of every plotting function in :mod:`biplan.plot`: ``f(result, *, ax=None, ...) ->
Axes``. Given an ``ax`` the function draws into it; without one it creates a journal-column
figure (3.4 × 2.6 in, 8 pt text). It never calls ``show()``, never changes the matplotlib
backend and never keeps global state; the caller owns the figure.

Line styles of :func:`force_displacement`: contiguous stable stretches of the path are solid,
unstable stretches dashed; a displacement-controlled snap (the sweep left an equilibrium for a
stable one on another branch, ``path.switched``) breaks the curve, is joined to the previous
step by a thin dotted drop and marked with an open circle. Failed steps (NaN force) are gaps.
States flagged ``is_event`` (located limit points and bifurcations of a
:class:`~biplan.solvers.path_results.Path`) are marked with crosses. A legend names the styles
drawn (stable, unstable, branch switch, limit point) and sits above the axes
(:func:`legend_above`), where it cannot cover the curve.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from biplan.analysis.response.quasistatic import QuasiStaticPath

__all__ = ["COLUMN_FIGSIZE", "FONT_SIZE", "cell_edges", "force_displacement", "legend_above"]

#: Journal single-column figure size [in] and text size [pt].
COLUMN_FIGSIZE = (3.4, 2.6)
FONT_SIZE = 8

#: Colour-blind-safe default line colour (Okabe–Ito blue) and snap-marker colour (vermillion).
LINE_COLOR = "#0072B2"
SNAP_COLOR = "#D55E00"


def _new_axes(ax: Axes | None, figsize: tuple[float, float], **subplot_kw: Any) -> Axes:
    """Return ``ax`` or the single Axes of a new constrained-layout figure of ``figsize`` [in]."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=figsize, layout="constrained")
    return fig.add_subplot(**subplot_kw)


def _style(ax: Axes) -> None:
    """Apply the journal text size to an Axes' tick labels, axis labels and title."""
    ax.tick_params(labelsize=FONT_SIZE)
    ax.xaxis.label.set_fontsize(FONT_SIZE)
    ax.yaxis.label.set_fontsize(FONT_SIZE)
    ax.title.set_fontsize(FONT_SIZE)
    zaxis = getattr(ax, "zaxis", None)
    if zaxis is not None:
        zaxis.label.set_fontsize(FONT_SIZE)


def cell_edges(x: np.ndarray, clip_at_zero: bool = False) -> np.ndarray:
    """Cell edges around the centres ``x`` (midpoints; the outer cells as wide as their
    neighbours, a single cell 1 wide) for ``pcolormesh``. ``clip_at_zero``: an axis of
    non-negative values (C, U/l₀) is not extended below zero."""
    x = np.asarray(x, dtype=float)
    if x.size == 1:
        e = np.array([x[0] - 0.5, x[0] + 0.5])
    else:
        mid = 0.5 * (x[1:] + x[:-1])
        e = np.r_[2 * x[0] - mid[0], mid, 2 * x[-1] - mid[-1]]
    if clip_at_zero and np.all(x >= 0.0):
        e = np.maximum(e, 0.0)
    return e


def legend_above(ax: Axes, **kwargs: Any) -> Any:
    """The legend of every labelled artist of ``ax``, in a row above the axes (off the data:
    nothing is drawn there); None when nothing is labelled. ``kwargs`` go to ``ax.legend``."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    options = {
        "fontsize": FONT_SIZE - 1,
        "frameon": False,
        "loc": "lower left",
        "bbox_to_anchor": (0.0, 1.0),
        "ncol": min(len(handles), 2),
        "handlelength": 1.8,
        "columnspacing": 1.0,
        "borderaxespad": 0.2,
        **kwargs,
    }
    return ax.legend(handles, labels, **options)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Half-open index ranges [i, j) of the contiguous True runs of a boolean mask."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def force_displacement(
    path: QuasiStaticPath | Any,
    *,
    ax: Axes | None = None,
    normalise: float | None = None,
    color: str = LINE_COLOR,
    label: str | None = None,
    legend: bool = True,
) -> Axes:
    """Plot the end force F [N] against the prescribed displacement U [mm] of a sweep.

    Parameters
    ----------
    path : QuasiStaticPath, Path, Trajectory or any object with the arrays
        ``displacement`` [mm], ``force`` [N] and ``stable``, and optionally ``switched``
        (branch switches) and ``is_event`` (located limit points).
    ax : Axes, optional
        Axes to draw into; a new 3.4 × 2.6 in figure when omitted.
    normalise : float, optional
        Length l₀ [mm] (e.g. ``tube.initial_length``); the horizontal axis then shows the
        dimensionless U / l₀ instead of U [mm].
    color : str
        Line colour of the path.
    label : str, optional
        Name of the path in the legend: its stretches are labelled "``label``, stable" and
        "``label``, unstable" (default "stable" and "unstable").
    legend : bool
        Draw the legend above the axes (:func:`legend_above`; a caller that adds artists
        may call it again).

    Returns
    -------
    Axes
        The Axes drawn into.

    Raises
    ------
    ValueError
        If ``normalise`` is given and not a finite length > 0.
    """
    u = np.asarray(path.displacement, dtype=float)
    f = np.asarray(path.force, dtype=float)
    stable = np.asarray(path.stable, dtype=bool)
    switched = np.asarray(getattr(path, "switched", np.zeros(len(u), bool)), dtype=bool)
    flags = getattr(path, "is_event", getattr(path, "limit_point", None))
    events = np.asarray(np.zeros(len(u), bool) if flags is None else flags, dtype=bool)
    if normalise is not None:
        if not (np.isfinite(normalise) and normalise > 0):
            raise ValueError(f"normalise must be a finite length > 0 mm, got {normalise!r}")
        u = u / normalise
    ax = _new_axes(ax, COLUMN_FIGSIZE)

    ok = np.isfinite(f) & np.isfinite(u)
    n = len(u)
    # Each style is labelled once, on its first stretch.
    names = {"-": "stable", "--": "unstable"}
    if label is not None:
        names = {k: f"{label}, {v}" for k, v in names.items()}
    # Stable stretches: runs of converged stable steps, cut where the sweep snapped.
    for i, j in _runs(ok & stable):
        cuts = [k for k in range(i + 1, j) if switched[k]]
        for a, b in zip([i, *cuts], [*cuts, j], strict=True):
            ax.plot(u[a:b], f[a:b], "-", color=color, lw=1.2, label=names.pop("-", None))
    # Unstable stretches, joined to the converged neighbours they leave and enter (not across
    # a snap, which is drawn as a drop below).
    for i, j in _runs(ok & ~stable):
        lo = i - 1 if i > 0 and ok[i - 1] and not switched[i] else i
        hi = j + 1 if j < n and ok[j] and not switched[j] else j
        ax.plot(u[lo:hi], f[lo:hi], "--", color=color, lw=1.2, label=names.pop("--", None))

    snaps = np.flatnonzero(switched & ok)
    for k in snaps:
        prev = k - 1
        while prev >= 0 and not ok[prev]:
            prev -= 1
        if prev >= 0:
            ax.plot([u[prev], u[k]], [f[prev], f[k]], ":", color="0.5", lw=0.8)
    if snaps.size:
        ax.plot(
            u[snaps],
            f[snaps],
            "o",
            mfc="white",
            mec=SNAP_COLOR,
            ms=3.5,
            mew=0.9,
            ls="none",
            label="branch switch",
            zorder=3,
        )

    if events.any():
        ax.plot(
            u[events],
            f[events],
            "x",
            color=SNAP_COLOR,
            ms=4,
            mew=1.0,
            ls="none",
            label="limit point / bifurcation",
            zorder=4,
        )
    ax.set_xlabel(r"$U/l_0$ [–]" if normalise is not None else r"$U$ [mm]")
    ax.set_ylabel(r"$F$ [N]")
    ax.axhline(0.0, color="0.8", lw=0.6, zorder=0)
    ax.margins(x=0.02)
    if legend:
        legend_above(ax)
    _style(ax)
    return ax
