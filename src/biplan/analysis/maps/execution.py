"""Where the chunks of a map run: threads of this process, a local Dask cluster, or a user's
Dask scheduler (:class:`Execution`, the ``--workers``/``--scheduler``/``--threads`` of
``biplan map``).

* ``Execution()`` — this process, one thread per available core (at most one per chunk); the
  first chunk runs alone so that the kernels are compiled once
  (:func:`~biplan.analysis.scaleout.thread_runner`);
* ``Execution(threads=n)`` — this process on ``n`` threads (1: sequential, no runner);
* ``Execution(workers=n)``, n > 1 — a loopback Dask ``LocalCluster`` of ``n`` processes;
* ``Execution(scheduler="tcp://host:8786")`` — the user's Dask cluster.
"""

from __future__ import annotations

from dataclasses import dataclass

from biplan._errors import check_integer
from biplan.analysis.scaleout import Runner

__all__ = ["Execution"]


@dataclass(frozen=True)
class Execution:
    """How a map's chunks are run.

    Parameters
    ----------
    workers : int
        Worker processes (≥ 1); 1 runs the chunks in this process.
    scheduler : str, optional
        Address of a Dask scheduler of an existing cluster (``workers`` and ``threads`` are then
        not used).
    threads : int
        Threads of this process running chunks (≥ 0; 0: one per available core); used with
        ``workers == 1`` and no scheduler.

    Raises
    ------
    ConfigError
        ``workers`` or ``threads`` not an integer in range (named by the field).
    """

    workers: int = 1
    scheduler: str | None = None
    threads: int = 0

    def __post_init__(self) -> None:
        check_integer("workers", self.workers, low=1)
        check_integer("threads", self.threads, low=0, note=" (0: one per available core)")

    @property
    def distributed(self) -> bool:
        """Whether the chunks run on Dask (a scheduler, or more than one worker)."""
        return self.scheduler is not None or self.workers > 1

    @property
    def cores(self) -> int:
        """Cores the map runs on, for its cost estimate (a scheduler's are unknown: one)."""
        from biplan.analysis.scaleout import available_cores

        if self.scheduler is not None:
            return 1
        if self.workers > 1:
            return self.workers
        return self.threads or available_cores()

    def runner(self, n_chunks: int) -> Runner | None:
        """The runner of a map of ``n_chunks`` chunks (None: sequentially, in this process)."""
        from biplan.analysis.scaleout import available_cores, dask_runner, thread_runner

        if self.distributed:
            return dask_runner(self.scheduler, self.workers)
        n_threads = self.threads or min(available_cores(), n_chunks)
        return thread_runner(n_threads) if n_threads > 1 else None
