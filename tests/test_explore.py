"""``biplan explore``: refusals of files it cannot draw, and the pages' data (no browser).

The pages in a real browser are tested in ``tests/test_explore_browser.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import biplan
from biplan.cli.main import EXIT_BIPLAN_ERROR, main
from biplan.geometry import surface
from biplan.plot.explorer.response import shown_steps
from biplan.plot.explorer.shapes import SUBDIVISIONS, shape_set, tube_points

DATA = Path(__file__).resolve().parent / "data"
STATES = DATA / "states4" / "states.nc"


def _run(args: list[str]) -> int:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return int(exc.value.code or 0)


def _refused(args: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert _run(args) == EXIT_BIPLAN_ERROR
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize("what", ["stability map", "corrupt", "empty catalogue", "missing"])
def test_explore_refuses_what_it_cannot_draw_before_writing(
    what: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    file = tmp_path / "result.nc"
    if what == "stability map":
        ds = xr.Dataset({"regime": (("C",), np.ones(2))}, coords={"C": [1.0, 2.0]})
        ds.attrs["quantity"] = "stability_count"
        ds.to_netcdf(file, engine="h5netcdf")
        reason = "it is a map (stability_count)"
    elif what == "corrupt":
        file.write_bytes(b"\x89HDF\r\n not really a netCDF file")
        reason = "cannot read it"
    elif what == "empty catalogue":
        xr.load_dataset(STATES).isel(state=slice(0, 0)).to_netcdf(file, engine="h5netcdf")
        reason = "it is a state catalogue without states"
    else:
        reason = "no such file"
    out = tmp_path / "page.html"
    line = _refused(["explore", str(file), "--out", str(out)], capsys)
    assert f"invalid RESULT = '{file}'" in line
    assert "a state catalogue" in line and "a design map" in line and "a response" in line
    assert reason in line
    assert not out.exists()


def test_explore_refuses_an_out_that_is_not_html(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    line = _refused(["explore", str(STATES), "--out", str(tmp_path / "x.png")], capsys)
    assert "--out" in line and ".html" in line


def test_explore_refuses_an_unreadable_transition_graph(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A broken transitions.graphml beside the catalogue is named, not silently dropped."""
    import shutil

    shutil.copyfile(STATES, tmp_path / "states.nc")
    graph = tmp_path / "transitions.graphml"
    graph.write_text("<graphml><broken")
    out = tmp_path / "page.html"
    line = _refused(["explore", str(tmp_path / "states.nc"), "--out", str(out)], capsys)
    assert f"invalid transitions.graphml = '{graph}'" in line and "cannot read it" in line
    assert not out.exists()


def test_page_shapes_are_the_surface_mesh(model4: biplan.Model) -> None:
    """The element motions applied to the reference mesh give the points of the tube surface
    of ``biplan plot --kind tube`` (at the page's decimation)."""
    qs = np.asarray(xr.load_dataset(STATES)["q"].values[[0, 5, -1]])
    shapes = shape_set(model4, qs)
    reference = np.asarray(model4.global_nodes(model4.zeros()))
    for k, q in enumerate(qs):
        nodes = np.asarray(model4.global_nodes(q))
        expected = surface.surface(
            nodes, shapes.radius, reference=reference, subdivisions=SUBDIVISIONS
        ).points
        np.testing.assert_allclose(tube_points(shapes, k), expected, atol=1e-9)


def test_shown_steps_keep_the_last_step() -> None:
    assert shown_steps(5, 10).tolist() == [0, 1, 2, 3, 4]
    steps = shown_steps(1001, 300)
    assert len(steps) <= 301 and steps[0] == 0 and steps[-1] == 1000
