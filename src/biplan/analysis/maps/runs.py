"""A map run: the sweep of an evaluator over a grid into a chunk sink, then the merged map.

:class:`MapJob` (made by :func:`biplan.io.sweepstore.open_map`, which opens the chunk store of
an output directory) runs the chunks its sink does not hold yet (``resume`` continues a killed
run without recomputing its finished chunks) on an
:class:`~biplan.analysis.maps.execution.Execution`, then has the sink write the merged map
(``DIR/map.nc``); it returns a :class:`MapRun`. The files are :mod:`biplan.io.sweepstore`'s.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from biplan.analysis.maps import sweeps

if TYPE_CHECKING:
    from biplan.analysis.maps.execution import Execution
    from biplan.analysis.maps.sweeps import Evaluator, Grid
    from biplan.model.tube import Tube

__all__ = ["MapJob", "MapRun", "MapSink"]


class MapSink(sweeps.ChunkSink, Protocol):
    """A chunk sink that also writes the merged map (``biplan.io.sweepstore.ChunkStore``)."""

    description: dict[str, Any]
    n_chunks: int

    @property
    def reused(self) -> int: ...

    @property
    def damaged(self) -> dict[int, str]: ...

    def write_map(self, ds: Any) -> Path: ...


@dataclass(frozen=True)
class MapRun:
    """A finished map run.

    Attributes
    ----------
    dataset : xarray.Dataset
        The map (as written to ``path``).
    path : Path
        ``DIR/map.nc``.
    n_points, n_failed : int
        Points of the grid, and those whose status is not 0.
    n_chunks, reused : int
        Chunks of the grid, and those of an earlier run that were reused (``resume``).
    seconds : float
        Wall time of the sweep [s].
    """

    dataset: Any
    path: Path
    n_points: int
    n_failed: int
    n_chunks: int
    reused: int
    seconds: float

    @property
    def all_failed(self) -> bool:
        """Whether every point of the map failed."""
        return self.n_failed == self.n_points

    def failed_points(self, limit: int = 3) -> list[str]:
        """The first ``limit`` failed points, each as its grid values and its status
        (``"C = 0.5, displacement = 0.05: not_converged"``; the names of ``STATUS``)."""
        status = self.dataset["status"]
        names = {v: k for k, v in sweeps.STATUS.items()}
        out = []
        for index in np.argwhere(status.values != 0)[:limit]:
            where = ", ".join(
                f"{dim} = {self.dataset[dim].values[i]:g}"
                for dim, i in zip(status.dims, index, strict=True)
            )
            code = int(status.values[tuple(index)])
            out.append(f"{where}: {names.get(code, code)}")
        return out


@dataclass(frozen=True)
class MapJob:
    """A map ready to run into its chunk store (:func:`open_map`).

    Attributes
    ----------
    design, grid, evaluator, chunk_size
        What is swept (:func:`~biplan.analysis.maps.sweeps.sweep`).
    store : MapSink
        Where the chunks and the map go (:class:`biplan.io.sweepstore.ChunkStore`, from
        :func:`biplan.io.sweepstore.open_map`).
    """

    design: Tube
    grid: Grid
    evaluator: Evaluator
    chunk_size: int
    store: MapSink

    @property
    def damaged(self) -> dict[int, str]:
        """Finished chunks of the resumed run whose file is missing or unreadable → why (they
        are computed again)."""
        return dict(sorted(self.store.damaged.items()))

    def run(
        self, execution: Execution, progress: Callable[[int, int], object] | None = None
    ) -> MapRun:
        """Compute the chunks not yet stored (on ``execution``), then write ``map.nc``.

        Parameters
        ----------
        execution : Execution
            Where the chunks run.
        progress : callable, optional
            ``progress(points_done, n_points)`` after every chunk.
        """
        runner = execution.runner(self.store.n_chunks)
        start = time.perf_counter()
        ds = sweeps.sweep(self.design, self.grid, self.evaluator, chunk_size=self.chunk_size,
                   sink=self.store, runner=runner, progress=progress)  # fmt: skip
        ds.attrs["config"] = self.store.description["config"]
        path = self.store.write_map(ds)
        return MapRun(
            dataset=ds,
            path=path,
            n_points=self.grid.size,
            n_failed=int(ds.attrs["n_failed"]),
            n_chunks=self.store.n_chunks,
            reused=self.store.reused,
            seconds=time.perf_counter() - start,
        )
