"""A gallery of stable states: 3D thumbnails in the order of the endpoint-space hierarchy.

The paper orders the stable states of a fully bistable MFT in endpoint space by a three-level
hierarchy (main text, "Hierarchical State Space"): the number of open helical folds sets the
endpoint-slope branch Θ, and within a branch the circular folds set the elongation u_z.
:func:`order_states` sorts a state catalogue by (number of open helical folds, u_z), the
count taken from each state's coordinates (a helical fold is open when more than half of its
length lies on the open branch of its law); :func:`gallery` draws the tubes in that order,
row by row, each labelled by its hexadecimal fold-state code and its slope Θ.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, cast

import numpy as np
from matplotlib.layout_engine import ConstrainedLayoutEngine

from biplan.plot.cylinder import cylinder, set_limits3d
from biplan.plot.response import FONT_SIZE
from biplan.plot.tube import add_colorbar, elongation_norm, fold_scale

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.axes3d import Axes3D

    from biplan.model.assembly import Model

__all__ = ["gallery", "open_helical_folds", "order_states"]

#: Width [in] of one thumbnail and height of one gallery row.
PANEL_WIDTH = 0.85
ROW_HEIGHT = 1.3


def open_helical_folds(model: Model, q: np.ndarray) -> int:
    """Number of helical folds with more than half their length on the open branch."""
    w = model.helical_boundary(q)
    count = 0
    for law, (w0, wa) in zip(model.tube.helical_laws, w, strict=True):
        if getattr(law, "transitions", None) is not None:
            count += int(np.asarray(law.phase_fractions(w0, wa))[2] > 0.5)
    return count


def order_states(states: Any, model: Model) -> np.ndarray:
    """Indices of a state catalogue in hierarchy order: open helical folds, then u_z.

    Parameters
    ----------
    states : xarray.Dataset
        A state catalogue (dims ``state``, ``coordinate``; ``q``, ``u_z``).
    model : Model

    Returns
    -------
    ndarray of int
        A permutation of ``range(n_states)``; ties keep the catalogue order.
    """
    qs = np.asarray(states["q"].values, dtype=float)
    n_open = np.array([open_helical_folds(model, q) for q in qs])
    u_z = np.asarray(states["u_z"].values, dtype=float)
    return np.lexsort((np.arange(len(qs)), u_z, n_open))


def gallery(
    states: Any,
    model: Model,
    *,
    ncols: int | None = None,
    color_by: str = "phase",
    elev: float = 20.0,
    azim: float = -60.0,
) -> Figure:
    """Draw every state of a catalogue as a 3D thumbnail, in hierarchy order.

    Parameters
    ----------
    states : xarray.Dataset
        A state catalogue (``kind = "states"``): ``q(state, coordinate)``, ``label(state)``
        (hex code), ``u_z`` [mm] and, optionally, ``Theta`` (normalised slope).
    model : Model
        The model of the catalogue (:func:`biplan.io.results.model_of`).
    ncols : int, optional
        Thumbnails per row; default min(n_states, 8) (a 7 in page width).
    color_by : {"phase", "elongation"}
        Fold colouring (one scale and one colorbar for all thumbnails).
    elev, azim : float
        View [degrees].

    Returns
    -------
    Figure
        One 3D Axes per state at a common scale (a scale bar in the first), titled with the
        label (and Θ); unused grid cells are removed.

    Raises
    ------
    ValueError
        For an empty catalogue or an unknown ``color_by``.
    """
    import matplotlib.pyplot as plt

    qs = np.asarray(states["q"].values, dtype=float)
    if not len(qs):
        raise ValueError("the state catalogue is empty")
    order = order_states(states, model)
    ncols = ncols or min(len(qs), 8)
    nrows = -(-len(qs) // ncols)
    norm = elongation_norm(model, qs) if color_by == "elongation" else None
    cmap, norm = fold_scale(color_by, norm, model, qs[0])
    fig = plt.figure(figsize=(PANEL_WIDTH * ncols + 0.9, ROW_HEIGHT * nrows), layout="constrained")
    labels = states["label"].values if "label" in states else np.arange(len(qs)).astype(str)
    theta = states["Theta"].values if "Theta" in states else None
    radius = model.tube.development.radius
    z = np.stack([model.global_nodes(q)[..., 0] for q in qs])
    lo, hi = [-1.8 * radius, -radius, min(0.0, float(z.min()))], [radius, radius, float(z.max())]
    axes = []
    for i, k in enumerate(order):
        ax = cast("Axes3D", fig.add_subplot(nrows, ncols, i + 1, projection="3d"))
        cylinder(
            model,
            qs[k],
            ax=ax,
            elev=elev,
            azim=azim,
            color_by=color_by,
            norm=norm,
            scale_bar=i == 0,  # one scale bar for the gallery
        )
        set_limits3d(ax, np.array(lo), np.array(hi))
        title = str(labels[k])
        if theta is not None:
            title += f"\n$\\Theta$ = {np.round(float(theta[k]), 2) + 0.0:.2f}"  # no "-0.00"
        ax.set_title(title, fontsize=FONT_SIZE, pad=0)
        ax.set_gid(f"state-{labels[k]}")
        axes.append(ax)
    add_colorbar(axes, color_by, cmap, norm)
    engine = fig.get_layout_engine()
    if isinstance(engine, ConstrainedLayoutEngine):
        engine.set(rect=(0.05, 0.0, 0.95, 1.0))  # room for the scale-bar label
    return fig
