"""Figures of the state analysis on hand-made catalogues (no solving): the transition diagram
grows with its tallest column so that labels stay apart, and the endpoint space names only the
states whose names do not overlap, says how many, and shows Θ over its range."""

from __future__ import annotations

import itertools
from io import BytesIO

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import networkx as nx
import numpy as np
import pytest
import xarray as xr

from biplan.plot.states import (
    MAX_NAME_CANDIDATES,
    PALETTE,
    ROW_HEIGHT,
    branch_colours,
    display_extent,
    endpoint_space,
    transition_diagram,
)


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _hypercube(n_bits: int) -> nx.Graph:
    """Every state of n bistable folds, Hamming-1 edges (the graph of a tube whose every
    combination is stable)."""
    g = nx.Graph()
    for bits in itertools.product("01", repeat=n_bits):
        s = "".join(bits)
        g.add_node(format(int(s, 2), "03X"), bits=s)
    for u, du in g.nodes(data=True):
        for v, dv in g.nodes(data=True):
            if sum(a != b for a, b in zip(du["bits"], dv["bits"], strict=True)) == 1:
                g.add_edge(u, v)
    return g


@pytest.mark.parametrize(("n_bits", "tallest"), [(3, 3), (8, 70)])
def test_transition_diagram_is_tall_enough_for_its_tallest_column(n_bits, tallest) -> None:
    ax = transition_diagram(_hypercube(n_bits))
    width, height = ax.figure.get_size_inches()
    assert width == 7.0 and height == pytest.approx(max(4.2, ROW_HEIGHT * tallest + 0.9))
    labels = [t for t in ax.texts if t.get_text()]
    assert len(labels) == 2**n_bits
    # neighbouring labels of the tallest column sit at least one label height apart
    ax.figure.canvas.draw()
    middle = sorted(t.get_window_extent().y0 for t in labels if t.xy[0] == n_bits // 2)
    gap = np.diff(middle).min()
    assert gap >= labels[0].get_window_extent().height


def _catalogue(n: int, seed: int = 3, theta_sign: float = 1.0, branches: int = 4) -> xr.Dataset:
    rng = np.random.default_rng(seed)
    theta = theta_sign * rng.uniform(0, 0.2, n)
    theta[0] = 0.218
    return xr.Dataset(
        {
            "u_z": ("state", rng.uniform(0, 5, n)),
            "u_r": ("state", rng.uniform(-1, 1, n)),
            "theta": ("state", theta),
            "Theta": ("state", theta / 0.218),
            "energy": ("state", rng.uniform(0, 3, n)),
            "n_open_helical": ("state", rng.integers(0, branches, n)),
        },
        coords={"state": [f"{k:03X}" for k in range(n)]},
        attrs={"initial_length": 14.4},
    )


def _drawn_box(text, renderer):  # type: ignore[no-untyped-def]
    """Where a 3D name is drawn: a new 2D text with its string and font at the display point
    of its projected (x, y, z) (the figure's last draw)."""
    from matplotlib.text import Text
    from mpl_toolkits.mplot3d import proj3d

    ax = text.axes
    x, y, z = text.get_position_3d()
    px, py, _ = proj3d.proj_transform(x, y, z, ax.get_proj())
    dx, dy = ax.transData.transform((px, py))
    probe = Text(dx, dy, text.get_text(), fontproperties=text.get_fontproperties())
    probe.set_figure(text.figure)
    probe.set_horizontalalignment(text.get_horizontalalignment())
    probe.set_verticalalignment(text.get_verticalalignment())
    return probe.get_window_extent(renderer)


def test_names_are_measured_where_the_projection_draws_them() -> None:
    """A 3D text's own window extent sits at its raw (x, y); the labels are placed by their
    projected position."""
    ax = endpoint_space(_catalogue(66))
    ax.figure.savefig(BytesIO(), format="png", dpi=100)
    renderer = ax.figure.canvas.get_renderer()
    for t in ax.texts[:5]:
        drawn = _drawn_box(t, renderer)
        np.testing.assert_allclose(display_extent(t, renderer).bounds, drawn.bounds, atol=0.5)
        assert not np.allclose(t.get_window_extent(renderer).bounds, drawn.bounds, atol=0.5)


@pytest.mark.parametrize("n", [6, 66, 242])
def test_endpoint_space_names_a_readable_subset_and_says_so(n) -> None:
    ax = endpoint_space(_catalogue(n))
    fig = ax.figure
    fig.savefig(BytesIO(), format="png", dpi=100)  # the layout of the written file
    renderer = fig.canvas.get_renderer()
    shown = [t for t in ax.texts if t.get_visible()]
    boxes = [_drawn_box(t, renderer) for t in shown]
    for a, b in itertools.combinations(boxes, 2):
        assert not a.overlaps(b)
    legend = ax.get_legend().get_window_extent(renderer)
    assert not any(box.overlaps(legend) for box in boxes)
    assert f"names: {len(shown)} of {n} states" in ax.get_title()
    assert len(ax.texts) == min(n, MAX_NAME_CANDIDATES) and 1 <= len(shown) <= n
    if n == 242:
        assert len(shown) < n  # a dense catalogue: only a subset can be read
    if n == 6:
        assert len(shown) == n


@pytest.mark.parametrize(("sign", "zlim"), [(1.0, (0.0, 1.0)), (-1.0, (-1.0, 1.0))])
def test_endpoint_space_shows_theta_over_its_range(sign, zlim) -> None:
    ax = endpoint_space(_catalogue(12, theta_sign=sign), annotate=False)
    assert ax.get_zlim() == pytest.approx(zlim)
    assert "Θ = 1 at |θ| = 0.218 rad" in ax.get_title()
    assert f"Θ ∈ [{zlim[0]:g}, 1]" in ax.get_title()
    assert "max" in ax.get_zlabel() and not ax.texts


def test_a_transition_diagram_of_thousands_of_states_is_aggregated() -> None:
    """2,048 states (11 folds; tallest column 462): a 7 × 6 in density, names only on the
    pathway, the count of every column on top."""
    from biplan.plot.states import MAX_NAMED_ROWS

    g = _hypercube(11)
    path = ["000", "001", "003"]
    ax = transition_diagram(g, pathways=[path])
    assert MAX_NAMED_ROWS < 462
    assert tuple(ax.figure.get_size_inches()) == (7.0, 6.0)
    on_top = [t for t in ax.texts if t.xy[1] > 0.5]
    names = [t.get_text().strip() for t in ax.texts if t.xy[1] <= 0.5]
    assert sorted(names) == sorted(path)
    counts = sorted(int(t.get_text()) for t in on_top)
    assert counts == sorted(
        int(np.round(len(list(itertools.combinations(range(11), k))))) for k in range(12)
    )
    assert "2048 states" in ax.get_title()
    buf = BytesIO()
    ax.figure.savefig(buf, format="png", dpi=100)  # draws in reasonable size and time
    assert buf.tell() < 2_000_000


def test_endpoint_space_gives_every_slope_branch_its_own_colour() -> None:
    """Ten modules have 11 slope branches, more than the palette's 8 colours: each branch
    still gets its own colour, and the legend (two columns) covers no name."""
    from matplotlib.colors import to_hex

    ax = endpoint_space(_catalogue(400, branches=11))
    fig = ax.figure
    fig.savefig(BytesIO(), format="png", dpi=100)
    renderer = fig.canvas.get_renderer()
    colours = {to_hex(c.get_facecolor()[0]) for c in ax.collections}
    assert len(ax.collections) == 11 and len(colours) == 11
    legend = ax.get_legend()
    assert legend._ncols == 2
    box = legend.get_window_extent(renderer)
    shown = [_drawn_box(t, renderer) for t in ax.texts if t.get_visible()]
    assert not any(b.overlaps(box) for b in shown)
    assert not any(a.overlaps(b) for a, b in itertools.combinations(shown, 2))
    assert branch_colours(4) == list(PALETTE[:4])
