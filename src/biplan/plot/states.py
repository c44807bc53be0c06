"""Figures of the stable-state analysis (main Fig. 4 A–C, SI distributions figure).

* :func:`transition_diagram` — the state-transition graph, states in columns by number of open
  folds, Hamming-1 edges in grey and chosen pathways highlighted; a graph whose tallest column
  holds more than :data:`MAX_NAMED_ROWS` states (thousands of states of a long tube) is drawn
  aggregated: each column a density of small dots spread over a height proportional to its
  size, its count on top, edges faint, and names only on the pathways' states;
* :func:`endpoint_space` — the 3D scatter of the states in (u_z/l₀, u_r/l₀, Θ), coloured by
  slope branch (open helical folds); the Θ axis spans Θ's range ([0, 1], or [−1, 1] when a
  state tilts the other way) and the title states what Θ = 1 is (max |θ| in rad); states are
  named only where their names do not overlap (:func:`readable_labels`), and the title says
  how many are;
* :func:`distributions` — state counts over Θ, u_z/l₀ and u_r/l₀ and the branch-wise RMS
  relations, from :func:`biplan.analysis.states.hierarchy.hierarchy`.

:func:`write_state_figures` writes the three as :data:`STATE_FIGURES` (``biplan states``; the
paper's pathways p1–p3 highlighted on the transition diagram).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.plot.files import pyplot, save
from biplan.plot.response import FONT_SIZE, _new_axes, _style

if TYPE_CHECKING:
    import networkx as nx
    from matplotlib.axes import Axes

    from biplan.analysis.states.catalogue import StateCatalogue

__all__ = [
    "STATE_FIGURES",
    "branch_colours",
    "display_extent",
    "distributions",
    "endpoint_space",
    "readable_labels",
    "transition_diagram",
    "write_state_figures",
]

#: The figures :func:`write_state_figures` writes, in order.
STATE_FIGURES = ("transitions.png", "endpoint_space.png", "distributions.png")

#: Height [in] per state of the tallest column of :func:`transition_diagram` (a 4.2-in figure
#: holds 20; larger catalogues, e.g. 242 states of a five-module tube, get a taller figure).
ROW_HEIGHT = 0.165
#: Gap [px] :func:`readable_labels` keeps between two names.
LABEL_GAP = 2.0
#: Tallest column of :func:`transition_diagram` drawn with every state named (≈ 17 in).
MAX_NAMED_ROWS = 100
#: Most names :func:`endpoint_space` tries to place (extremes first, then by energy), and the
#: fewer it tries in a cloud of more than :data:`DENSE_STATES` states.
MAX_NAME_CANDIDATES = 150
DENSE_NAME_CANDIDATES = 40
DENSE_STATES = 300

#: Legend entries of the endpoint-space figure above which the legend has two columns.
LEGEND_ROWS = 6
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
    per state, at least 4.2 in). Above :data:`MAX_NAMED_ROWS` states in a column it is drawn
    aggregated (module docstring), 7 × 6 in.

    Parameters
    ----------
    graph : networkx.Graph
        From :func:`biplan.analysis.states.transitions.transition_graph`.
    pathways : sequence of sequences of state names
        Drawn in colour, in order, labelled ``names`` (default p1, p2, …).
    """
    pos = _positions(graph)
    # a column of n states needs ~ROW_HEIGHT inches per state to keep labels apart
    tallest = max((round(2 * abs(y)) + 1 for _, y in pos.values()), default=1)
    aggregate = tallest > MAX_NAMED_ROWS
    if aggregate:
        pos = {n: (x, y / tallest) for n, (x, y) in pos.items()}
    size = (7.0, 6.0) if aggregate else (7.0, max(4.2, ROW_HEIGHT * tallest + 0.9))
    ax = _new_axes(ax, size)
    n_edges = graph.number_of_edges()
    edge_alpha = min(1.0, 400.0 / max(n_edges, 1)) if aggregate else 1.0
    from matplotlib.collections import LineCollection

    segments = [(pos[u], pos[v]) for u, v in graph.edges]
    ax.add_collection(
        LineCollection(
            segments,
            colors="0.8" if not aggregate else "0.55",
            linewidths=0.6 if not aggregate else 0.3,
            alpha=edge_alpha,
            zorder=1,
            rasterized=aggregate,
        )
    )
    names = list(names) if names is not None else [f"p{k + 1}" for k in range(len(pathways))]
    for k, path in enumerate(pathways):
        xy = np.array([pos[n] for n in path])
        color = PALETTE[k % len(PALETTE)]
        ax.plot(xy[:, 0], xy[:, 1], color=color, lw=2.0, zorder=2, label=names[k])
    xy = np.array(list(pos.values())) if pos else np.zeros((0, 2))
    if aggregate:
        ax.scatter(xy[:, 0], xy[:, 1], s=3, color="0.2", lw=0, zorder=3, rasterized=True)
        named = {n for path in pathways for n in path}
        for node in sorted(named):
            x, y = pos[node]
            ax.scatter([x], [y], s=60, color="white", edgecolor="0.2", lw=0.7, zorder=4)
            ax.annotate(
                f" {node}", (x, y), ha="left", va="center", fontsize=FONT_SIZE - 3, zorder=5
            )
        columns: dict[float, int] = {}
        for x, _ in pos.values():
            columns[x] = columns.get(x, 0) + 1
        for x, count in columns.items():
            ax.annotate(f"{count}", (x, 0.53), ha="center", va="bottom", fontsize=FONT_SIZE - 3)
        ax.set_ylim(-0.55, 0.6)
        ax.set_title(
            f"{graph.number_of_nodes()} states, {n_edges} single-fold transitions "
            "(states per column on top)",
            fontsize=FONT_SIZE - 1,
        )
    else:
        for node, (x, y) in pos.items():
            ax.scatter([x], [y], s=140, color="white", edgecolor="0.2", lw=0.7, zorder=3)
            ax.annotate(node, (x, y), ha="center", va="center", fontsize=FONT_SIZE - 2, zorder=4)
    if len(xy):
        ax.set_xlim(xy[:, 0].min() - 0.6, xy[:, 0].max() + 0.6)
        if not aggregate:
            ax.set_ylim(xy[:, 1].min() - 0.6, xy[:, 1].max() + 0.6)
    ax.set_xlabel("open folds")
    ax.set_yticks([])
    for side in ("left", "right", "top"):
        ax.spines[side].set_visible(False)
    if pathways:
        ax.legend(fontsize=FONT_SIZE, frameon=False, loc="upper left")
    _style(ax)
    return ax


