"""Bar chart of design sensitivities (:mod:`biplan.analysis.sensitivity.equilibrium`).

:func:`elasticities` draws, for one observable y, the normalised sensitivity (p / y) ∂y/∂p of
every parameter p as a horizontal bar (positive: vermillion, negative: blue; Okabe–Ito), the
parameters in the order of the result. It follows the :mod:`biplan.plot` contract
``f(result, *, ax=None) -> Axes``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.plot.response import COLUMN_FIGSIZE, FONT_SIZE, _new_axes, _style

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from biplan.analysis.sensitivity.equilibrium import Observable, Sensitivity

__all__ = ["elasticities"]

POSITIVE_COLOR = "#D55E00"
NEGATIVE_COLOR = "#0072B2"


def elasticities(
    result: Sensitivity, *, observable: Observable | str | None = None, ax: Axes | None = None
) -> Axes:
    """Horizontal bars of (p / y) ∂y/∂p of one observable over the result's parameters.

    Parameters
    ----------
    result : Sensitivity
    observable : Observable or str, optional
        Default the result's first observable.
    ax : Axes, optional

    Returns
    -------
    Axes
    """
    names = [o.value for o in result.observables]
    name = names[0] if observable is None else getattr(observable, "value", observable)
    i = names.index(str(name))
    values = np.nan_to_num(result.elasticities[i], nan=0.0)
    labels = [p.name for p in result.parameters]
    height = max(COLUMN_FIGSIZE[1], 0.18 * len(labels) + 0.8)
    ax = _new_axes(ax, (COLUMN_FIGSIZE[0], height))
    y = np.arange(len(labels))[::-1]
    colors: Any = [POSITIVE_COLOR if v >= 0 else NEGATIVE_COLOR for v in values]
    ax.barh(y, values, color=colors, height=0.7)
    ax.axvline(0.0, color="0.3", lw=0.6)
    ax.set_yticks(y, labels, fontsize=FONT_SIZE - 1)
    ax.set_xlabel(rf"$(p/y)\,\partial y/\partial p$, y = {name}")
    ax.set_title(f"{name} = {result.values[i]:.4g} {result.observables[i].unit}")
    _style(ax)
    return ax
