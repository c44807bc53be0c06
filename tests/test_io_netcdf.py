"""biplan.io.netcdf.write_netcdf writes the file Dataset.to_netcdf writes, without Dask's
scheduler probe."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from biplan.io.netcdf import write_netcdf


def _dataset() -> xr.Dataset:
    return xr.Dataset(
        {
            "force": (("step",), np.array([0.0, 1.5, np.nan]), {"units": "N"}),
            "stable": (("step",), np.array([True, False, True])),
            "label": (("step",), np.array(["00", "2A", "66"])),
            "q": (("step", "coordinate"), np.arange(6.0).reshape(3, 2)),
        },
        coords={"step": [0, 1, 2], "coordinate": ["u", "v"]},
        attrs={"config": "[geometry]\nradius = 2.0\n", "n_modules": 6, "load": 1.25},
    )


def _same_file(a_path, b_path) -> None:
    with (
        xr.open_dataset(a_path, engine="h5netcdf") as a,
        xr.open_dataset(b_path, engine="h5netcdf") as b,
    ):
        assert a.identical(b)
        for name in a.variables:
            ea = {k: v for k, v in a[name].encoding.items() if k != "source"}
            eb = {k: v for k, v in b[name].encoding.items() if k != "source"}
            assert ea.keys() == eb.keys()
            for key in ea:
                np.testing.assert_equal(ea[key], eb[key])


def test_same_file_as_to_netcdf(tmp_path):
    ds = _dataset()
    ds.to_netcdf(tmp_path / "xarray.nc", engine="h5netcdf")
    assert write_netcdf(ds, tmp_path / "biplan.nc") == tmp_path / "biplan.nc"
    _same_file(tmp_path / "biplan.nc", tmp_path / "xarray.nc")
    # replaces an existing file
    write_netcdf(ds.isel(step=[0]), tmp_path / "biplan.nc")
    with xr.open_dataset(tmp_path / "biplan.nc", engine="h5netcdf") as back:
        assert back.sizes["step"] == 1


def test_chunked_dataset_goes_through_to_netcdf(tmp_path):
    pytest.importorskip("dask.array")
    ds = _dataset()
    write_netcdf(ds.chunk({"step": 1}), tmp_path / "chunked.nc")
    ds.to_netcdf(tmp_path / "xarray.nc", engine="h5netcdf")
    _same_file(tmp_path / "chunked.nc", tmp_path / "xarray.nc")


def test_no_dask_scheduler_probe(tmp_path):
    """Writing an in-memory dataset does not import dask.distributed (to_netcdf does)."""
    code = (
        "import sys, numpy as np, xarray as xr\n"
        "from biplan.io.netcdf import write_netcdf\n"
        f"write_netcdf(xr.Dataset({{'a': ('x', np.arange(3.0))}}), {str(tmp_path / 'a.nc')!r})\n"
        "print('distributed' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"