def readable_labels(texts: Sequence[Any], occupied: Sequence[Any] = ()) -> list[Any]:
    """Hide every text of ``texts`` (in priority order) that would overlap, in display
    coordinates (with a gap of :data:`LABEL_GAP` px), a text kept before it or an artist of
    ``occupied`` (a legend, a title: never hidden); returns the texts kept.

    The figure is drawn first, so that the positions are those of its final layout.
    """
    if not texts:
        return []
    fig = texts[0].get_figure(root=True)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    kept: list[Any] = []
    boxes = [a.get_window_extent(renderer) for a in occupied]
    for text in texts:
        box = display_extent(text, renderer).padded(LABEL_GAP / 2)
        if any(box.overlaps(other) for other in boxes):
            text.set_visible(False)
            continue
        kept.append(text)
        boxes.append(box)
    return kept


def display_extent(text: Any, renderer: Any) -> Any:
    """A text's box in display coordinates, where it is drawn. A 3D text (``ax.text(x, y, z,
    …)`` on 3D axes) is drawn at the projection of (x, y, z), but its ``get_window_extent``
    places it at (x, y) in the projected plane; here it is measured at the projected point
    (the axes' current projection)."""
    if not hasattr(text, "get_position_3d"):
        return text.get_window_extent(renderer)
    from matplotlib.text import Text
    from mpl_toolkits.mplot3d import proj3d

    x, y, z = text.get_position_3d()
    px, py, _ = proj3d.proj_transform(x, y, z, text.axes.get_proj())
    where = text.get_position()
    Text.set_position(text, (px, py))
    try:
        return Text.get_window_extent(text, renderer)
    finally:
        Text.set_position(text, where)


def _label_order(states: Any, points: np.ndarray) -> list[int]:
    """States to name first: the extremes of each coordinate, then by energy (lowest first,
    when the catalogue has it), then in catalogue order."""
    first: list[int] = []
    for column in points.T:
        for k in (int(np.argmin(column)), int(np.argmax(column))):
            if k not in first:
                first.append(k)
    rest = np.arange(len(points))
    if "energy" in states:
        rest = np.argsort(np.asarray(states["energy"].values, dtype=float), kind="stable")
    return first + [int(k) for k in rest if int(k) not in first]


def branch_colours(n: int) -> list[Any]:
    """Colours of slope branches 0 … n − 1: the Okabe–Ito :data:`PALETTE` while it has
    enough, else n distinct colours along viridis (so no two branches share a colour)."""
    if n <= len(PALETTE):
        return list(PALETTE[:n])
    import matplotlib

    cmap = matplotlib.colormaps["viridis"]
    return [cmap(k / (n - 1)) for k in range(n)]


