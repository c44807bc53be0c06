"""Figures of the stable-state analysis (main Fig. 4 A–C, SI distributions figure).

* :func:`transition_diagram` — the state-transition graph, states in columns by number of open
  folds, Hamming-1 edges in grey and chosen pathways highlighted;
* :func:`endpoint_space` — the 3D scatter of the states in (u_z/l₀, u_r/l₀, Θ), coloured by
  slope branch (open helical folds);
* :func:`distributions` — state counts over Θ, u_z/l₀ and u_r/l₀ and the branch-wise RMS
  relations, from :func:`biplan.analysis.hierarchy.hierarchy`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.plot.response import FONT_SIZE, _new_axes, _style

if TYPE_CHECKING:
    import networkx as nx
    from matplotlib.axes import Axes

__all__ = ["distributions", "endpoint_space", "transition_diagram"]

#: Height [in] per state of the tallest column of :func:`transition_diagram` (a 4.2-in figure
#: holds 20; larger catalogues, e.g. 242 states of a five-module tube, get a taller figure).
ROW_HEIGHT = 0.165
#: :func:`endpoint_space` names the states only up to this many (beyond, labels overlap).
MAX_ANNOTATED = 80

#: Okabe–Ito colours for pathways and slope branches.
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000")


def _positions(graph: nx.Graph) -> dict[str, tuple[float, float]]:
    """Columns by number of open folds; within a column, ordered by the binary value."""
    columns: dict[int, list[str]] = {}
    for node, data in graph.nodes(data=True):
        columns.setdefault(str(data["bits"]).count("1"), []).append(node)
    pos = {}
    for col, nodes in columns.items():
        nodes.sort(key=lambda n: int(str(graph.nodes[n]["bits"]), 2))
        for k, node in enumerate(nodes):
            pos[node] = (float(col), (len(nodes) - 1) / 2.0 - k)
    return pos


def transition_diagram(
    graph: nx.Graph,
    *,
    pathways: Sequence[Sequence[str]] = (),
    names: Sequence[str] | None = None,
    ax: Axes | None = None,
) -> Axes:
    """Draw the state-transition graph with pathways highlighted.

    A new figure is 7 in wide and tall enough for its tallest column (``ROW_HEIGHT`` inches
    per state, at least 4.2 in).

    Parameters
    ----------
    graph : networkx.Graph
        From :func:`biplan.analysis.transitions.transition_graph`.
    pathways : sequence of sequences of state names
        Drawn in colour, in order, labelled ``names`` (default p1, p2, …).
    """
    pos = _positions(graph)
    # a column of n states needs ~ROW_HEIGHT inches per state to keep labels apart
    tallest = max((round(2 * abs(y)) + 1 for _, y in pos.values()), default=1)
    ax = _new_axes(ax, (7.0, max(4.2, ROW_HEIGHT * tallest + 0.9)))
    for u, v in graph.edges:
        (x0, y0), (x1, y1) = pos[u], pos[v]
        ax.plot([x0, x1], [y0, y1], color="0.8", lw=0.6, zorder=1)
    names = list(names) if names is not None else [f"p{k + 1}" for k in range(len(pathways))]
    for k, path in enumerate(pathways):
        xy = np.array([pos[n] for n in path])
        color = PALETTE[k % len(PALETTE)]
        ax.plot(xy[:, 0], xy[:, 1], color=color, lw=2.0, zorder=2, label=names[k])
    for node, (x, y) in pos.items():
        ax.scatter([x], [y], s=140, color="white", edgecolor="0.2", lw=0.7, zorder=3)
        ax.annotate(node, (x, y), ha="center", va="center", fontsize=FONT_SIZE - 2, zorder=4)
    ax.set_xlabel("open folds")
    ax.set_yticks([])
    for side in ("left", "right", "top"):
        ax.spines[side].set_visible(False)
    if pathways:
        ax.legend(fontsize=FONT_SIZE, frameon=False, loc="upper left")
    _style(ax)
    return ax


def endpoint_space(states: Any, *, ax: Axes | None = None, annotate: bool = True) -> Axes:
    """3D scatter of the states in endpoint space (u_z/l₀, u_r/l₀, Θ), by slope branch.

    Parameters
    ----------
    states : xarray.Dataset
        A state catalogue (``StateCatalogue.to_dataset()`` or a ``states.nc`` file).
    annotate : bool
        Name every state (only for catalogues of at most :data:`MAX_ANNOTATED` states).
    """
    ax = _new_axes(ax, (4.2, 3.6), projection="3d")
    l0 = float(states.attrs["initial_length"])
    uz = np.asarray(states["u_z"].values, dtype=float) / l0
    ur = np.asarray(states["u_r"].values, dtype=float) / l0
    th = np.asarray(states["Theta"].values, dtype=float)
    hel = np.asarray(states["n_open_helical"].values, dtype=int)
    for b in np.unique(hel):
        sel = hel == b
        ax.scatter(  # type: ignore[misc]
            uz[sel],
            ur[sel],
            th[sel],
            s=14,
            color=PALETTE[int(b) % len(PALETTE)],
            label=f"{b} open helical",
            depthshade=False,
        )
    if annotate and uz.size <= MAX_ANNOTATED:
        for name, x, y, z in zip(states["state"].values, uz, ur, th, strict=True):
            ax.text(x, y, z, f" {name}", fontsize=FONT_SIZE - 3)  # type: ignore[arg-type]
    ax.set_xlabel("$u_z/l_0$")
    ax.set_ylabel("$u_r/l_0$")
    ax.set_zlabel(r"$\Theta$")  # type: ignore[attr-defined]
    ax.legend(fontsize=FONT_SIZE - 1, frameon=False, loc="upper left")
    _style(ax)
    return ax


def distributions(hierarchy: Any, *, fig: Any = None) -> np.ndarray:
    """Four panels: counts over Θ, u_z/l₀, u_r/l₀; RMS of u_z/l₀, u_r/l₀ per slope branch.

    Parameters
    ----------
    hierarchy : xarray.Dataset
        From :func:`biplan.analysis.hierarchy.hierarchy`.

    Returns
    -------
    ndarray of Axes (4,)
    """
    import matplotlib.pyplot as plt

    fig = fig or plt.figure(figsize=(7.0, 1.9), layout="constrained")
    axes = np.asarray(fig.subplots(1, 4)).ravel()
    for ax, key, xlabel in (
        (axes[0], "Theta", r"$\Theta$"),
        (axes[1], "u_z", "$u_z/l_0$"),
        (axes[2], "u_r", "$u_r/l_0$"),
    ):
        centres = np.asarray(hierarchy[f"{key}_bin"].values, dtype=float)
        counts = np.asarray(hierarchy[f"count_{key}"].values, dtype=float)
        width = float(np.min(np.diff(centres))) * 0.85 if centres.size > 1 else 0.1
        ax.bar(centres, counts, width=width, color=PALETTE[0])
        ax.set_xlabel(xlabel)
        ax.set_ylabel("states")
    ax = axes[3]
    theta = np.asarray(hierarchy["mean_Theta"].values, dtype=float)
    ax.plot(theta, hierarchy["rms_u_z_rel"].values, "o-", color=PALETTE[1], label="$u_z/l_0$")
    ax.plot(theta, hierarchy["rms_u_r_rel"].values, "s--", color=PALETTE[2], label="$u_r/l_0$")
    ax.set_xlabel(r"branch mean $\Theta$")
    ax.set_ylabel("RMS")
    ax.legend(fontsize=FONT_SIZE - 1, frameon=False)
    for a in axes:
        _style(a)
    return axes
