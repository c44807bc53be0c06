"""The first netCDF write of a process: ``biplan.io.netcdf.write_netcdf`` against
``Dataset.to_netcdf`` (the baseline), each in a new process, alternating.

``to_netcdf`` asks Dask for its scheduler before writing, which imports ``dask.distributed``
when Dask is installed; ``write_netcdf`` writes an in-memory dataset through xarray's h5netcdf
store without asking. Both processes have imported xarray and built a dataset first (which
imports ``dask.array`` either way), so the times are the write alone.

Run:  .venv/bin/python benchmarks/bench_netcdf_write.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

CHILD = """
import sys, time
import numpy as np, xarray as xr
ds = xr.Dataset({"force": ("step", np.linspace(0.0, 2.0, 300))}, attrs={"config": "x"})
t = time.perf_counter()
if sys.argv[1] == "to_netcdf":
    ds.to_netcdf(sys.argv[2], engine="h5netcdf")
else:
    from biplan.io.netcdf import write_netcdf
    write_netcdf(ds, sys.argv[2])
print(time.perf_counter() - t, "distributed" in sys.modules)
"""


def _once(how: str, path: Path) -> tuple[float, bool]:
    out = subprocess.run(
        [sys.executable, "-c", CHILD, how, str(path)], capture_output=True, text=True, check=True
    )
    seconds, distributed = out.stdout.split()
    return float(seconds), distributed == "True"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    times: dict[str, list[float]] = {"to_netcdf": [], "write_netcdf": []}
    imports: dict[str, bool] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(args.repeats):
            for how in times:
                seconds, imports[how] = _once(how, Path(tmp) / f"{how}.nc")
                times[how].append(seconds)
    for how, ts in times.items():
        print(
            f"{how:13s} median {statistics.median(ts) * 1e3:6.1f} ms "
            f"(min {min(ts) * 1e3:.1f}, max {max(ts) * 1e3:.1f}); "
            f"dask.distributed imported: {imports[how]}"
        )
    ratio = statistics.median(times["write_netcdf"]) / statistics.median(times["to_netcdf"])
    print(f"write_netcdf / to_netcdf (medians): {ratio:.2f}")


if __name__ == "__main__":
    main()