def endpoint_space(states: Any, *, ax: Axes | None = None, annotate: bool = True) -> Axes:
    """3D scatter of the states in endpoint space (u_z/l₀, u_r/l₀, Θ), by slope branch.

    Θ = θ / max|θ| (MODEL §15): its axis spans [0, 1], or [−1, 1] when a state tilts the
    other way, and the title gives max|θ| [rad] when the catalogue holds θ. The names of the
    states are drawn only where they do not overlap (:func:`readable_labels`, extremes first,
    then by energy); the title says how many of the states are named.

    Parameters
    ----------
    states : xarray.Dataset
        A state catalogue (``StateCatalogue.to_dataset()`` or a ``states.nc`` file).
    annotate : bool
        Name the states (a readable subset).
    """
    ax = _new_axes(ax, (4.2, 3.8), projection="3d")
    l0 = float(states.attrs["initial_length"])
    uz = np.asarray(states["u_z"].values, dtype=float) / l0
    ur = np.asarray(states["u_r"].values, dtype=float) / l0
    th = np.asarray(states["Theta"].values, dtype=float)
    hel = np.asarray(states["n_open_helical"].values, dtype=int)
    marker = float(np.clip(14.0 * np.sqrt(66.0 / max(uz.size, 1)), 2.0, 14.0))
    branches = np.unique(hel)
    colours = branch_colours(int(branches.max(initial=0)) + 1)
    for b in branches:
        sel = hel == b
        ax.scatter(  # type: ignore[misc]
            uz[sel],
            ur[sel],
            th[sel],
            s=marker,
            color=colours[int(b)],
            label=f"{b} open helical",
            depthshade=False,
        )
    ax.set_xlabel("$u_z/l_0$")
    ax.set_ylabel("$u_r/l_0$")
    ax.set_zlabel(r"$\Theta = \theta/\max|\theta|$")  # type: ignore[attr-defined]
    low = -1.0 if np.nanmin(th, initial=0.0) < 0.0 else 0.0
    ax.set_zlim(low, 1.0)  # type: ignore[attr-defined]
    ax.set_zticks(np.linspace(low, 1.0, 3 if low == 0.0 else 5))  # type: ignore[attr-defined]
    columns = 1 if branches.size <= LEGEND_ROWS else 2
    legend = ax.legend(
        fontsize=FONT_SIZE - 1 - (columns - 1), frameon=False, loc="upper left", ncol=columns
    )
    _style(ax)
    scale = f"Θ ∈ [{low:g}, 1]"
    if "theta" in states:
        theta = np.abs(np.asarray(states["theta"].values, dtype=float))
        scale += f", Θ = 1 at |θ| = {np.nanmax(theta, initial=0.0):.3g} rad"
    texts = []
    if annotate:
        names = [str(n) for n in states["state"].values]
        order = _label_order(states, np.column_stack([uz, ur, th]))
        tried = MAX_NAME_CANDIDATES if uz.size <= DENSE_STATES else DENSE_NAME_CANDIDATES
        for k in order[:tried]:
            text = ax.text(uz[k], ur[k], th[k], f" {names[k]}", fontsize=FONT_SIZE - 3)  # type: ignore[arg-type]
            texts.append(text)
    n = uz.size
    count = "\nnames: {} of {} states" if annotate else ""
    title = ax.set_title(scale + count.format(n, n), fontsize=FONT_SIZE - 1)
    kept = readable_labels(texts, occupied=[legend, title])  # same title height: same layout
    title.set_text(scale + count.format(len(kept), n))
    return ax


def distributions(hierarchy: Any, *, fig: Any = None) -> np.ndarray:
    """Four panels: counts over Θ, u_z/l₀, u_r/l₀; RMS of u_z/l₀, u_r/l₀ per slope branch.

    Parameters
    ----------
    hierarchy : xarray.Dataset
        From :func:`biplan.analysis.states.hierarchy.hierarchy`.

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


def write_state_figures(catalogue: StateCatalogue, graph: nx.Graph, out: Path) -> list[Path]:
    """Write :data:`STATE_FIGURES` of a catalogue and its transition graph into the existing
    directory ``out``: the transition diagram with the paper's pathways
    (:func:`~biplan.analysis.states.transitions.paper_pathways`), the endpoint space and the
    distributions; returns the paths."""
    from biplan.analysis.states.hierarchy import hierarchy
    from biplan.analysis.states.transitions import paper_pathways

    pyplot()  # the figures go to files
    paths, names = paper_pathways(graph)
    draw = (
        lambda: transition_diagram(graph, pathways=paths, names=names).figure,
        lambda: endpoint_space(catalogue.to_dataset(seeds=False)).figure,
        lambda: distributions(hierarchy(catalogue))[0].figure,
    )
    files = [out / name for name in STATE_FIGURES]
    for figure, file in zip(draw, files, strict=True):
        save(figure(), file)  # one figure open at a time
    return files
