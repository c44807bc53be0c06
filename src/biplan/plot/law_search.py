"""Figure of a fold-law search (:mod:`biplan.calibration.fig4_search`): the count of stable
states over the two law coefficients that move it most, with the paper's 34 marked.

* :func:`count_samples` — the global stage's law sets in the plane of the two coefficients,
  coloured by their count; sets with 00, 2A, 1B and 66 all stable ringed, sets with 34 states
  starred;
* :func:`count_slice` — the count on the grid through the best law set (the search's slice
  stage), the 34 contour drawn where the count crosses it, points with exactly 34 marked,
  cells where 66 is not stable hatched, the best set starred;
* :func:`write_count_figure` — both side by side in one PNG.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from biplan._errors import ConfigError
from biplan.analysis.states.law_records import PAPER_N_STATES, PAPER_STATES
from biplan.analysis.states.law_search import PARAMETERS
from biplan.plot.files import figure_file
from biplan.plot.maps import grid_edges
from biplan.plot.response import FONT_SIZE, _new_axes, _style

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from biplan.calibration.fig4_search import SearchResult

__all__ = ["count_samples", "count_slice", "write_count_figure"]

_UNIT = {"k": "N/mm²", "w": "mm"}
#: Colour map of the count (the paper's 34 sits in its middle third for counts to ~100).
CMAP = "viridis"
MARK = "#D55E00"


def _label(name: str) -> str:
    s, c = name.split(".")
    return f"{s} {c[0]}$_{c[1]}$ [{_UNIT[c[0]]}]"


def _axes(result: SearchResult) -> tuple[int, int]:
    if len(result.slice_axes) == 2:
        a, b = (PARAMETERS.index(name) for name, _ in result.slice_axes)
        return a, b
    i, j = np.argsort(-result.influence, kind="stable")[:2]
    return int(i), int(j)


def count_samples(result: SearchResult, *, ax: Axes | None = None) -> Axes:
    """The global stage's searched law sets over the two most influential coefficients,
    coloured by count (module docstring)."""
    ax = _new_axes(ax, (3.4, 2.8))
    i, j = _axes(result)
    rows = (result.stage == 0) & result.records.ok
    if not rows.any():
        raise ConfigError("result", "no searched law set", "a search with at least one")
    v, n = result.records.values[rows], result.records.n_states[rows]
    all4 = result.records.named[rows].all(axis=1)
    art = ax.scatter(v[:, i], v[:, j], c=n, s=4, cmap=CMAP, linewidths=0)
    ax.scatter(v[all4, i], v[all4, j], s=14, facecolors="none", edgecolors="k", linewidths=0.4,
               label=f"{', '.join(PAPER_STATES)} stable")  # fmt: skip
    hit = n == PAPER_N_STATES
    ax.scatter(v[hit, i], v[hit, j], marker="*", s=40, color=MARK,
               label=f"{PAPER_N_STATES} states ({int(hit.sum())} sets)")  # fmt: skip
    cbar = ax.figure.colorbar(art, ax=ax)
    cbar.set_label("stable states", fontsize=FONT_SIZE)
    cbar.ax.tick_params(labelsize=FONT_SIZE)
    ax.set_xlabel(_label(PARAMETERS[i]))
    ax.set_ylabel(_label(PARAMETERS[j]))
    ax.set_title(f"global stage: {int(rows.sum())} law sets", fontsize=FONT_SIZE)
    ax.legend(fontsize=FONT_SIZE - 1, loc="best", framealpha=0.8)
    _style(ax)
    return ax


def count_slice(result: SearchResult, *, ax: Axes | None = None) -> Axes:
    """The count on the slice grid through the best law set (module docstring)."""
    if result.slice is None or len(result.slice_axes) != 2:
        raise ConfigError("result", "no slice", "a search with slice_points > 0")
    ax = _new_axes(ax, (3.4, 2.8))
    (xn, x), (yn, y) = result.slice_axes
    s = result.slice
    count = np.where(s.ok, s.n_states, np.nan).astype(float).reshape(len(x), len(y)).T
    lost = (s.ok & (s.named[:, PAPER_STATES.index("66")] == 0)).reshape(len(x), len(y)).T
    mesh = ax.pcolormesh(grid_edges(x), grid_edges(y), count, cmap=CMAP, shading="flat")
    if np.nanmin(count) < PAPER_N_STATES < np.nanmax(count):
        ax.contour(x, y, count, levels=[PAPER_N_STATES], colors=MARK, linewidths=1.0)
    ax.contourf(x, y, lost.astype(float), levels=[0.5, 1.5], colors="none", hatches=["////"])
    exact = count == PAPER_N_STATES
    yy, xx = np.nonzero(exact)
    label = f"{PAPER_N_STATES} states ({xx.size} points; line: crosses {PAPER_N_STATES})"
    ax.scatter(x[xx], y[yy], marker="s", s=6, color=MARK, label=label)
    best = result.records.values[result.best]
    ax.scatter(best[PARAMETERS.index(xn)], best[PARAMETERS.index(yn)], marker="*", s=60,
               color="w", edgecolors="k", linewidths=0.5, label="best law set")  # fmt: skip
    cbar = ax.figure.colorbar(mesh, ax=ax)
    cbar.set_label("stable states", fontsize=FONT_SIZE)
    cbar.ax.tick_params(labelsize=FONT_SIZE)
    ax.set_xlabel(_label(xn))
    ax.set_ylabel(_label(yn))
    ax.set_title("slice through the best set (hatched: 66 not stable)", fontsize=FONT_SIZE)
    ax.legend(fontsize=FONT_SIZE - 1, loc="best", framealpha=0.8)
    _style(ax)
    return ax


def write_count_figure(result: SearchResult, file: Path) -> Path:
    """Both panels in one PNG (the slice only when the search has one)."""
    panels = 2 if result.slice is not None else 1
    with figure_file(file, figsize=(3.6 * panels, 3.0), ncols=panels) as (_, axes):
        axes = np.atleast_1d(axes)
        count_samples(result, ax=axes[0])
        if panels == 2:
            count_slice(result, ax=axes[1])
    return Path(file)
