"""First-instability map: every point equals an independent first-snap search of its design;
a design that stays stable is NaN with found = 0; the dataset is labelled."""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan.analysis.maps.grid import Grid, apply_values
from biplan.analysis.maps.instability_map import CRITICAL, InstabilityEvaluator
from biplan.analysis.maps.sweeps import sweep
from biplan.analysis.response.loadcontrol import first_snap
from conftest import make_tube


def test_every_point_is_its_designs_first_snap():
    tube = make_tube(1)
    grid = Grid.of(C=[0.5, 1.5])
    ds = sweep(tube, grid, InstabilityEvaluator(up_to=3.0), chunk_size=2)
    assert ds["force"].attrs["units"] == "N" and ds.attrs["quantity"] == "first_instability"
    for i, c in enumerate(grid.axes[0].values):
        snap = first_snap(biplan.Model(apply_values(tube, {"C": c})), 3.0)
        assert snap is not None and ds["found"].values[i] == 1
        assert ds["force"].values[i] == pytest.approx(snap.force, rel=1e-12)
        assert ds["critical"].values[i] == CRITICAL[snap.critical]
    # a stiffer C holds more before the circular fold's peak
    assert ds["force"].values[1] > ds["force"].values[0]


def test_a_design_that_stays_stable_is_nan_not_failed():
    ds = sweep(make_tube(1), Grid.of(C=[1.0]), InstabilityEvaluator(up_to=0.05), chunk_size=1)
    assert np.isnan(ds["force"].values[0]) and ds["found"].values[0] == 0
    assert ds["status"].values[0] == 0


def test_bad_up_to_is_refused():
    with pytest.raises(biplan.ConfigError, match="up_to"):
        InstabilityEvaluator(up_to=-1.0)


def test_cli_writes_the_map_and_its_figure(tmp_path):
    import xarray as xr

    from biplan.cli.main import main
    from biplan.io.config import dump_config

    config = tmp_path / "one.toml"
    config.write_text(dump_config(make_tube(1)))
    out = tmp_path / "map"
    args = ["map", "instability", str(config), "--b", "0.45,0.55", "--C", "0.05,1.5"]
    with pytest.raises(SystemExit) as info:
        main([*args, "--out", str(out), "--quiet", "--chunk-size", "4"])
    assert info.value.code in (0, None)
    with xr.open_dataset(out / "map.nc", engine="h5netcdf") as ds:
        assert ds["force"].dims == ("b", "C") and ds.attrs["quantity"] == "first_instability"
        assert np.isfinite(ds["force"].values).all()
    with pytest.raises(SystemExit) as info:
        main(["map", "plot", str(out)])
    assert info.value.code in (0, None) and (out / "force.png").stat().st_size > 0
