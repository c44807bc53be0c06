"""Parameter sweeps over any tube or law parameter: grids, chunks, batched evaluation.

``sweep(design, grid, quantity)`` evaluates ``quantity`` (an :class:`Evaluator`, e.g. the
force-ramp response of :mod:`biplan.analysis.maps.design_map` or the equilibrium count of
:mod:`biplan.analysis.maps.stability_map`) at every point of a :class:`Grid` of design parameters
and
returns a labelled ``xarray.Dataset`` with one dimension per grid axis (grids and parameters:
:mod:`biplan.analysis.maps.grid`, re-exported here).

The grid is cut into chunks of ``chunk_size`` points (row-major order, the last axis fastest).
A chunk is the unit of work, of scale-out and of resumption: the evaluator gets the points of a
chunk together (the design and stability maps solve them on the compiled System of each point,
compiled once per install whatever the layout or chunk). Chunks run in this process, on a Dask
cluster (:func:`run_chunks`) or in a process pool, and their results can be streamed to a
:class:`ChunkSink` (``biplan.io.sweepstore.ChunkStore``) that skips finished chunks on resume.

A chunk or a point that fails is recorded with a :data:`STATUS` code and NaN values; the sweep
goes on.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from biplan._errors import ConfigError, check_integer
from biplan.analysis.maps.grid import (
    QUANTITIES,
    Grid,
    GridAxis,
    apply_values,
    base_value,
    parse_axis,
)
from biplan.model.tube import Tube

__all__ = [
    "QUANTITIES",
    "STATUS",
    "ChunkSink",
    "Evaluator",
    "Grid",
    "GridAxis",
    "apply_values",
    "assemble",
    "base_value",
    "check_grid",
    "chunk_indices",
    "evaluate_chunk",
    "parse_axis",
    "run_chunks",
    "run_local",
    "sweep",
]

#: Point status codes (``status`` variable of every sweep Dataset).
STATUS = {"ok": 0, "not_converged": 1, "nonfinite": 2, "error": 3, "invalid": 4}


class Evaluator(Protocol):
    """What ``sweep`` evaluates at each grid point (see ``design_map.ResponseEvaluator``)."""

    @property
    def name(self) -> str:
        """Name of the quantity (Dataset attribute ``quantity``)."""
        ...

    @property
    def load_axes(self) -> tuple[str, ...]:
        """Grid axes that are loads (not design parameters), e.g. ``("displacement",)``."""
        ...

    def dim_sizes(self, design: Tube) -> dict[str, int]:
        """Length of every extra (non-grid) dimension of the output variables."""
        ...

    def evaluate(
        self, tubes: Sequence[Tube], loads: Sequence[Mapping[str, float]], batch: int
    ) -> dict[str, np.ndarray]:
        """Arrays (n_points, ...) for the points; must include ``status`` (int)."""
        ...

    def variables(self, design: Tube) -> dict[str, tuple[tuple[str, ...], str, str]]:
        """name → (extra dims, unit, description) of every output variable."""
        ...

    def finish(self, ds: Any) -> Any:
        """Post-process the assembled Dataset (e.g. label a transition band)."""
        ...

    def describe(self) -> dict[str, Any]:
        """Settings recorded in the Dataset's attributes."""
        ...


class ChunkSink(Protocol):
    """Where finished chunks go (``biplan.io.sweepstore.ChunkStore``)."""

    def done(self, chunk: int) -> bool: ...

    def load(self, chunk: int) -> dict[str, np.ndarray]: ...

    def save(self, chunk: int, result: dict[str, np.ndarray]) -> None: ...


def chunk_indices(grid: Grid, chunk_size: int) -> list[np.ndarray]:
    """Flat point indices of every chunk (the last one may be shorter)."""
    chunk_size = check_integer("chunk_size", chunk_size, low=1)
    return [
        np.arange(lo, min(lo + chunk_size, grid.size)) for lo in range(0, grid.size, chunk_size)
    ]


def _nan_result(evaluator: Evaluator, design: Tube, n: int, code: int) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for name, (dims, _, _) in evaluator.variables(design).items():
        extra = tuple(_extent(evaluator, design, d) for d in dims)
        if name == "status":
            out[name] = np.full((n, *extra), code, dtype=np.int64)
        else:
            out[name] = np.full((n, *extra), np.nan)
    return out


