"""Design and stability maps (paper Fig. 3 A.1 and A.3).

* :func:`design_map` — filled contours of the terminal u_z/l₀ or u_r/l₀ of the force ramp over
  (b, C), with the swept design starred (for the paper's design the validated one, b = 0.573,
  C = 1.444) and points where stability was lost hatched; failed points are left blank.
* :func:`stability_map` — regions coloured monostable / bistable / multistable over (U/l₀, C)
  (grey where no stable equilibrium was found, white where the point failed), the transition
  band hatched and outlined. The axes end at the grid's first and last values (each point's
  cell reaches halfway to its neighbours, so the cells of the outer points are half cells),
  and the legend names only the regimes the map holds.

:func:`write_map_figures` writes the figures of a finished map (``biplan map plot``): ``u_z.png``
and ``u_r.png`` of a design map, ``force.png`` of a first-instability map, ``stability.png`` of
a stability map (:func:`map_figures`).

Same contract as every plotting function: ``f(ds, *, ax=None, ...) -> Axes``; a new
journal-column figure (3.4 × 2.6 in, 8 pt) when no Axes is given; no ``show()``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan._errors import ConfigError
from biplan.plot.files import figure_file
from biplan.plot.response import COLUMN_FIGSIZE, FONT_SIZE, _new_axes, _style, cell_edges

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = [
    "REGIME_COLORS",
    "VALIDATED_DESIGN",
    "design_map",
    "grid_edges",
    "map_figures",
    "stability_map",
    "write_map_figures",
]

#: (b, C) of the validated semi-bistable design (SI Table calib).
VALIDATED_DESIGN = (0.573, 1.444)
#: Okabe–Ito colours of the regimes: monostable, bistable, multistable.
REGIME_COLORS = ("#56B4E9", "#E69F00", "#CC79A7")
#: Colour of points where no stable equilibrium was found (regime 0).
NONE_COLOR = "#BBBBBB"
_LABELS = {"u_z": r"$u_z/l_0$", "u_r": r"$u_r/l_0$", "force": r"first instability $F^*$ [N]"}


def grid_edges(x: np.ndarray, log: bool = False) -> np.ndarray:
    """Cell edges of grid values ``x`` that end at the grid: the midpoints between
    neighbours (geometric means with ``log``, for an axis drawn on a log scale), and ``x[0]``,
    ``x[-1]`` outside them (so a map drawn on them spans exactly the grid). A single value
    gets a cell 1 wide around it (never below zero for a value ≥ 0): a grid of one value has
    no extent to end at."""
    x = np.asarray(x, dtype=float)
    if x.size == 1:
        return cell_edges(x, clip_at_zero=True)
    mid = np.sqrt(x[1:] * x[:-1]) if log else 0.5 * (x[1:] + x[:-1])
    return np.r_[x[0], mid, x[-1]]


def _spans_decades(x: np.ndarray) -> bool:
    """Whether values ``x`` are positive and span more than a decade (drawn on a log axis)."""
    x = np.asarray(x, dtype=float)
    return bool(x.size > 1 and x.min() > 0 and x.max() > 10 * x.min())


def _require(ds: Any, names: tuple[str, ...], what: str) -> None:
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise ConfigError("map", f"missing {', '.join(missing)}", what)


def design_map(
    ds: Any,
    variable: str = "u_z",
    *,
    ax: Axes | None = None,
    star: tuple[float, float] | str | None = "base",
    levels: int = 12,
    cmap: str = "viridis",
    highlight: float | None = None,
) -> Axes:
    """Contours of ``variable`` over (b, C): ``u_z`` or ``u_r`` (normalised by l₀) of a design
    map, ``force`` of a first-instability map. C is drawn on a log axis when the map spans
    more than a decade of it.

    Parameters
    ----------
    ds : xarray.Dataset
        A map with dims (b, C) (``sweep``, ``biplan map design`` or ``biplan map instability``).
    variable : str
        ``"u_z"``, ``"u_r"`` or (first-instability map) ``"force"``.
    ax : Axes, optional
    star : (float, float) or "base" or None
        (b, C) to mark with a star. ``"base"`` (default): the design the map was swept from
        (the ``base_value`` attributes of its b and C coordinates, written by ``sweep``), which
        for the paper's design is the validated one; :data:`VALIDATED_DESIGN` for a map that
        does not record it. None: no star. A star outside the map's (b, C) range is not drawn.
    levels : int
        Number of contour levels.
    cmap : str
        Matplotlib colour map.
    highlight : float, optional
        A value of ``variable`` whose contour is drawn bold and labelled (e.g. the paper's
        1.6 N ramp on a first-instability map: designs below it transform within the ramp).
    """
    _require(ds, (variable, "b", "C"), "a design map with dims (b, C)")
    da = ds[variable].transpose("C", "b")
    ax = _new_axes(ax, COLUMN_FIGSIZE)
    b, c, z = ds["b"].values, ds["C"].values, np.ma.masked_invalid(da.values)
    cs: Any
    if b.size > 1 and c.size > 1:
        cs = ax.contourf(b, c, z, levels=levels, cmap=cmap)
        ax.contour(b, c, z, levels=cs.levels, colors="k", linewidths=0.3, alpha=0.5)
        if highlight is not None and z.min() < highlight < z.max():
            line = ax.contour(b, c, z, levels=[highlight], colors="w", linewidths=1.5)
            ax.clabel(line, fmt=lambda v: f"{v:g}", fontsize=FONT_SIZE - 1)
    else:
        cs = ax.pcolormesh(b, c, z, cmap=cmap, shading="nearest")
    cbar = ax.figure.colorbar(cs, ax=ax)
    cbar.set_label(_LABELS.get(variable, variable), fontsize=FONT_SIZE)
    cbar.ax.tick_params(labelsize=FONT_SIZE)
    if "stability_lost" in ds and b.size > 1 and c.size > 1:
        lost = ds["stability_lost"].transpose("C", "b").values
        if np.nansum(lost) > 0:
            ax.contourf(b, c, np.nan_to_num(lost), levels=[0.5, 1.5], colors="none",
                        hatches=["///"])  # fmt: skip
    if isinstance(star, str):
        if star != "base":
            raise ConfigError("star", star, '"base", a (b, C) pair or None')
        base = (ds["b"].attrs.get("base_value"), ds["C"].attrs.get("base_value"))
        star = VALIDATED_DESIGN if None in base else (float(base[0]), float(base[1]))
    inside = star is not None and (
        b.min() <= star[0] <= b.max() and c.min() <= star[1] <= c.max()
    )  # a star off the map would only stretch the axes
    if star is not None and inside:
        ax.plot(*star, marker="*", ms=10, mfc="white", mec="k", mew=0.8, ls="none",
                label="base design")  # fmt: skip
    ax.set_xlabel(r"geometric ratio $b$")
    ax.set_ylabel(r"stiffness ratio $C$")
    _style(ax)
    if _spans_decades(c):
        ax.set_yscale("log")
    return ax


def stability_map(ds: Any, *, ax: Axes | None = None, legend: bool = True) -> Axes:
    """Mono/bi/multistable regions over (U/l₀, C) with the transition band hatched. C is
    drawn on a log axis when the map spans more than a decade of it.

    Parameters
    ----------
    ds : xarray.Dataset
        A stability map with ``regime`` over dims (C, displacement) and ``transition``.
    ax : Axes, optional
    legend : bool
        Draw the legend of the regimes.
    """
    from matplotlib.collections import LineCollection
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch, Rectangle

    _require(ds, ("regime", "displacement", "C"), "a stability map with dims (C, displacement)")
    ax = _new_axes(ax, COLUMN_FIGSIZE)
    reg = ds["regime"].transpose("C", "displacement").values
    u, c = ds["displacement"].values, ds["C"].values
    log_c = _spans_decades(c)
    ue, ce = grid_edges(u), grid_edges(c, log=log_c)
    cmap = ListedColormap((NONE_COLOR, *REGIME_COLORS)).with_extremes(bad="white")
    norm = BoundaryNorm([-0.5, 0.5, 1.5, 2.5, 3.5], cmap.N)
    ax.pcolormesh(ue, ce, np.ma.masked_invalid(reg), cmap=cmap, norm=norm, shading="flat")
    band = np.zeros(reg.shape, dtype=bool)
    if "transition" in ds:
        band = ds["transition"].transpose("C", "displacement").values > 0.5
        for j, i in zip(*np.nonzero(band), strict=True):
            cell = Rectangle(
                (ue[i], ce[j]), ue[i + 1] - ue[i], ce[j + 1] - ce[j],
                fill=False, hatch="xx", linewidth=0.0, edgecolor="0.2",
            )  # fmt: skip
            ax.add_patch(cell)
        outline = _band_outline(band, ue, ce)
        if outline:
            ax.add_collection(LineCollection(outline, colors="k", linewidths=0.8))
    if log_c:
        ax.set_yscale("log")
    ax.set_xlim(ue[0], ue[-1])
    ax.set_ylim(ce[0], ce[-1])
    if legend:  # only what the map holds
        handles = [
            Patch(color=col, label=lab)
            for value, col, lab in zip(
                (1, 2, 3), REGIME_COLORS, ("monostable", "bistable", "multistable"), strict=True
            )
            if np.any(reg == value)
        ]
        if np.any(reg == 0):
            handles.append(Patch(color=NONE_COLOR, label="none found"))
        if np.any(np.isnan(reg)):
            handles.append(Patch(facecolor="white", edgecolor="0.5", lw=0.5, label="failed"))
        if band.any():
            handles.append(Patch(facecolor="none", edgecolor="k", hatch="xx", label="transition"))
        ax.legend(  # above the axes: the regions fill the whole frame
            handles=handles, fontsize=FONT_SIZE - 1, loc="lower center", frameon=False,
            bbox_to_anchor=(0.5, 1.0), ncol=min(len(handles), 4), handlelength=1.2,
            columnspacing=0.8, borderaxespad=0.2,
        )  # fmt: skip
    ax.set_xlabel(r"normalised displacement $U/l_0$")
    ax.set_ylabel(r"stiffness ratio $C$")
    _style(ax)
    return ax


def _band_outline(
    band: np.ndarray, x_edges: np.ndarray, y_edges: np.ndarray
) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Segments of the boundary of the union of the ``band`` cells (rows along y, columns
    along x): every cell side that faces a non-band cell or the outside of the grid."""
    b = np.pad(np.asarray(band, dtype=bool), 1)
    segs: list[tuple[tuple[float, float], tuple[float, float]]] = []
    for j, i in zip(*np.nonzero(b[1:-1, 1:-1]), strict=True):
        x0, x1, y0, y1 = x_edges[i], x_edges[i + 1], y_edges[j], y_edges[j + 1]
        if not b[j + 1, i]:  # left
            segs.append(((x0, y0), (x0, y1)))
        if not b[j + 1, i + 2]:  # right
            segs.append(((x1, y0), (x1, y1)))
        if not b[j, i + 1]:  # below
            segs.append(((x0, y0), (x1, y0)))
        if not b[j + 2, i + 1]:  # above
            segs.append(((x0, y1), (x1, y1)))
    return segs


def map_figures(ds: Any) -> tuple[str, ...]:
    """The figures (names without suffix) :func:`write_map_figures` draws of a map:
    ``stability`` of a stability map, ``force`` of a first-instability map, else ``u_z`` and
    ``u_r`` (a design map)."""
    if "regime" in ds:
        return ("stability",)
    if "found" in ds:
        return ("force",)
    return ("u_z", "u_r")


def write_map_figures(ds: Any, folder: Path) -> list[Path]:
    """Write every figure of the map ``ds`` (:func:`map_figures`) as ``folder/NAME.png``, one
    journal column each; returns the files written."""
    files = []
    for name in map_figures(ds):
        file = folder / f"{name}.png"
        with figure_file(file, figsize=COLUMN_FIGSIZE) as (_, ax):
            if name == "stability":
                stability_map(ds, ax=ax)
            else:
                design_map(ds, name, ax=ax)
        files.append(file)
    return files
