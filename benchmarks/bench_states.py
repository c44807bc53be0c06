"""Benchmark: stable-state searches of fully bistable tubes (N modules, 2N − 1 bistable folds).

For each N of ``--sizes`` (default 4 5 6), in one process:

* exhaustive search (all 2^(2N−1) seeds; :func:`biplan.analysis.states.search.enumerate_states`):
  cold (a new layout: its kernels compile; the persistent cache may hold them) and warm;
* neighbourhood search (:attr:`~biplan.analysis.states.search.Search.NEIGHBOURHOOD`), warm, with the
  seeds it tried and whether it found the same states;
* the baseline in the same run: the exhaustive search on one thread
  (``Enumeration(threads=1)``) against the default (the seeds of a chunk in parallel, one
  thread per core), for N ≤ ``--one-thread-max``.

The JAX relaxation pool these searches ran on before the compiled core is gone; its figures
are in docs/performance.md.

Usage::

    .venv/bin/python benchmarks/bench_states.py [--sizes 4 5 6] [--one-thread-max 6]
        [--dask 6] [--sample 10 32]

``--dask N``: the exhaustive search of N modules on a Dask ``LocalCluster`` of 1 and of 2
workers (pinned, one thread each), timed from the moment the warmed-up cluster is ready to the
last chunk; the speed-up of 2 workers over 1 (target ≥ 1.6×).

``--sample N K``: K chunks of N's exhaustive search, spread evenly over the seed space, on a
2-worker ``LocalCluster`` (timed after warm-up), extrapolated to every seed (the N = 10 estimate:
524,288 seeds, target ≤ 15 min).

Targets (issue "a core without per-layout compilation"): N = 4 ≤ 0.1 s, N = 8 ≤ 30 s warm,
N = 10 ≤ 10 min on 2 Dask workers.
"""

from __future__ import annotations

import argparse
import functools
import time

import numpy as np

import biplan
from biplan.analysis.states import seeding
from biplan.analysis.states.catalogue import Enumeration
from biplan.analysis.states.labels import bistable_folds
from biplan.analysis.states.search import Search, enumerate_states


def timed(fn, *args, **kwargs):  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--sizes", type=int, nargs="*", default=[4, 5, 6])
    parser.add_argument("--one-thread-max", type=int, default=6)
    parser.add_argument("--dask", type=int, default=0, help="modules of the Dask run (0: none)")
    parser.add_argument("--sample", type=int, nargs=2, default=None, metavar=("N", "CHUNKS"))
    args = parser.parse_args()
    if args.dask:
        dask_speedup(args.dask)
    if args.sample:
        dask_sample(*args.sample)
    for n in args.sizes:
        model = biplan.Model(biplan.designs.fully_bistable(n_modules=n))
        cat, cold = timed(enumerate_states, model, confirm=True)
        cat, warm = timed(enumerate_states, model, confirm=True)
        near, warm_near = timed(enumerate_states, model, search=Search.NEIGHBOURHOOD, confirm=True)
        same = [s.name for s in near.states] == [s.name for s in cat.states]
        print(
            f"N={n}: {len(cat.seeds)} seeds -> {len(cat)} states; exhaustive cold {cold:.1f} s, "
            f"warm {warm:.2f} s ({1e3 * warm / len(cat.seeds):.2f} ms/seed, "
            f"{seeding.thread_count(Enumeration())} threads); neighbourhood {warm_near:.2f} s, "
            f"{len(near.seeds)} seeds, same states: {same}",
            flush=True,
        )
        if n <= args.one_thread_max:
            _, alone = timed(enumerate_states, model, Enumeration(threads=1), confirm=True)
            print(
                f"N={n}: exhaustive on one thread {alone:.2f} s (one thread / default "
                f"{alone / warm:.2f}x)",
                flush=True,
            )


def dask_speedup(n: int) -> None:
    from biplan.analysis.scaleout import dask_runner

    model = biplan.Model(biplan.designs.fully_bistable(n_modules=n))
    alone = enumerate_states(model, confirm=True)
    times = {}
    for workers in (1, 2):
        ready: list[float] = []
        last: list[float] = []
        run = dask_runner(
            None, workers, warm_up=True, on_ready=lambda r=ready: r.append(time.perf_counter())
        )
        cat = enumerate_states(
            model,
            confirm=True,
            runner=run,
            progress=lambda k, m, r=last: r.append(time.perf_counter()),
        )
        times[workers] = last[-1] - ready[0]
        same = [s.name for s in cat.states] == [s.name for s in alone.states]
        print(
            f"N={n}: Dask LocalCluster, {workers} worker(s): {len(cat.seeds)} seeds in "
            f"{times[workers]:.1f} s after warm-up; same states as one process: {same}",
            flush=True,
        )
    print(f"N={n}: speed-up 2 vs 1 workers {times[1] / times[2]:.2f}x  [target >= 1.6x]")


def dask_sample(n: int, n_sample: int) -> None:
    from biplan.analysis.maps.sweeps import run_chunks
    from biplan.analysis.scaleout import dask_runner

    tube = biplan.designs.fully_bistable(n_modules=n)
    settings = Enumeration()
    n_seeds = 2 ** len(bistable_folds(tube))
    n_chunks = -(-n_seeds // settings.chunk)
    picks = np.unique(np.linspace(0, n_chunks - 1, n_sample).round().astype(int))
    chunks = [np.arange(c * settings.chunk, min((c + 1) * settings.chunk, n_seeds)) for c in picks]
    ready: list[float] = []
    t0 = time.perf_counter()
    run = dask_runner(None, 2, warm_up=True, on_ready=lambda: ready.append(time.perf_counter()))
    task = functools.partial(seeding.evaluate_chunk, tube, settings)
    done = run_chunks(task, chunks, runner=run)
    wall = time.perf_counter() - ready[0]
    sampled = sum(len(c) for c in chunks)
    stable = sum(
        int(seeding.outcome_masks(r, settings.stability_tolerance)[1].sum()) for r in done.values()
    )
    per_seed = wall / sampled
    print(
        f"N={n}: {sampled} of {n_seeds:,} seeds ({len(chunks)} spread chunks) on a 2-worker "
        f"LocalCluster in {wall:.1f} s after {ready[0] - t0:.0f} s of start-up and warm-up "
        f"({1e3 * per_seed:.2f} ms/seed, {stable} stable); every seed: about "
        f"{per_seed * n_seeds / 60:.1f} min  [target <= 15 min]",
        flush=True,
    )


if __name__ == "__main__":
    main()