def _extent(evaluator: Evaluator, design: Tube, dim: str) -> int:
    return evaluator.dim_sizes(design)[dim]


def evaluate_chunk(
    design: Tube, grid: Grid, evaluator: Evaluator, indices: np.ndarray, batch: int
) -> dict[str, np.ndarray]:
    """Evaluate the points ``indices`` of ``grid`` (a chunk; ``batch``: the evaluator's
    ``batch`` argument, the chunk size).

    Points whose design is invalid get status ``invalid``; a chunk whose batched evaluation
    raises is retried point by point, and a point that still raises gets status ``error``.
    Either way the other points are kept. Pure and picklable: this is what a worker runs.
    """
    tubes: list[Tube | None] = []
    loads: list[dict[str, float]] = []
    for i in indices:
        values = grid.point(int(i))
        loads.append({k: v for k, v in values.items() if k in evaluator.load_axes})
        try:
            tubes.append(apply_values(design, values))
        except ConfigError:
            tubes.append(None)
    n = len(indices)
    result = _nan_result(evaluator, design, n, STATUS["invalid"])
    good = [k for k, t in enumerate(tubes) if t is not None]
    if not good:
        return result

    def run(which: list[int]) -> dict[str, np.ndarray]:
        return evaluator.evaluate(
            [tubes[k] for k in which],  # type: ignore[misc]
            [loads[k] for k in which],
            batch,
        )

    try:
        parts = [(good, run(good))]
    except Exception:
        parts = []
        for k in good:
            try:
                parts.append(([k], run([k])))
            except Exception:
                err = _nan_result(evaluator, design, 1, STATUS["error"])
                parts.append(([k], err))
    for which, part in parts:
        for name, arr in part.items():
            result[name][which] = arr
    return result


def run_local(
    task: Callable[[np.ndarray], dict[str, np.ndarray]], todo: list[tuple[int, np.ndarray]]
) -> Iterable[tuple[int, dict[str, np.ndarray]]]:
    """The runner of this process: chunks one after the other
    (:mod:`biplan.analysis.scaleout` has the parallel ones)."""
    for cid, idx in todo:
        yield cid, task(idx)


def run_chunks(
    task: Callable[[np.ndarray], dict[str, np.ndarray]],
    chunks: Sequence[np.ndarray],
    *,
    runner: Callable[..., Iterable[tuple[int, dict[str, np.ndarray]]]] | None = None,
    sink: ChunkSink | None = None,
    progress: Callable[[int, int], object] | None = None,
    wanted: Sequence[int] | None = None,
) -> dict[int, dict[str, np.ndarray]]:
    """The results of chunks (arrays of indices) by chunk number: those ``sink`` holds are
    loaded, the others (of ``wanted``; default all) computed as ``task(indices)`` by ``runner``
    (default this process, :func:`run_local`) and saved to ``sink`` as they finish;
    ``progress(indices_done, n_indices)`` after the loaded ones and after every chunk."""
    results: dict[int, dict[str, np.ndarray]] = {}
    todo: list[tuple[int, np.ndarray]] = []
    keep = set(range(len(chunks)) if wanted is None else wanted)
    for cid, idx in enumerate(chunks):
        if sink is not None and sink.done(cid):
            results[cid] = sink.load(cid)
        elif cid in keep:
            todo.append((cid, idx))
    total = sum(len(c) for c in chunks)
    done = sum(len(chunks[c]) for c in results)
    if progress is not None:
        progress(done, total)
    for cid, res in (runner or run_local)(task, todo):
        results[cid] = res
        if sink is not None:
            sink.save(cid, res)
        done += len(chunks[cid])
        if progress is not None:
            progress(done, total)
    return results


