"""Writing labelled datasets to netCDF4 files (h5netcdf engine).

:func:`write_netcdf` is ``Dataset.to_netcdf(path, engine="h5netcdf")`` for the in-memory
datasets biplan writes. ``to_netcdf`` asks Dask which scheduler is active before every write
(for its write lock and its auto-close rule), which imports ``dask.distributed`` whenever Dask is
installed: the first write of a process takes 246 ms instead of 54 ms
(``benchmarks/bench_netcdf_write.py``; docs/performance.md). A dataset that holds
no Dask arrays needs neither, so it is written through xarray's own h5netcdf store with
xarray's HDF5 lock; a dataset with chunked variables goes through ``to_netcdf`` unchanged.
Both give the same file (``tests/test_io_netcdf.py``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["write_netcdf"]


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
