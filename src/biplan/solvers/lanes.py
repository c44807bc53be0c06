"""Lanes: one compiled kernel over many independent rows, on a few threads.

The batched drivers (state seeds, path predictors, map tasks, observations) run the same
compiled kernel on every row of their inputs. Each such kernel is a serial ``@njit(nogil=True)``
function whose last two arguments are a block of rows ``lo, hi``: it fills rows ``lo:hi`` of
output arrays allocated by its caller, so blocks of rows can run at the same time on Python
threads (the kernel holds no GIL) without sharing any written memory. :func:`run_rows` hands
the blocks to a thread pool; with one thread it calls the kernel once, on every row.

Numba's own parallel loops (``parallel=True`` with ``prange``) would do the same work, but a
parallel kernel compiles several times longer than the serial one (the parallel passes and
the thread-pool wrapper are compiled for every such kernel): 157 s and 124 s for the path
corrector and the observation batch in one cold-cache measurement, against 26 s for the
serial observation (docs/performance.md, "One-time compile").

The number of threads is :func:`thread_count`: ``NUMBA_NUM_THREADS`` (Numba's default, the
number of cores), or a smaller number inside :func:`limited` (e.g. an in-process state search
with ``Enumeration.threads``).
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Any

__all__ = ["BLOCKS_PER_THREAD", "limited", "run_rows", "thread_count"]

#: Blocks of rows per thread: more blocks balance rows of unequal cost (a seed that needs many
#: descent iterations beside easy ones), fewer cost less hand-over.
BLOCKS_PER_THREAD = 4

_LIMIT: contextvars.ContextVar[int | None] = contextvars.ContextVar("biplan_lanes", default=None)


def thread_count() -> int:
    """Threads the lanes run on: :func:`limited`'s number inside it, else
    ``numba.config.NUMBA_NUM_THREADS`` (the cores, unless the environment says otherwise)."""
    limit = _LIMIT.get()
    if limit is not None:
        return limit
    import numba

    return max(1, int(numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]


@contextlib.contextmanager
def limited(threads: int) -> Iterator[None]:
    """Run the lanes inside the block on at most ``threads`` (≥ 1) threads."""
    if threads < 1:
        raise ValueError(f"threads = {threads}: must be ≥ 1")
    token = _LIMIT.set(int(threads))
    try:
        yield
    finally:
        _LIMIT.reset(token)


@functools.cache
def _pool(threads: int) -> ThreadPoolExecutor:
    """One pool per thread count, kept for the process (no thread start per call)."""
    return ThreadPoolExecutor(max_workers=threads, thread_name_prefix="biplan-lane")


def run_rows(
    kernel: Callable[..., Any],
    k: int,
    *args: Any,
    threads: int | None = None,
    min_rows: int = 1,
) -> None:
    """Call ``kernel(*args, lo, hi)`` on blocks [lo, hi) that cover the rows 0 … k − 1.

    Parameters
    ----------
    kernel : callable
        A compiled ``nogil`` kernel that fills rows ``lo:hi`` of its output arguments.
    k : int
        Number of rows.
    *args
        The kernel's arguments before ``lo, hi`` (inputs and preallocated outputs).
    threads : int, optional
        Threads to use; default :func:`thread_count`.
    min_rows : int
        Fewest rows per thread worth a thread: fewer rows run in the calling thread.
    """
    n = thread_count() if threads is None else max(1, int(threads))
    n = max(1, min(n, k // max(1, min_rows)))
    if n == 1 or k <= 1:
        kernel(*args, 0, k)
        return
    blocks = min(k, BLOCKS_PER_THREAD * n)
    edges = [k * b // blocks for b in range(blocks + 1)]
    pool = _pool(n)
    futures = [pool.submit(kernel, *args, edges[b], edges[b + 1]) for b in range(blocks)]
    for future in futures:
        future.result()