def assemble(
    design: Tube,
    grid: Grid,
    evaluator: Evaluator,
    chunks: list[np.ndarray],
    results: Mapping[int, dict[str, np.ndarray]],
) -> Any:
    """The labelled Dataset of a finished sweep (dims: the grid axes, then extra dims)."""
    import xarray as xr

    specs = evaluator.variables(design)
    data_vars: dict[str, Any] = {}
    for name, (dims, unit, desc) in specs.items():
        parts = [results[c][name] for c in range(len(chunks))]
        flat = np.concatenate(parts, axis=0)
        arr = flat.reshape(grid.shape + flat.shape[1:])
        attrs: dict[str, Any] = {"units": unit, "long_name": desc}
        if name == "status":
            attrs["flag_values"] = list(STATUS.values())
            attrs["flag_meanings"] = " ".join(STATUS)
        data_vars[name] = ((*grid.names, *dims), arr, attrs)
    coords = {}
    for a in grid.axes:
        attrs = {"units": a.unit}
        base = base_value(design, a.name)
        if base is not None:  # the swept design's own value (starred on the design map)
            attrs["base_value"] = base
        coords[a.name] = (a.name, np.asarray(a.values), attrs)
    ds = xr.Dataset(data_vars, coords=coords)
    ds.attrs["quantity"] = evaluator.name
    ds.attrs["n_points"] = grid.size
    ds.attrs["n_failed"] = int(np.sum(ds["status"].values != 0))
    for key, value in evaluator.describe().items():
        ds.attrs[f"setting_{key}"] = value
    return evaluator.finish(ds)


def check_grid(design: Tube, grid: Grid, quantity: Evaluator) -> None:
    """Check every axis name and every design value of ``grid`` (what :func:`sweep` does
    first, before solving anything).

    Raises
    ------
    ConfigError
        An axis that is neither a design quantity nor a load axis of ``quantity``, or a value
        that gives no valid tube (named by its axis, e.g. ``b``).
    """
    for axis in grid.axes:
        if axis.name not in QUANTITIES and axis.name not in quantity.load_axes:
            raise ConfigError(
                "grid axis", axis.name, f"one of {', '.join(QUANTITIES + quantity.load_axes)}"
            )
    for axis in grid.axes:
        for v in axis.values:
            if axis.name not in quantity.load_axes:
                apply_values(design, {axis.name: v})


def sweep(
    design: Tube,
    grid: Grid,
    quantity: Evaluator,
    *,
    chunk_size: int = 32,
    sink: ChunkSink | None = None,
    runner: Callable[..., Iterable[tuple[int, dict[str, np.ndarray]]]] | None = None,
    progress: Callable[[int, int], object] | None = None,
    chunks_to_run: Sequence[int] | None = None,
) -> Any:
    """Evaluate ``quantity`` over ``grid`` for tubes derived from ``design``.

    Parameters
    ----------
    design : Tube
        The base design; every grid point changes the parameters named by the grid axes.
    grid : Grid
        Axes of :data:`QUANTITIES` (and the evaluator's load axes).
    quantity : Evaluator
        E.g. ``design_map.ResponseEvaluator()`` or ``stability_map.StabilityEvaluator()``.
    chunk_size : int
        Points per chunk (also passed to the evaluator as its ``batch``).
    sink : ChunkSink, optional
        Stream finished chunks to it; chunks it already holds are loaded, not recomputed.
    runner : callable, optional
        ``runner(task, todo)`` yielding ``(chunk, result)`` in any order
        (:mod:`biplan.analysis.scaleout`, e.g. ``dask_runner``); default in this process.
    progress : callable, optional
        Called as ``progress(points_done, n_points)`` after every chunk.
    chunks_to_run : sequence of int, optional
        Run only these chunks (the rest must be in ``sink``); returns None if the sweep is then
        still incomplete. For tests of interruption and for manual partitioning.

    Returns
    -------
    xarray.Dataset or None
        Variables of ``quantity`` with dims (*grid axes, …), ``status`` per point, and the
        settings and ``chunk_size`` in the attributes.
    """
    check_grid(design, grid, quantity)
    chunks = chunk_indices(grid, chunk_size)
    task = functools.partial(evaluate_chunk, design, grid, quantity, batch=chunk_size)
    results = run_chunks(
        task, chunks, runner=runner, sink=sink, progress=progress, wanted=chunks_to_run
    )
    if len(results) < len(chunks):
        return None
    ds = assemble(design, grid, quantity, chunks, results)
    ds.attrs["chunk_size"] = chunk_size
    return ds
