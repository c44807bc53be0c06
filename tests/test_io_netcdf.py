"""biplan.io.netcdf.write_netcdf writes the file Dataset.to_netcdf writes, without Dask's
scheduler probe; write_labelled writes the same file from plain arrays, without xarray."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from biplan.io.netcdf import write_labelled, write_netcdf
from biplan.solvers.results import Labelled


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


def _hdf5_layout(path) -> dict:
    """Every HDF5 object's shape, type and attributes (dimension-scale references left out),
    and the file's attributes."""
    import h5py

    skip = ("DIMENSION_LIST", "REFERENCE_LIST")
    with h5py.File(path, "r") as f:
        out = {
            name: (v.shape, str(v.dtype), {a: repr(v.attrs[a]) for a in v.attrs if a not in skip})
            for name, v in f.items()
        }
        out["/"] = {a: repr(f.attrs[a]) for a in f.attrs}
    return out


def _labelled() -> Labelled:
    return Labelled(
        {
            "force": (("time",), np.array([0.0, 1.5, np.nan]), {"units": "N"}),
            "stable": (("time",), np.array([1, 0, 1], dtype=np.int8), {"units": "1"}),
            "segment": (("time",), np.array([0, 0, 1]), {"units": "1"}),
            "label": (("time",), np.array(["00", "2A", "66"]), {}),
            "q": (("time", "coordinate"), np.arange(6.0).reshape(3, 2), {"units": "mm or rad"}),
        },
        {
            "fold": ["helical 1", "circular 0"],
            "coordinate": np.arange(2),
            "time": ("time", np.array([0.0, 0.1, 0.25]), {"units": "s"}),
        },
        {"config": "[geometry]\nradius = 2.0\n", "n_modules": 6, "load": 1.25},
    )


def test_labelled_arrays_are_written_as_their_dataset(tmp_path):
    """write_labelled (h5netcdf alone) writes the file of the labelled arrays' xarray dataset:
    the same dataset read back, the same encoding, the same HDF5 objects and attributes."""
    lab = _labelled()
    write_netcdf(lab.to_dataset(), tmp_path / "xarray.nc")
    assert write_labelled(lab, tmp_path / "biplan.nc") == tmp_path / "biplan.nc"
    _same_file(tmp_path / "biplan.nc", tmp_path / "xarray.nc")
    assert _hdf5_layout(tmp_path / "biplan.nc") == _hdf5_layout(tmp_path / "xarray.nc")
    with xr.open_dataset(tmp_path / "biplan.nc", engine="h5netcdf") as back:
        assert back.identical(lab.to_dataset())


def test_labelled_arrays_refuse_a_coordinate_off_its_dimension(tmp_path):
    lab = _labelled()
    coords = {**lab.coords, "t_ms": ("time", np.arange(3.0), {})}
    with pytest.raises(ValueError, match="'t_ms' is not a dimension coordinate"):
        write_labelled(Labelled(lab.variables, coords, lab.attrs), tmp_path / "a.nc")
    assert not (tmp_path / "a.nc").exists()


@pytest.fixture(scope="module")
def responses(model6):
    """A path under force control, a stable-branch displacement sweep and a ramp in time."""
    from biplan.analysis.response.run import respond
    from biplan.analysis.response.settings import Method, QuasiStatic, Ramp

    return {
        "path": respond(model6, "force", QuasiStatic(1.0, Method.ARCLENGTH, 0.1, 0.5, 200)),
        "sweep": respond(model6, "displacement", QuasiStatic(1.0, Method.STABLE, 0.25, 0.5, 200)),
        "trajectory": respond(model6, "force", Ramp(0.8, 0.1, 0.0, 0.02, 0.05)),
    }


@pytest.mark.parametrize("kind", ["path", "sweep", "trajectory"])
def test_response_files_hold_the_results_dataset(responses, model6, kind, tmp_path):
    """save_response writes the netCDF file of the result's xarray dataset (without importing
    xarray: tests/test_cli_respond.py), and the CSV of its columns."""
    from biplan.io.response_files import save_response
    from biplan.io.results import dataset, sweep_dataset

    run = responses[kind]
    assert run.complete, run.message
    nc, table = save_response(run.result, tmp_path / "r", model6)
    ds = sweep_dataset(run.result, model6) if kind == "sweep" else dataset(run.result)
    write_netcdf(ds, tmp_path / "xarray.nc")
    _same_file(nc, tmp_path / "xarray.nc")
    assert _hdf5_layout(nc) == _hdf5_layout(tmp_path / "xarray.nc")
    if kind != "sweep":  # the CSV's columns are the dataset's
        rows = np.genfromtxt(table, delimiter=",", names=True, skip_header=1)
        index = ds["time"] if kind == "trajectory" else ds["step"]
        np.testing.assert_array_equal(rows["t" if kind == "trajectory" else "step"], index)
        for name in ("force", "u_z", "energy", "min_eigenvalue", "stable"):
            np.testing.assert_array_equal(rows[name], ds[name].values)
