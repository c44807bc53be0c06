"""The explorer page of a response (``response.nc`` of ``biplan respond``; a path, trajectory
or stable-branch sweep).

Panels: the force–displacement curve (the pressure under pressure control), with a slider
that moves through the saved steps (at most :data:`MAX_SHAPES`, evenly spaced, the last one
always among them) and a marker on the curve; the tube and the planar development at the
chosen step, with its load, displacement, endpoint values, energy and λ_min. Clicking a point
of the curve moves the slider there.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.plot.explorer.page import Page, PageKind, panel, shape_panels
from biplan.plot.explorer.shapes import shape_set

if TYPE_CHECKING:
    from biplan.model.assembly import Model

__all__ = ["MAX_SHAPES", "response_page", "shown_steps"]

#: Most steps a response page holds shapes of.
MAX_SHAPES = 300
STABLE_COLOR = "#0072B2"
UNSTABLE_COLOR = "#D55E00"


def shown_steps(n: int, most: int = MAX_SHAPES) -> np.ndarray:
    """Indices of the steps shown of ``n``: every step when n ≤ ``most``, else an even
    stride, the last step always included."""
    stride = max(1, int(np.ceil(n / most)))
    index = np.arange(0, n, stride)
    return index if index[-1] == n - 1 else np.r_[index, n - 1]


def _values(dataset: Any, name: str, index: np.ndarray) -> list[float | None]:
    if name not in dataset:
        return [None] * len(index)
    v = np.asarray(dataset[name].values, dtype=float)[index]
    return [float(x) if np.isfinite(x) else None for x in v]


def response_page(dataset: Any, model: Model, *, source: str = "") -> Page:
    """The explorer page of a response dataset.

    Parameters
    ----------
    dataset : xarray.Dataset
        A path, trajectory or stable-branch sweep (dims ``step`` or ``time``) with ``force``,
        ``displacement`` and ``q``.
    model : Model
        The model of its tube.
    source : str
        Where the response came from (shown under the title).

    Returns
    -------
    Page
    """
    import plotly.graph_objects as go

    dim = "time" if "time" in dataset.dims else "step"
    n = dataset.sizes[dim]
    index = shown_steps(n)
    pressure = dataset.attrs.get("control") == "pressure" and "load_parameter" in dataset
    load_var = "load_parameter" if pressure else "force"
    unit = dataset[load_var].attrs.get("units", "kPa" if pressure else "N")
    load_name = f"{'pressure p' if pressure else 'force F'} [{unit}]"
    load = np.asarray(dataset[load_var].values, dtype=float)
    u = np.asarray(dataset["displacement"].values, dtype=float)
    stable = (
        np.asarray(dataset["stable"].values, dtype=bool)
        if "stable" in dataset
        else np.ones(n, bool)
    )
    fig = go.Figure()
    fig.add_scatter(x=u, y=load, mode="lines", line={"color": "#999999", "width": 1},
                    hoverinfo="skip", name="all saved steps")  # fmt: skip
    styles = ((True, STABLE_COLOR, "stable"), (False, UNSTABLE_COLOR, "unstable"))
    for flag, color, name in styles:
        pick = np.flatnonzero(stable[index] == flag)
        if pick.size:
            fig.add_scatter(x=u[index[pick]], y=load[index[pick]], customdata=pick,
                            mode="markers", marker={"size": 6, "color": color}, name=name,
                            hovertemplate="U = %{x:.4g} mm<br>%{y:.4g}<extra></extra>")  # fmt: skip
    selected = len(fig.data)
    fig.add_scatter(x=[], y=[], mode="markers", name="shown", hoverinfo="skip",
                    marker={"size": 16, "color": "rgba(0,0,0,0)",
                            "line": {"color": "#000000", "width": 3}})  # fmt: skip
    fig.update_layout(
        xaxis={"title": {"text": "load-point displacement U [mm]"}},
        yaxis={"title": {"text": load_name}},
        margin={"l": 60, "r": 10, "t": 10, "b": 45},
        legend={"orientation": "h", "y": 1.08},
        hovermode="closest",
    )
    axis_value = np.asarray(dataset[dim].values, dtype=float)[index]
    steps = {
        "index": index.tolist(),
        "axis": dim,
        "axis_value": axis_value.tolist(),
        "load": _values(dataset, load_var, index),
        "displacement": _values(dataset, "displacement", index),
        "u_z": _values(dataset, "u_z", index),
        "u_r": _values(dataset, "u_r", index),
        "theta": _values(dataset, "theta", index),
        "energy": _values(dataset, "energy", index),
        "min_eigenvalue": _values(dataset, "min_eigenvalue", index),
    }
    shapes = shape_set(model, np.asarray(dataset["q"].values, dtype=float)[index])
    body = "".join(
        [
            panel("curve", "Response", note="click a point, or move the slider below", wide=True),
            '<section class="panel wide controls"><label>shape <input type="range" '
            'id="step-slider" min="0" max="0" step="1" value="0"></label>'
            '<span id="step-text"></span></section>',
            shape_panels(),
        ]
    )
    kind = str(dataset.attrs.get("kind", "response"))
    subtitle = (
        f"{source + ': ' if source else ''}{kind} of a {model.layout.n_modules}-module tube, "
        f"{n} saved {dim}s, {len(index)} shapes"
    )
    return Page(
        kind=PageKind.response,
        title="biplan explorer: response",
        subtitle=subtitle,
        body=body,
        figures={"curve": fig},
        data={
            "steps": steps,
            "load_name": load_name,
            "traces": {"selected": selected},
            "shapes": shapes.to_json(),
            "start": len(index) - 1,
        },
    )
