"""The explorer page of a state catalogue (``states.nc`` of ``biplan states``).

Panels: the transition graph with the states in columns by number of open folds (the layout
of Fig. 4 A, :func:`biplan.plot.states.transition_diagram`), nodes coloured by slope branch
(number of open helical folds) and edges by barrier when the graph carries them; the endpoint
space (u_z/l₀, u_r/l₀, Θ) as a rotatable 3D scatter (Fig. 4 B); the selected state's 3D tube
and planar development with its label, bits, energy, λ_min and endpoint values. Clicking a
state in the graph or in endpoint space selects it in both; choosing two states highlights
the pathway between them (fewest fold switches, or least total barrier climbed when the
edges carry barriers: :func:`biplan.analysis.states.transitions.pathway`) in both panels, and the
step buttons move the selection along it, shape by shape.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.plot.explorer.page import Page, PageKind, panel, shape_panels
from biplan.plot.explorer.shapes import shape_set
from biplan.plot.states import PALETTE, _positions

if TYPE_CHECKING:
    import networkx as nx

    from biplan.model.assembly import Model

__all__ = ["MAX_NAMED", "catalogue_page"]

#: Largest catalogue whose graph nodes carry their names as text (larger: on hover only).
MAX_NAMED = 150
#: Colours of the barrier classes of the edges (light to dark) and of edges without one.
BARRIER_COLORS = ("#c6dbef", "#6baed6", "#2171b5", "#08306b")
EDGE_COLOR = "#bbbbbb"
PATH_COLOR = "#D55E00"
SELECTED_COLOR = "#000000"


def _float(value: Any) -> float | None:
    x = float(value)
    return x if np.isfinite(x) else None


def _states(dataset: Any) -> dict[str, Any]:
    """Per-state values for the script (lists in the order of the ``state`` dimension)."""
    l0 = float(dataset.attrs.get("initial_length", np.nan))

    def column(name: str) -> np.ndarray:
        return np.asarray(dataset[name].values)

    theta = column("theta").astype(float)
    scale = float(np.max(np.abs(theta))) if theta.size else 0.0
    big_theta = column("Theta").astype(float) if "Theta" in dataset else theta / max(scale, 1e-12)
    return {
        "name": [str(n) for n in dataset["state"].values],
        "bits": [str(b) for b in column("bits")],
        "branch": [int(b) for b in column("n_open_helical")],
        "energy": [_float(v) for v in column("energy")],
        "min_eigenvalue": [_float(v) for v in column("min_eigenvalue")],
        "u_z": [_float(v) for v in column("u_z")],
        "u_r": [_float(v) for v in column("u_r")],
        "theta": [_float(v) for v in theta],
        "Theta": [_float(v) for v in big_theta],
        "u_z_l0": [_float(v / l0) for v in column("u_z")],
        "u_r_l0": [_float(v / l0) for v in column("u_r")],
    }


def _edges(graph: nx.Graph, index: dict[str, int]) -> list[list[Any]]:
    """[i, j, fold name, saddle energy or None] of every edge."""
    rows = []
    for u, v, d in graph.edges(data=True):
        saddle = d.get("saddle_energy")
        rows.append([index[u], index[v], str(d.get("fold_name", "")), _float(saddle or np.nan)])
    return rows


def _barrier_bins(edges: list[list[Any]], energy: list[float | None]) -> np.ndarray | None:
    """Edges of the classes of BARRIER_COLORS by the larger of their two barriers (quantile
    bins), or None without barriers."""
    heights = [
        max(s - (energy[i] or 0.0), s - (energy[j] or 0.0)) if s is not None else np.nan
        for i, j, _, s in edges
    ]
    values = np.asarray(heights, dtype=float)
    if not np.isfinite(values).any():
        return None
    finite = values[np.isfinite(values)]
    cuts = np.quantile(finite, np.linspace(0, 1, len(BARRIER_COLORS) + 1)[1:-1])
    return np.where(np.isfinite(values), np.searchsorted(cuts, values), -1)


def _graph_figure(states: dict[str, Any], edges: list, pos: np.ndarray) -> tuple[Any, dict]:
    import plotly.graph_objects as go

    fig = go.Figure()
    bins = _barrier_bins(edges, states["energy"])
    classes = [(-1, EDGE_COLOR, "edge")] if bins is None else [(-1, EDGE_COLOR, "no barrier")]
    if bins is not None:
        classes += [(k, c, f"barrier class {k + 1}") for k, c in enumerate(BARRIER_COLORS)]
    for k, color, name in classes:
        chosen = [e for m, e in enumerate(edges) if (bins is None or bins[m] == k)]
        if not chosen:
            continue
        x = [v for i, j, *_ in chosen for v in (pos[i, 0], pos[j, 0], None)]
        y = [v for i, j, *_ in chosen for v in (pos[i, 1], pos[j, 1], None)]
        fig.add_scatter(x=x, y=y, mode="lines", line={"color": color, "width": 1}, name=name,
                        hoverinfo="skip", showlegend=bins is not None)  # fmt: skip
    path = len(fig.data)
    fig.add_scatter(x=[], y=[], mode="lines", line={"color": PATH_COLOR, "width": 4},
                    name="pathway", hoverinfo="skip")  # fmt: skip
    named = len(states["name"]) <= MAX_NAMED
    branches = np.asarray(states["branch"])
    for b in sorted(set(branches.tolist())):
        idx = np.flatnonzero(branches == b)
        fig.add_scatter(
            x=pos[idx, 0], y=pos[idx, 1], customdata=idx,
            mode="markers+text" if named else "markers",
            text=[states["name"][i] for i in idx], textfont={"size": 9},
            marker={"size": 16 if named else 7, "color": PALETTE[b % len(PALETTE)],
                    "line": {"color": "#333333", "width": 0.5}},
            name=f"{b} open helical", hovertemplate="%{text}<extra></extra>",
        )  # fmt: skip
    selected = len(fig.data)
    fig.add_scatter(x=[], y=[], mode="markers", hoverinfo="skip", name="selected",
                    marker={"size": 22, "color": "rgba(0,0,0,0)",
                            "line": {"color": SELECTED_COLOR, "width": 3}})  # fmt: skip
    fig.update_layout(
        xaxis={"title": "open folds", "dtick": 1, "zeroline": False},
        yaxis={"visible": False},
        margin={"l": 30, "r": 10, "t": 10, "b": 40},
        legend={"orientation": "h", "y": 1.02, "yanchor": "bottom"},
        clickmode="event",
        hovermode="closest",
    )
    return fig, {"path": path, "selected": selected}


def _endpoint_figure(states: dict[str, Any], theta_max: float) -> tuple[Any, dict]:
    import plotly.graph_objects as go

    fig = go.Figure()
    branches = np.asarray(states["branch"])
    xyz = [states["u_z_l0"], states["u_r_l0"], states["Theta"]]
    for b in sorted(set(branches.tolist())):
        idx = np.flatnonzero(branches == b)
        fig.add_scatter3d(
            x=[xyz[0][i] for i in idx], y=[xyz[1][i] for i in idx], z=[xyz[2][i] for i in idx],
            customdata=idx, text=[states["name"][i] for i in idx], mode="markers",
            marker={"size": 5, "color": PALETTE[b % len(PALETTE)]},
            name=f"{b} open helical", hovertemplate="%{text}<extra></extra>",
        )  # fmt: skip
    path = len(fig.data)
    fig.add_scatter3d(x=[], y=[], z=[], mode="lines", line={"color": PATH_COLOR, "width": 6},
                      name="pathway", hoverinfo="skip")  # fmt: skip
    selected = len(fig.data)
    fig.add_scatter3d(x=[], y=[], z=[], mode="markers", name="selected", hoverinfo="skip",
                      marker={"size": 9, "color": "rgba(0,0,0,0)",
                              "line": {"color": SELECTED_COLOR, "width": 4}})  # fmt: skip
    fig.update_layout(
        scene={
            "xaxis": {"title": {"text": "u_z/l0"}},
            "yaxis": {"title": {"text": "u_r/l0"}},
            "zaxis": {"title": {"text": f"Θ (1 = {theta_max:.3g} rad)"}},
        },
        margin={"l": 0, "r": 0, "t": 10, "b": 0},
        legend={"orientation": "h"},
        uirevision="endpoint",
    )
    return fig, {"path": path, "selected": selected}


GRAPH_NOTE = "states by number of open folds; click a state to select it"
_CONTROLS = (
    '<section class="panel wide controls" id="panel-pathway"><h2>Pathway</h2>'
    '<label>from <select id="path-from"></select></label> '
    '<label>to <select id="path-to"></select></label> '
    '<label>by <select id="path-weight"><option value="switches">fewest fold switches</option>'
    '<option value="barrier">least total barrier</option></select></label> '
    '<button id="path-show" type="button">show pathway</button> '
    '<button id="path-prev" type="button">◀ step</button> '
    '<button id="path-next" type="button">step ▶</button> '
    '<span id="path-text"></span></section>'
)


def catalogue_page(dataset: Any, model: Model, graph: nx.Graph, *, source: str = "") -> Page:
    """The explorer page of a state catalogue.

    Parameters
    ----------
    dataset : xarray.Dataset
        A state catalogue (``attrs["kind"] == "states"``: ``StateCatalogue.to_dataset``) with
        at least one state.
    model : Model
        The model of its tube.
    graph : networkx.Graph
        Its transition graph (:func:`biplan.analysis.states.transitions.transition_graph`), with
        ``saddle_energy`` on the edges where barriers were computed.
    source : str
        Where the catalogue came from (shown under the title).

    Returns
    -------
    Page
    """
    names = [str(n) for n in dataset["state"].values]
    index = {n: k for k, n in enumerate(names)}
    states = _states(dataset)
    layout = _positions(graph)
    pos = np.asarray([layout[n] for n in names], dtype=float)
    edges = _edges(graph, index)
    theta_max = float(np.max(np.abs(np.asarray(dataset["theta"].values, dtype=float))))
    graph_fig, graph_traces = _graph_figure(states, edges, pos)
    endpoint_fig, endpoint_traces = _endpoint_figure(states, theta_max)
    shapes = shape_set(model, np.asarray(dataset["q"].values, dtype=float))
    has_barriers = any(e[3] is not None for e in edges)
    body = "".join(
        [
            _CONTROLS,
            '<div class="row">',
            panel("graph", "Transition graph", note=GRAPH_NOTE),
            panel("endpoint", "Endpoint space", note="drag to rotate; click a state"),
            "</div>",
            shape_panels(),
        ]
    )
    n_edges = graph.number_of_edges()
    subtitle = (
        f"{source + ': ' if source else ''}{len(names)} stable states of a "
        f"{model.layout.n_modules}-module tube, {n_edges} single-fold transitions"
        + ("; barriers [N·mm] on the edges" if has_barriers else "; no barriers computed")
    )
    data = {
        "states": states,
        "edges": edges,
        "has_barriers": has_barriers,
        "graph_pos": np.round(pos, 4).tolist(),
        "traces": {"graph": graph_traces, "endpoint": endpoint_traces},
        "bit_folds": str(dataset.attrs.get("bit_folds", "")),
        "shapes": shapes.to_json(),
        "start": 0,
    }
    return Page(
        kind=PageKind.catalogue,
        title="biplan explorer: stable states",
        subtitle=subtitle,
        body=body,
        figures={"graph": graph_fig, "endpoint": endpoint_fig},
        data=data,
    )
