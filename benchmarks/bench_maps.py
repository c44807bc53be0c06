"""Design- and stability-map timings: batched sweeps, the scalar loop, Dask scale-out.

Run:  .venv/bin/python benchmarks/bench_maps.py [--design 50] [--stability 40] [--dask 12]
      [--chunk-size 16] [--baseline 6] [--skip-dask]

In one process, for the semi-bistable paper design (6 modules):

* design map — ``sweep`` of the force-ramp response over an n × n (b, C) grid,
  b ∈ [0.40, 0.57], C ∈ [0.5, 3.0] (one layout), 16 load steps; cold (first call in the
  process: compilation or the persistent-cache load) and warm times, points/s;
* scalar loop — :func:`biplan.analysis.maps.design_map.response_point` (one Newton solve per load
  step, the same algorithm unbatched) over ``--baseline`` points, points/s;
* stability map — ``sweep`` of the equilibrium count over an n × n (C, U/l₀) grid at the
  design's b (0.573, same layout), C ∈ [0.5, 3.0], U/l₀ ∈ [0.01, 0.4], chunks of whole rows
  (``stability_chunk_size``, as the CLI); cold (a two-point row: fixed-seed and march kernels
  compile) and warm;
* threads — the same design and stability maps with the chunks on ``--threads`` threads of
  this process (``thread_runner``, the CLI's default on a multi-core machine), warm;
* Dask — the design map on a ``--dask`` × ``--dask`` grid with a loopback ``LocalCluster`` of 1
  and of 2 workers (kernels compiled in the workers before timing), speed-up.

Grids smaller than the targets (50 × 50 design, 40 × 40 stability) are timed as given and
extrapolated linearly in the number of points (the cost per point is independent of the grid
size: fixed chunk shape); the printout says when it extrapolates.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import biplan
from biplan.analysis.maps.design_map import ResponseEvaluator, response_point
from biplan.analysis.maps.stability_map import StabilityEvaluator, stability_chunk_size
from biplan.analysis.maps.sweeps import Grid, apply_values, sweep
from biplan.analysis.scaleout import dask_runner, thread_runner


def _timed(fn):  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def _report(name: str, n: int, cold: float, warm: float, target_n: int, target_s: float) -> None:
    rate = n / warm
    line = f"{name}: {n} points  cold {cold:8.1f} s  warm {warm:8.1f} s  ({rate:.2f} points/s)"
    if n != target_n:
        line += f"  -> extrapolated to {target_n} points: {target_n / rate:.0f} s warm"
    print(line + f"  [target {target_n} points <= {target_s:.0f} s]")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", type=int, default=50, help="design grid n (n × n)")
    ap.add_argument("--stability", type=int, default=40, help="stability grid n (n × n)")
    ap.add_argument("--dask", type=int, default=12, help="Dask comparison grid n (n × n)")
    ap.add_argument("--chunk-size", type=int, default=16, help="points per chunk/batch")
    ap.add_argument("--baseline", type=int, default=6, help="points of the scalar loop")
    ap.add_argument("--threads", type=int, default=2, help="threads of the threaded runs")
    ap.add_argument("--skip-dask", action="store_true")
    ap.add_argument("--skip-sequential", action="store_true", help="threaded runs only")
    ap.add_argument("--save-stability", default=None, help="write the stability map (netCDF)")
    args = ap.parse_args()
    print(f"cpus: {os.cpu_count()}, load average: {os.getloadavg()}")
    design = biplan.designs.semi_bistable()
    ev = ResponseEvaluator()
    cs = args.chunk_size

    n = args.design
    grid = Grid.of(b=np.linspace(0.40, 0.57, n), C=np.linspace(0.5, 3.0, n))
    small = Grid.of(b=[0.45], C=[1.0])
    threads = thread_runner(args.threads)
    cold, _ = _timed(lambda: sweep(design, small, ev, chunk_size=cs))
    seq = None
    if not args.skip_sequential:
        seq, ds = _timed(lambda: sweep(design, grid, ev, chunk_size=cs))
        _report("design map", grid.size, cold, seq, 2500, 60.0)
        print(f"  failed points: {ds.attrs['n_failed']}")
    warm, ds = _timed(lambda: sweep(design, grid, ev, chunk_size=cs, runner=threads))
    _report(f"design map, {args.threads} threads", grid.size, cold, warm, 2500, 60.0)
    print(f"  failed points: {ds.attrs['n_failed']}")

    pts = [grid.point(i) for i in np.linspace(0, grid.size - 1, args.baseline).astype(int)]
    response_point(apply_values(design, pts[0]))  # compile
    t_loop, _ = _timed(lambda: [response_point(apply_values(design, p)) for p in pts])
    loop_rate = len(pts) / t_loop
    which, t_map = ("sequential", seq) if seq is not None else (f"{args.threads} threads", warm)
    print(
        f"scalar loop (response_point): {loop_rate:.2f} points/s; "
        f"batched ({which})/scalar = {grid.size / t_map / loop_rate:.1f}x"
    )

    m = args.stability
    sev = StabilityEvaluator()
    sgrid = Grid.of(C=np.linspace(0.5, 3.0, m), displacement=np.linspace(0.01, 0.4, m))
    scs = stability_chunk_size(m)  # whole rows, as the CLI
    cold, _ = _timed(lambda: sweep(design, Grid.of(C=[1.0], displacement=[0.1, 0.2]), sev,
                                   chunk_size=scs))  # fmt: skip
    runs = [("stability map", None)] if not args.skip_sequential else []
    for name, runner in [*runs, (f"stability map, {args.threads} threads", threads)]:
        warm, sds = _timed(lambda r=runner: sweep(design, sgrid, sev, chunk_size=scs, runner=r))
        _report(name, sgrid.size, cold, warm, 1600, 120.0)
        counts = {k: int((sds["regime"].values == v).sum()) for k, v in (("mono", 1), ("bi", 2),
                  ("multi", 3))}  # fmt: skip
        print(f"  regimes: {counts}, transition band: {int(sds['transition'].sum())} points")
    if args.save_stability:
        sds.to_netcdf(args.save_stability)

    if args.skip_dask:
        return
    k = args.dask
    dgrid = Grid.of(b=np.linspace(0.40, 0.57, k), C=np.linspace(0.5, 3.0, k))
    times = {}
    for workers in (1, 2):
        ready: list[float] = []
        last: list[float] = []

        def stamp_ready(r: list[float] = ready) -> None:
            r.append(time.perf_counter())

        def stamp_chunk(done: int, total: int, r: list[float] = last) -> None:
            r.append(time.perf_counter())

        run = dask_runner(None, workers, warm_up=True, on_ready=stamp_ready)
        t0 = time.perf_counter()
        sweep(design, dgrid, ev, chunk_size=cs, runner=run, progress=stamp_chunk)
        total = time.perf_counter() - t0
        t = last[-1] - ready[0]  # the sweep proper, after start-up and warm-up
        times[workers] = t
        print(
            f"dask LocalCluster {workers} worker(s): {dgrid.size} points in {t:.1f} s "
            f"({dgrid.size / t:.2f} points/s; {total:.1f} s with cluster start and warm-up)"
        )
    print(f"  speed-up 2 vs 1 workers: {times[1] / times[2]:.2f}x  [target >= 1.6x]")


if __name__ == "__main__":
    main()
