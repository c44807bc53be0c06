"""A map run into a directory (``biplan map``): the chunk store, the sweep, ``map.nc``.

* :func:`open_map` — the chunk store of a map in ``DIR/chunks``
  (:class:`~biplan.io.sweepstore.ChunkStore`: ``resume`` continues a killed run without
  recomputing its finished chunks) as a :class:`MapJob`, whose :meth:`MapJob.run` sweeps
  the evaluator over the grid and writes the merged map to ``DIR/map.nc`` (netCDF; its
  attributes hold the configuration and the settings); it returns a :class:`MapRun`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from biplan.analysis.maps import sweeps
from biplan.io.config import dump_config
from biplan.io.sweepstore import ChunkStore, save_map

if TYPE_CHECKING:
    from biplan.analysis.maps.execution import Execution
    from biplan.analysis.maps.sweeps import Evaluator, Grid
    from biplan.model.tube import Tube

__all__ = ["MapJob", "MapRun", "open_map"]


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


@dataclass(frozen=True)
class MapJob:
    """A map ready to run into its chunk store (:func:`open_map`).

    Attributes
    ----------
    design, grid, evaluator, chunk_size
        What is swept (:func:`~biplan.analysis.maps.sweeps.sweep`).
    store : ChunkStore
        The chunk store in the output directory.
    """

    design: Tube
    grid: Grid
    evaluator: Evaluator
    chunk_size: int
    store: ChunkStore

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
        save_map(ds, self.store.map_path)
        return MapRun(
            dataset=ds,
            path=self.store.map_path,
            n_points=self.grid.size,
            n_failed=int(ds.attrs["n_failed"]),
            n_chunks=self.store.n_chunks,
            reused=self.store.reused,
            seconds=time.perf_counter() - start,
        )


def open_map(
    design: Tube,
    grid: Grid,
    evaluator: Evaluator,
    out: Path,
    *,
    chunk_size: int,
    resume: bool = False,
) -> MapJob:
    """The map of ``evaluator`` over ``grid`` to run into the directory ``out`` (chunks under
    ``out/chunks``, the map in ``out/map.nc``); nothing is computed yet.

    Parameters
    ----------
    design : Tube
        The base design (with the grid checked against it:
        :func:`~biplan.analysis.maps.sweeps.check_grid`).
    grid : Grid
    evaluator : Evaluator
    out : Path
        Output directory (created).
    chunk_size : int
        Points per chunk (the unit of work and of resumption).
    resume : bool
        Continue a killed run in ``out``: its finished chunks are reused.

    Raises
    ------
    ConfigError
        ``out``: a directory holding chunks of another run (without ``resume``), or chunk
        files but no manifest; ``--resume``: a directory of another sweep.
    """
    description = {
        "config": dump_config(design),
        "quantity": evaluator.name,
        "settings": evaluator.describe(),
        "grid": {a.name: list(a.values) for a in grid.axes},
        "chunk_size": chunk_size,
    }
    n_chunks = len(sweeps.chunk_indices(grid, chunk_size))
    store = ChunkStore(out, description, n_chunks, resume)
    return MapJob(design, grid, evaluator, chunk_size, store)
