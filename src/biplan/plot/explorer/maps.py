"""The explorer page of a force-ramp design map (``map.nc`` of ``biplan map design``).

Panels: the terminal u_z/l₀ and u_r/l₀ as heatmaps over the map's two axes (b, C), the swept
design starred (for the paper's design the validated one; :func:`biplan.plot.maps.design_map`);
clicking a cell selects it in both and shows that design's ramp response (force against
load-point displacement, the quasi-static steps and the dynamic finish after a snap,
:func:`biplan.analysis.maps.ramp_curves.ramp_curves`) and its terminal shape (tube and planar
development). Designs of different b have different element polygons, so the page holds one
reference mesh per b (:class:`~biplan.plot.explorer.shapes.ShapeSet`), decimated further
(:data:`MAP_SUBDIVISIONS`) than the other pages'.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.plot.explorer.page import Page, PageKind, panel, shape_panels
from biplan.plot.explorer.shapes import shape_set
from biplan.plot.maps import VALIDATED_DESIGN

if TYPE_CHECKING:
    from biplan.analysis.maps.ramp_curves import RampCurve
    from biplan.model.tube import Tube

__all__ = ["MAP_SUBDIVISIONS", "map_page"]

#: Strips per circumference of the map page's meshes (one mesh per b value).
MAP_SUBDIVISIONS = 16
_TITLES = {"u_z": "terminal u_z/l0", "u_r": "terminal u_r/l0"}


def _number(value: Any) -> float | None:
    x = float(value)
    return x if np.isfinite(x) else None


def _star(dataset: Any) -> tuple[float, float]:
    base = (dataset["b"].attrs.get("base_value"), dataset["C"].attrs.get("base_value"))
    return VALIDATED_DESIGN if None in base else (float(base[0]), float(base[1]))


def _heatmap(dataset: Any, variable: str, cell_index: np.ndarray, star: tuple) -> Any:
    import plotly.graph_objects as go

    da = dataset[variable].transpose("C", "b")
    fig = go.Figure()
    fig.add_heatmap(
        x=dataset["b"].values, y=dataset["C"].values, z=da.values,
        customdata=cell_index.T, colorscale="Viridis", colorbar={"title": {"text": "/l0"}},
        hovertemplate="b = %{x:.3g}<br>C = %{y:.3g}<br>%{z:.4g}<extra></extra>",
    )  # fmt: skip
    fig.add_scatter(x=[star[0]], y=[star[1]], mode="markers", name="swept design",
                    marker={"symbol": "star", "size": 16, "color": "white",
                            "line": {"color": "black", "width": 1}},
                    hovertemplate="swept design<extra></extra>")  # fmt: skip
    fig.add_scatter(x=[], y=[], mode="markers", name="selected", hoverinfo="skip",
                    marker={"symbol": "square-open", "size": 18, "color": "#D55E00",
                            "line": {"width": 3}})  # fmt: skip
    fig.update_layout(
        xaxis={"title": {"text": "geometric ratio b"}},
        yaxis={"title": {"text": "stiffness ratio C"}},
        margin={"l": 55, "r": 10, "t": 10, "b": 45},
        showlegend=False,
    )
    return fig


def map_page(
    dataset: Any,
    designs: Sequence[Tube | None],
    curves: Sequence[RampCurve | None],
    *,
    source: str = "",
) -> Page:
    """The explorer page of a design map.

    Parameters
    ----------
    dataset : xarray.Dataset
        A force-ramp design map over (b, C) (``biplan map design``).
    designs, curves : sequence
        The tube and the ramp response of every point, row-major in the order of the map's
        variables' dims (:func:`biplan.analysis.maps.ramp_curves.map_designs`); None where a design
        is invalid or was not followed.
    source : str
        Where the map came from (shown under the title).

    Returns
    -------
    Page
    """
    from biplan.model.assembly import Model

    dims = dataset["u_z"].dims
    shape = tuple(dataset.sizes[d] for d in dims)
    cell_index = np.arange(int(np.prod(shape))).reshape(shape)
    if dims != ("b", "C"):
        cell_index = np.moveaxis(cell_index, [dims.index("b"), dims.index("C")], [0, 1])
    groups: dict[float, list[int]] = {}
    for i, tube in enumerate(designs):
        if tube is not None and curves[i] is not None:
            groups.setdefault(round(float(tube.b), 12), []).append(i)
    shape_sets, where = [], {}
    for which in groups.values():
        model = Model(designs[which[0]])  # type: ignore[arg-type]
        qs = np.asarray([curves[i].q for i in which])  # type: ignore[union-attr]
        shape_sets.append(shape_set(model, qs, subdivisions=MAP_SUBDIVISIONS).to_json())
        where.update({i: [len(shape_sets) - 1, k] for k, i in enumerate(which)})
    flat = {v: np.asarray(dataset[v].values).reshape(-1) for v in dataset.data_vars}
    cells = []
    for i in range(cell_index.size):
        point = np.unravel_index(i, shape)
        c = curves[i]
        cells.append(
            {
                "b": float(dataset["b"].values[point[dims.index("b")]]),
                "C": float(dataset["C"].values[point[dims.index("C")]]),
                "u_z": _number(flat["u_z"][i]),
                "u_r": _number(flat["u_r"][i]),
                "stability_lost": _number(flat["stability_lost"][i]),
                "time_lost": _number(flat["time_lost"][i]),
                "note": "no response (invalid design)" if c is None else
                ("ramp not finished" if not c.completed else
                 ("dynamically after a snap" if c.dynamic else "quasi-statically")),
                "force": [] if c is None else np.round(c.force, 6).tolist(),
                "displacement": [] if c is None else np.round(c.displacement, 6).tolist(),
                "dynamic_force": [] if c is None else np.round(c.dynamic_force, 6).tolist(),
                "dynamic_displacement": [] if c is None else
                np.round(c.dynamic_displacement, 6).tolist(),
                "shape": where.get(i),
            }
        )  # fmt: skip
    star = _star(dataset)
    figures = {f"map-{v}": _heatmap(dataset, v, cell_index, star) for v in ("u_z", "u_r")}
    near = np.argmin([np.hypot(c["b"] - star[0], c["C"] - star[1]) if c["shape"] else np.inf
                      for c in cells])  # fmt: skip
    body = "".join(
        [
            '<div class="row">',
            panel("map-u_z", _TITLES["u_z"], note="click a cell; ☆ the swept design"),
            panel("map-u_r", _TITLES["u_r"], note="click a cell"),
            "</div>",
            panel("curve", "Ramp response of the selected design", wide=True),
            shape_panels(),
        ]
    )
    rate = float(dataset.attrs.get("setting_rate_N_per_s", np.nan))
    duration = float(dataset.attrs.get("setting_duration_s", np.nan))
    subtitle = (
        f"{source + ': ' if source else ''}{cell_index.size} designs over (b, C), force ramp "
        f"{rate:g} N/s for {duration:g} s; ☆ b = {star[0]:.3g}, C = {star[1]:.3g}"
    )
    return Page(
        kind=PageKind.design_map,
        title="biplan explorer: design map",
        subtitle=subtitle,
        body=body,
        figures=figures,
        data={
            "cells": cells,
            "shape_sets": shape_sets,
            "final_force": rate * duration,
            "traces": {"selected": 2},
            "start": int(near),
        },
    )
