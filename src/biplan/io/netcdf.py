"""Writing labelled results to netCDF4 files (h5netcdf engine).

:func:`write_netcdf` is ``Dataset.to_netcdf(path, engine="h5netcdf")`` for the in-memory
datasets biplan writes. ``to_netcdf`` asks Dask which scheduler is active before every write
(for its write lock and its auto-close rule), which imports ``dask.distributed`` whenever Dask is
installed: the first write of a process takes 246 ms instead of 54 ms
(``benchmarks/bench_netcdf_write.py``; docs/performance.md). A dataset that holds
no Dask arrays needs neither, so it is written through xarray's own h5netcdf store with
xarray's HDF5 lock; a dataset with chunked variables goes through ``to_netcdf`` unchanged.
Both give the same file (``tests/test_io_netcdf.py``).

:func:`write_labelled` writes a :class:`~biplan.solvers.results.Labelled` result (plain
arrays) with h5netcdf alone, as xarray's store writes its dataset: the same dimensions,
variables, attributes and encoding (``_FillValue`` NaN on floating-point variables, strings as
variable-length UTF-8), so the file reads back as the same dataset (``tests/test_io_netcdf.py``).
Its coordinates are dimension coordinates, as in every biplan result. It spares the ``biplan``
command the import of xarray, pandas and Dask (about 0.8 s of ``biplan respond``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from biplan.solvers.results import Labelled

__all__ = ["write_labelled", "write_netcdf"]


def write_netcdf(ds: Any, path: str | Path) -> Path:
    """Write ``ds`` (an ``xarray.Dataset``) to ``path`` as netCDF4 [h5netcdf]; returns the path.

    The file is replaced if it exists; its folder must exist.
    """
    out = Path(path)
    if any(v.chunks is not None for v in ds.variables.values()):
        ds.to_netcdf(out, engine="h5netcdf")
        return out
    from xarray.backends import H5NetCDFStore
    from xarray.backends.locks import HDF5_LOCK

    store = H5NetCDFStore.open(str(out), mode="w", lock=HDF5_LOCK)
    try:
        ds.dump_to_store(store)
    finally:
        store.close()
    return out


def _entries(data: Labelled) -> list[tuple[str, tuple[str, ...], np.ndarray, dict[str, Any]]]:
    """(name, dims, values, attributes) of the data variables, then of the coordinates."""
    out = [(n, _dims(d), np.asarray(v), dict(a)) for n, (d, v, a) in data.variables.items()]
    for name, coord in data.coords.items():
        dims, values, attrs = coord if isinstance(coord, tuple) else (name, coord, {})
        if _dims(dims) != (name,):
            # xarray would name it in a ``coordinates`` attribute: not written here
            raise ValueError(f"coordinate {name!r} is not a dimension coordinate (dims {dims})")
        out.append((name, (name,), np.asarray(values), dict(attrs)))
    return out


def _dims(dims: str | tuple[str, ...]) -> tuple[str, ...]:
    """A variable's dimension names (one name may be given as a string, as xarray takes it)."""
    return (dims,) if isinstance(dims, str) else tuple(dims)


def write_labelled(data: Labelled, path: str | Path) -> Path:
    """Write ``data`` to ``path`` as netCDF4 with h5netcdf, the file that
    ``data.to_dataset()`` written by :func:`write_netcdf` gives; returns the path.

    The file is replaced if it exists; its folder must exist. Raises ValueError for a
    coordinate that is not a dimension coordinate (xarray lists those in a ``coordinates``
    attribute, which this writer does not write).
    """
    import h5netcdf
    import h5py

    out = Path(path)
    entries = _entries(data)
    with h5netcdf.File(str(out), "w", decode_vlen_strings=True, format="NETCDF4") as f:
        for key, value in data.attrs.items():
            f.attrs[key] = value
        sizes: dict[str, int] = {}
        for _, dims, values, _ in entries:
            sizes.update(zip(dims, values.shape, strict=True))
        for dim, size in sizes.items():
            f.dimensions[dim] = size
        for name, dims, values, attrs in entries:
            dtype: Any = values.dtype
            fill = None
            if values.dtype.kind in "UO":
                dtype, values = h5py.special_dtype(vlen=str), values.astype(object)
            elif values.dtype.kind == "f":
                fill = np.nan
            var = f.create_variable(name, dimensions=dims, dtype=dtype, fillvalue=fill)
            for key, value in attrs.items():
                var.attrs[key] = value
            var[...] = values
    return out
