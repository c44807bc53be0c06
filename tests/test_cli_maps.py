"""``biplan map design|stability|plot``, run in-process on tiny grids.

The design map uses chunks of 4 points (the batch shape of tests/test_sweeps.py) and the
stability map b = 0.573 (the layout of the semi-bistable design), so no new kernel compiles.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from biplan.cli.main import EXIT_BIPLAN_ERROR, main
from biplan.io.sweepstore import load_map

CONFIG = Path(__file__).resolve().parents[1] / "examples" / "semi_bistable.toml"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _run(args: list[str]) -> int:
    with pytest.raises(SystemExit) as exc:
        main(args)
    return int(exc.value.code or 0)


@pytest.fixture(scope="module")
def design_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("maps") / "design"
    args = ["map", "design", str(CONFIG), "--b", "0.5:0.55:2", "--C", "1,2"]
    assert _run([*args, "--out", str(out), "--chunk-size", "4", "--quiet"]) == 0
    return out


def test_design_map_cli_writes_a_labelled_map(design_dir: Path) -> None:
    ds = load_map(design_dir)
    assert ds["u_z"].dims == ("b", "C") and ds["u_z"].shape == (2, 2)
    assert (ds["status"].values == 0).all()
    assert "[laws.circular]" in ds.attrs["config"]
    manifest = json.loads((design_dir / "manifest.json").read_text())
    assert manifest["finished"] == [0]
    # more extension at the lower C
    assert (ds["u_z"].values[:, 0] > ds["u_z"].values[:, 1]).all()


def test_design_map_cli_resume_and_refusal(design_dir: Path) -> None:
    args = ["map", "design", str(CONFIG), "--b", "0.5:0.55:2", "--C", "1,2", "--chunk-size", "4"]
    before = load_map(design_dir)
    # a finished directory is not overwritten without --resume
    assert _run([*args, "--out", str(design_dir), "--quiet"]) == EXIT_BIPLAN_ERROR
    # another grid cannot resume it
    other = ["map", "design", str(CONFIG), "--b", "0.5:0.6:2", "--C", "1,2", "--chunk-size", "4"]
    assert _run([*other, "--out", str(design_dir), "--resume", "--quiet"]) == EXIT_BIPLAN_ERROR
    assert _run([*args, "--out", str(design_dir), "--resume", "--quiet"]) == 0
    after = load_map(design_dir)
    assert after["u_z"].values.tobytes() == before["u_z"].values.tobytes()


def test_map_plot_design(design_dir: Path) -> None:
    assert _run(["map", "plot", str(design_dir)]) == 0
    for name in ("u_z", "u_r"):
        assert (design_dir / f"{name}.png").read_bytes()[:8] == PNG_SIGNATURE


@pytest.mark.parametrize(
    ("option", "value", "needle"),
    [("--b", "0.5:0.6:0", "N ≥ 1"), ("--C", "x", "comma"), ("--b", "0.1,0.5", "b")],
)
def test_bad_grid_exits_with_the_parameter_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, value: str, needle: str
) -> None:
    grid = {"--b": "0.5", "--C": "1"}
    grid[option] = value
    args = ["map", "design", str(CONFIG), "--out", str(tmp_path / "x"), "--quiet"]
    for k, v in grid.items():
        args += [k, v]
    assert _run(args) == EXIT_BIPLAN_ERROR
    err = capsys.readouterr().err
    assert "invalid" in err and needle in err


@pytest.mark.parametrize(
    ("option", "value", "needles"),
    [
        ("--threads", "-1", ("--threads", "-1")),
        ("--after-snap", "jump", ("--after-snap", "jump", "dynamic or stop")),
        ("--workers", "0", ("--workers", "0", "≥ 1")),
    ],
)
def test_bad_map_option_exits_with_the_setting_named(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    option: str,
    value: str,
    needles: tuple[str, ...],
) -> None:
    args = ["map", "design", str(CONFIG), "--b", "0.5", "--C", "1", option, value]
    assert _run([*args, "--out", str(tmp_path / "x"), "--quiet"]) == EXIT_BIPLAN_ERROR
    err = capsys.readouterr().err
    assert all(n in err for n in needles)
    assert not (tmp_path / "x").exists()  # refused before anything was written


def test_stability_map_cli(tmp_path: Path) -> None:
    """``--chunk-size 2``: the search kernels of an 8-point bucket, which the stability tests
    of test_sweeps.py and the reproduce run also compile (the persistent cache shares them;
    the default, whole rows of at least 128 points, is checked by stability_chunk_size)."""
    out = tmp_path / "stab"
    args = ["map", "stability", str(CONFIG), "--displacement", "0.02,0.2", "--C", "1.0"]
    assert _run([*args, "--b", "0.573", "--out", str(out), "--chunk-size", "2", "--quiet"]) == 0
    ds = load_map(out)
    assert ds["regime"].dims == ("C", "displacement")
    assert ds["energy"].dims == ("C", "displacement", "equilibrium")
    assert "transition" in ds
    n = ds["n_stable"].values
    assert np.isfinite(n).all() and (n >= 1).all()
    assert _run(["map", "plot", str(out)]) == 0
    assert (out / "stability.png").read_bytes()[:8] == PNG_SIGNATURE


def test_design_map_explorer_page(browser: Any, design_dir: Path, tmp_path: Path) -> None:
    """`biplan explore map.nc` in headless Chromium: heatmaps, curve and shape panels, no
    console error; clicking a cell selects that design (title, ramp curve); not blank."""
    from _browser import click_point, not_blank, open_page

    out = tmp_path / "map.html"
    assert _run(["explore", str(design_dir / "map.nc"), "--out", str(out), "--quiet"]) == 0
    page, errors = open_page(browser, out)
    for div in ("map-u_z", "map-u_r", "curve", "tube", "development"):
        assert page.locator(f"#{div} .main-svg").count() > 0, div
    cells = page.evaluate("biplanExplorer.data.cells")
    assert len(cells) == 4
    target = next(i for i, c in enumerate(cells) if i != page.evaluate("biplanExplorer.selected"))
    click_point(page, "map-u_z", cells[target]["b"], cells[target]["C"])
    page.wait_for_function(f"biplanExplorer.selected === {target}")
    b, c = (  # JavaScript's toPrecision(3)
        f"{v:.{max(2 - int(np.floor(np.log10(abs(v)))), 0)}f}"
        for v in (cells[target]["b"], cells[target]["C"])
    )
    assert page.inner_text("#shape-title") == f"b = {b}, C = {c}"
    curve = page.evaluate("document.getElementById('curve').data[0].y")
    assert curve == pytest.approx(cells[target]["force"])
    not_blank(page.screenshot(full_page=True))
    assert errors == []
    page.close()
