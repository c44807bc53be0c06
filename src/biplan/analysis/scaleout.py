"""Running the chunks of a sweep on a Dask cluster or a process pool.

A runner is ``runner(task, todo)`` yielding ``(chunk, result)`` as chunks finish (any order):
``todo`` lists (chunk id, indices) and ``task(indices)`` computes one chunk's result (a dict of
arrays). :func:`biplan.analysis.maps.sweeps.sweep` and the exhaustive state search
(:func:`biplan.analysis.states.seeding.exhaustive`) stream each result to their sink. A task is a
picklable partial of a module-level function over picklable descriptions (the frozen
:class:`~biplan.Tube`, the grid, the evaluator, the search settings): a worker builds its
model from them, compiles its kernels once per layout (module-level caches) and shares the
persistent JAX compilation cache that biplan configures when its core is first imported
(:func:`biplan._compile.setup.configure`). Dask reruns the chunks of a worker that dies on another
one.

* :func:`dask_runner` — a ``LocalCluster`` on 127.0.0.1 (processes, one thread each) by
  default, or ``Client(address)`` of a user's scheduler; falls back to :func:`process_runner`
  when ``dask.distributed`` is not importable.
* :func:`process_runner` — ``concurrent.futures.ProcessPoolExecutor``.
* :func:`thread_runner` — threads of this process. A compiled kernel releases the GIL while it
  runs and one run keeps about one core busy, so two threads on two cores run two chunks at
  once with the kernels compiled once (measured: 1.72× on 16 design-map chunks of 16 points;
  a local Dask cluster of 2 pinned workers gave 1.41× on a map of that size and 1.76× on
  100 chunks, paying for start-up, serialisation and a scheduler).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from biplan._errors import ConfigError, check_integer

__all__ = ["Runner", "available_cores", "dask_runner", "process_runner", "thread_runner"]

Todo = list[tuple[int, np.ndarray]]
Task = Callable[[np.ndarray], dict[str, np.ndarray]]
Runner = Callable[[Task, Todo], Iterator[tuple[int, dict[str, np.ndarray]]]]


def _warm(task: Task, indices: np.ndarray) -> bool:
    """Evaluate the first index of a chunk (compiles the worker's kernels; cheap once
    cached)."""
    task(indices[:1])
    return True


def _pin_process(core: int) -> int:
    """Restrict every thread of this process to CPU ``core`` (Linux; a no-op elsewhere).

    XLA:CPU runs each worker's kernels on an intra-op thread pool sized from the machine's
    cores, so unpinned local workers overlap on the same cores: measured on the 2-core project
    machine, one unpinned sweep process uses ≈ 1.2 cores (a 256-point design map: 11.4 s
    unpinned, 13.4 s pinned to one core), and two such workers contend. Pinning worker i to
    core i gives each its own core.
    """
    import os

    if not hasattr(os, "sched_setaffinity"):
        return -1
    import contextlib

    for tid in os.listdir("/proc/self/task"):
        with contextlib.suppress(OSError):  # a thread that ended meanwhile
            os.sched_setaffinity(int(tid), {core})
    return core


def _available_cores() -> list[int]:
    import os

    if hasattr(os, "sched_getaffinity"):
        return sorted(os.sched_getaffinity(0))
    return list(range(os.cpu_count() or 1))


def available_cores() -> int:
    """Number of CPU cores this process may run on (its affinity mask where supported)."""
    return len(_available_cores())


def _on_executor(pool: Any, task: Task, todo: Todo) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
    """Submit every chunk of ``todo`` to the ``concurrent.futures`` executor ``pool`` and
    yield results as they finish; on exit (also when the caller stops iterating) the chunks
    not yet started are cancelled and the pool is shut down."""
    from concurrent.futures import as_completed

    try:
        futures = {pool.submit(task, idx): cid for cid, idx in todo}
        for fut in as_completed(futures):
            yield futures[fut], fut.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def thread_runner(n_threads: int = 2) -> Runner:
    """Run chunks on ``n_threads`` threads of this process.

    The first chunk runs alone, so that its kernels are compiled (or loaded from the
    persistent cache) once, then the others run ``n_threads`` at a time; results are yielded
    as chunks finish. Stopping the iteration cancels the chunks not yet started. The built-in
    evaluators are thread-safe (a test checks the map bit for bit against the sequential
    one); a custom evaluator must be too.
    """
    check_integer("threads", n_threads, low=1)

    def run(task: Task, todo: Todo) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        from concurrent.futures import ThreadPoolExecutor

        if not todo:
            return
        cid, idx = todo[0]
        yield cid, task(idx)
        pool = ThreadPoolExecutor(n_threads, thread_name_prefix="biplan-sweep")
        yield from _on_executor(pool, task, todo[1:])

    return run


def process_runner(n_workers: int = 2) -> Runner:
    """Run chunks in a ``ProcessPoolExecutor`` of ``n_workers`` processes (spawned)."""
    check_integer("workers", n_workers, low=1)

    def run(task: Task, todo: Todo) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        if not todo:
            return
        pool = ProcessPoolExecutor(n_workers, mp_context=mp.get_context("spawn"))
        yield from _on_executor(pool, task, todo)

    return run


def dask_runner(
    address: str | None = None,
    n_workers: int = 2,
    *,
    warm_up: bool = False,
    on_ready: Callable[[], object] | None = None,
    pin: bool = True,
) -> Runner:
    """Run chunks on Dask: ``Client(address)`` if given, else a loopback ``LocalCluster``.

    Parameters
    ----------
    address : str, optional
        Scheduler address of a user's cluster (``tcp://host:8786``).
    n_workers : int
        Worker processes of the local cluster (one thread each), ≥ 1.
    warm_up : bool
        Compile every worker's kernels before the chunks are submitted (benchmarks).
    on_ready : callable, optional
        Called once the cluster is up (and warm), just before the chunks are submitted.
    pin : bool
        Local cluster of 2 or more workers and at most as many workers as cores only: pin
        worker i to its own core (see :func:`_pin_process`; Linux). A single worker is left
        free to use every core.
    """
    check_integer("workers", n_workers, low=1)
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:  # pragma: no cover - dask is a core dependency
        if address is not None:
            raise ConfigError("--scheduler", address, "usable only with dask installed") from None
        return process_runner(n_workers)

    def run(task: Task, todo: Todo) -> Iterator[tuple[int, dict[str, np.ndarray]]]:
        if not todo:
            return
        cluster: Any = None
        if address is None:
            cluster = LocalCluster(
                n_workers=n_workers,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
            )
            client = Client(cluster)
            cores = _available_cores()
            if pin and 1 < n_workers <= len(cores):
                workers = sorted(client.scheduler_info()["workers"])
                for core, worker in zip(cores, workers, strict=False):
                    client.run(_pin_process, core, workers=[worker])
        else:
            client = Client(address)
        try:
            if warm_up:
                client.run(_warm, task, todo[0][1])
            if on_ready is not None:
                on_ready()
            futures = {client.submit(task, idx, pure=False): cid for cid, idx in todo}
            for fut in as_completed(list(futures)):
                yield futures[fut], fut.result()
        finally:
            client.close()
            if cluster is not None:
                cluster.close()

    return run
