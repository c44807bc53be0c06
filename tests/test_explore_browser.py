"""The explorer pages of ``biplan explore`` in a real headless browser (Chromium + Playwright).

The browser is Debian's ``chromium`` (``scripts/install_browser.sh``, run by ``make test``),
driven by Playwright's Python API through ``executable_path``. Where neither can be found
the tests are skipped, with the reason in the summary and a warning. Each page is checked for
console errors, its panels, its linking (clicking a state or cell changes the shape panel's
title; a pathway is highlighted) and a screenshot that is not blank.
"""

from __future__ import annotations

import itertools
import shutil
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np
import pytest
import xarray as xr

import biplan
from _browser import click_point, not_blank, open_page
from biplan.cli.main import main
from biplan.geometry import surface
from biplan.plot.explorer.shapes import SUBDIVISIONS

DATA = Path(__file__).resolve().parent / "data"
STATES = DATA / "states4" / "states.nc"


@pytest.fixture(scope="module")
def catalogue_html(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("explore") / "explorer.html"
    with pytest.raises(SystemExit) as exc:
        main(["explore", str(STATES), "--out", str(out), "--quiet"])
    assert exc.value.code in (0, None)
    return out


def test_catalogue_page(browser: Any, catalogue_html: Path, model4: biplan.Model) -> None:
    from biplan.analysis.states.transitions import pathway

    page, errors = open_page(browser, catalogue_html)
    for div in ("graph", "endpoint", "tube", "development"):
        assert page.locator(f"#{div} .main-svg").count() > 0, div
    names = page.evaluate("biplanExplorer.data.states.name")
    pos = page.evaluate("biplanExplorer.data.graph_pos")
    assert page.inner_text("#shape-title") == f"state {names[0]}"

    # clicking a state node selects it: the shape panel's title is its label
    k = names.index("1B")
    click_point(page, "graph", *pos[k])
    page.wait_for_function(f"biplanExplorer.selected === {k}")
    assert page.inner_text("#shape-title") == "state 1B"

    # the tube drawn is the surface mesh of `biplan plot --kind tube`
    script = f"biplanExplorer.tubePoints(biplanExplorer.data.shapes, {k})"
    drawn = np.asarray(page.evaluate(script))
    q = xr.load_dataset(STATES)["q"].values[k]
    expected = surface.surface(
        np.asarray(model4.global_nodes(q)),
        model4.tube.development.radius,
        reference=np.asarray(model4.global_nodes(model4.zeros())),
        subdivisions=SUBDIVISIONS,
    ).points
    np.testing.assert_allclose(drawn, expected, atol=1e-4)

    # two states: the pathway is highlighted in the graph and in endpoint space
    page.select_option("#path-from", str(names.index("2A")))
    page.select_option("#path-to", str(names.index("66")))
    page.click("#path-show")
    shown = page.evaluate("biplanExplorer.pathway")
    graph = nx.read_graphml(STATES.parent / "transitions.graphml")
    expected_path = pathway(graph, "2A", "66")
    assert shown[0] == "2A" and shown[-1] == "66" and len(shown) == len(expected_path)
    assert all(graph.has_edge(a, b) for a, b in itertools.pairwise(shown))
    trace = page.evaluate("biplanExplorer.data.traces.graph.path")
    xs = page.evaluate(f"document.getElementById('graph').data[{trace}].x")
    assert np.allclose(xs, [pos[names.index(n)][0] for n in shown])
    trace3 = page.evaluate("biplanExplorer.data.traces.endpoint.path")
    drawn3 = page.evaluate(f"document.getElementById('endpoint').data[{trace3}].x.length")
    assert drawn3 == len(shown)
    assert page.inner_text("#shape-title") == "state 2A"
    page.click("#path-next")
    assert page.inner_text("#shape-title") == f"state {shown[1]}"
    assert "fold" in page.inner_text("#path-text")

    not_blank(page.screenshot(full_page=True))
    not_blank(page.locator("#tube").screenshot())
    assert errors == []
    page.close()


def test_response_page(browser: Any, model4: biplan.Model, tmp_path: Path) -> None:
    from _datasets import result_dataset

    qs = xr.load_dataset(STATES)["q"].values
    path = np.linspace(qs[0], qs[-1], 12)
    file = tmp_path / "response.nc"
    result_dataset(model4, path, np.linspace(0.0, 1.0, 12)).to_netcdf(file, engine="h5netcdf")
    out = tmp_path / "response.html"
    with pytest.raises(SystemExit) as exc:
        main(["explore", str(file), "--out", str(out), "--quiet"])
    assert exc.value.code in (0, None)
    page, errors = open_page(browser, out)
    assert page.locator("#curve .main-svg").count() > 0
    assert page.inner_text("#shape-title") == "step 11"
    page.fill("#step-slider", "3")
    page.dispatch_event("#step-slider", "input")
    assert page.inner_text("#shape-title") == "step 3"
    not_blank(page.screenshot(full_page=True))
    assert errors == []
    page.close()


def test_least_barrier_pathway(browser: Any, tmp_path: Path) -> None:
    """With barriers on the edges (transitions.graphml beside the catalogue), the pathway
    "by least total barrier" climbs as little in total as networkx's."""
    from biplan.analysis.states.transitions import barrier_weight, pathway

    graph = nx.read_graphml(STATES.parent / "transitions.graphml")
    rng = np.random.default_rng(7)
    for u, v, d in graph.edges(data=True):
        top = max(graph.nodes[u]["energy"], graph.nodes[v]["energy"])
        d["saddle_energy"] = float(top + rng.uniform(0.05, 2.0))
    folder = tmp_path / "states"
    folder.mkdir()
    shutil.copyfile(STATES, folder / "states.nc")
    nx.write_graphml(graph, folder / "transitions.graphml")
    out = tmp_path / "barriers.html"
    with pytest.raises(SystemExit) as exc:
        main(["explore", str(folder / "states.nc"), "--out", str(out), "--quiet"])
    assert exc.value.code in (0, None)
    page, errors = open_page(browser, out)
    page.evaluate("biplanExplorer.showPathway('2A', '66', 'barrier')")
    shown = page.evaluate("biplanExplorer.pathway")

    def climbed(path: list[str]) -> float:
        steps = itertools.pairwise(path)
        return sum(barrier_weight(a, b, graph.edges[a, b], graph) for a, b in steps)

    best = pathway(graph, "2A", "66", weight="barrier")
    assert shown[0] == "2A" and shown[-1] == "66"
    assert climbed(shown) == pytest.approx(climbed(best), rel=1e-9)
    assert errors == []
    page.close()
