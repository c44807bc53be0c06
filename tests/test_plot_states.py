"""Figures of the state analysis on hand-made catalogues (no solving): the transition diagram
grows with its tallest column so that labels stay apart, and the endpoint space names the
states only while the names can be read."""

from __future__ import annotations

import itertools

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import networkx as nx
import numpy as np
import pytest
import xarray as xr

from biplan.plot.states import MAX_ANNOTATED, ROW_HEIGHT, endpoint_space, transition_diagram


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


@pytest.mark.parametrize("n", [10, MAX_ANNOTATED + 1])
def test_endpoint_space_names_states_only_while_readable(n) -> None:
    rng = np.random.default_rng(3)
    ds = xr.Dataset(
        {
            "u_z": ("state", rng.uniform(0, 5, n)),
            "u_r": ("state", rng.uniform(-1, 1, n)),
            "Theta": ("state", rng.uniform(0, 1, n)),
            "n_open_helical": ("state", rng.integers(0, 4, n)),
        },
        coords={"state": [f"{k:03X}" for k in range(n)]},
        attrs={"initial_length": 14.4},
    )
    ax = endpoint_space(ds)
    assert len(ax.texts) == (n if n <= MAX_ANNOTATED else 0)
