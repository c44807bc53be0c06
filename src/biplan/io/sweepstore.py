"""Chunked, resumable sweep results on disk.

Layout of an output directory::

    DIR/manifest.json          what is being computed (config, grid, quantity, chunk size)
                               and which chunks are finished
    DIR/chunks/chunk-00012.npz one NumPy archive per finished chunk (flat point axis; a run
                               of an earlier biplan, resumed, has netCDF files, read as well)
    DIR/map.nc                 the merged, labelled Dataset once every chunk is finished

A chunk file is written to a temporary name and renamed, then the manifest is rewritten the
same way, so a run killed at any moment leaves only complete chunk files. ``--resume`` checks
that the manifest describes the same sweep (same config, grid, quantity settings and chunk
size; a refusal names the entries that differ, e.g. ``settings.solver`` for a map of an
earlier solver) and loads the finished chunks instead of recomputing them. A chunk archive
(``numpy.savez``, uncompressed, read without pickle) stores its arrays exactly, so a resumed
map equals an uninterrupted one bit for bit; a chunk of the ten-module state search (128
seeds) is stored in about 1 ms, where a netCDF file took 34–38 ms, a third of the time its
seeds take to relax (``benchmarks/bench_state_files.py``).

A finished chunk whose file is missing or cannot be read (truncated, overwritten) is recorded
in :attr:`ChunkStore.damaged` with the reason and computed again. A directory holding chunk
files but no manifest is refused: without the manifest nothing says which sweep the chunks
belong to (restore ``manifest.json``, or remove ``chunks/`` to start again). An unreadable
manifest is refused too.
"""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan._errors import ConfigError
from biplan.analysis.maps import sweeps
from biplan.analysis.maps.runs import MapJob
from biplan.io.config import dump_config
from biplan.io.netcdf import write_netcdf

if TYPE_CHECKING:
    from biplan.analysis.maps.sweeps import Evaluator, Grid
    from biplan.model.tube import Tube

__all__ = ["MAP_FILE", "ChunkStore", "load_map", "open_map", "save_map"]

#: File name of the merged map in an output directory.
MAP_FILE = "map.nc"
_MANIFEST = "manifest.json"


def _atomic_write(path: Path, write: Any) -> None:
    tmp = path.with_name(path.name + ".part")
    write(tmp)
    os.replace(tmp, path)


def _differences(old: Any, new: Any, prefix: str = "") -> list[str]:
    """The entries in which two sweep descriptions differ (``settings.solver``, ``grid.C``,
    ``chunk_size``, …; nested one level), or the whole description when the old one is
    missing."""
    if not isinstance(old, dict) or not isinstance(new, dict):
        return [prefix or "the description"] if old != new else []
    out: list[str] = []
    for key in sorted(set(old) | set(new)):
        a, b = old.get(key), new.get(key)
        if a != b:
            name = f"{prefix}.{key}" if prefix else str(key)
            nested = not prefix and isinstance(a, dict) and isinstance(b, dict)
            out += _differences(a, b, name) if nested else [name]
    return out


class ChunkStore:
    """A directory of finished chunks of one sweep (implements ``sweeps.ChunkSink``).

    Parameters
    ----------
    directory : str or Path
        Output directory (created).
    description : dict
        JSON-serialisable description of the sweep (config text, grid, quantity settings,
        chunk size); a resumed run must describe the same sweep.
    n_chunks : int
        Number of chunks of the sweep.
    resume : bool
        Keep the finished chunks of an earlier run of the same sweep. Without it, a directory
        that already holds chunks of a sweep is refused (ConfigError), never overwritten.

    Attributes
    ----------
    damaged : dict of int to str
        Finished chunks of the earlier run whose file is missing or unreadable, with the
        reason; they are computed again.
    reused : int
        Chunks of the earlier run that are reused.

    Raises
    ------
    ConfigError
        ``out``: the directory holds finished chunks and ``resume`` is false, holds chunk files
        but no manifest, or its manifest is unreadable; ``--resume``: the manifest describes
        another sweep.
    """

    def __init__(
        self, directory: str | Path, description: dict[str, Any], n_chunks: int, resume: bool
    ) -> None:
        self.directory = Path(directory)
        self.chunk_dir = self.directory / "chunks"
        self.description = json.loads(json.dumps(description))
        self.key = hashlib.sha256(json.dumps(self.description, sort_keys=True).encode()).hexdigest()
        self.n_chunks = n_chunks
        self.finished: set[int] = set()
        #: Finished chunks of the earlier run that are computed again → why (``--resume``).
        self.damaged: dict[int, str] = {}
        self._loaded: dict[int, dict[str, np.ndarray]] = {}
        old = self._read_manifest()
        if old is not None:
            if old.get("finished") and not resume:
                raise ConfigError(
                    "out", str(self.directory), "an empty directory, or --resume to continue"
                )
            if resume and old.get("key") != self.key:
                differ = _differences(old.get("sweep"), self.description)
                why = f"; this one differs in {', '.join(differ)}" if differ else ""
                raise ConfigError(
                    "--resume",
                    str(self.directory),
                    f"a directory of the same sweep (config, grid, settings and chunk size){why}",
                )
            if resume:
                self._reuse(old.get("finished", []))
        self.chunk_dir.mkdir(parents=True, exist_ok=True)
        self._write_manifest()

    def _read_manifest(self) -> dict[str, Any] | None:
        """The manifest of an earlier run (None if there is none); refuses chunk files
        without a manifest and an unreadable manifest."""
        manifest = self.directory / _MANIFEST
        if not manifest.exists():
            orphans = sorted(self.chunk_dir.glob("chunk-*")) if self.chunk_dir.is_dir() else []
            if orphans:
                raise ConfigError(
                    "out",
                    str(self.directory),
                    f"a directory with its {_MANIFEST}: it holds {len(orphans)} chunk files but "
                    "no manifest, so they cannot be matched to this sweep (restore "
                    f"{_MANIFEST}, or remove {self.chunk_dir} to start again)",
                )
            return None
        try:
            old = json.loads(manifest.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
            raise ConfigError(
                "out", str(self.directory), f"a directory with a readable {_MANIFEST} ({err})"
            ) from None
        if not isinstance(old, dict):
            raise ConfigError(
                "out", str(self.directory), f"a directory with a readable {_MANIFEST}"
            )
        return old

    def _reuse(self, finished: list[int]) -> None:
        """Keep the finished chunks of an earlier run that read back; the others are
        recorded in :attr:`damaged` (and computed again)."""
        for chunk in finished:
            if not (self._path(chunk).exists() or self._netcdf_path(chunk).exists()):
                self.damaged[chunk] = "its file is missing"
                continue
            try:
                self._loaded[chunk] = self._read(chunk)
            except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
                self.damaged[chunk] = f"its file cannot be read ({err})"
                continue
            self.finished.add(chunk)

    @property
    def reused(self) -> int:
        """Number of chunks of an earlier run that are reused."""
        return len(self._loaded)

    def _path(self, chunk: int) -> Path:
        return self.chunk_dir / f"chunk-{chunk:05d}.npz"

    def _write_manifest(self) -> None:
        data = {
            "key": self.key,
            "n_chunks": self.n_chunks,
            "finished": sorted(self.finished),
            "sweep": self.description,
        }
        _atomic_write(
            self.directory / _MANIFEST, lambda p: p.write_text(json.dumps(data, indent=1))
        )

    def done(self, chunk: int) -> bool:
        """Whether ``chunk`` is finished on disk."""
        return chunk in self.finished

    def save(self, chunk: int, result: dict[str, np.ndarray]) -> None:
        """Write one finished chunk (arrays with a leading point axis; numbers, booleans or
        strings: an object array is refused with TypeError, it would need pickle)."""
        arrays = {name: np.asarray(arr) for name, arr in result.items()}
        for name, arr in arrays.items():
            if arr.dtype.hasobject:
                raise TypeError(f"chunk array {name!r} holds Python objects: not storable")

        def write(path: Path) -> None:
            with path.open("wb") as f:
                np.savez(f, allow_pickle=False, **arrays)

        _atomic_write(self._path(chunk), write)
        self.finished.add(chunk)
        self._write_manifest()

    def load(self, chunk: int) -> dict[str, np.ndarray]:
        """The arrays of a finished chunk."""
        if chunk in self._loaded:
            return self._loaded[chunk]
        return self._read(chunk)

    def _netcdf_path(self, chunk: int) -> Path:
        """Where biplan before the archives wrote the chunk (a netCDF file)."""
        return self.chunk_dir / f"chunk-{chunk:05d}.nc"

    def _read(self, chunk: int) -> dict[str, np.ndarray]:
        if not self._path(chunk).exists() and self._netcdf_path(chunk).exists():
            import xarray as xr  # a run of an earlier biplan, resumed

            with xr.open_dataset(self._netcdf_path(chunk), engine="h5netcdf") as ds:
                return {str(name): np.asarray(ds[name].values) for name in ds.data_vars}
        archive = np.load(self._path(chunk), allow_pickle=False)
        if not isinstance(archive, np.lib.npyio.NpzFile):
            raise ValueError("not a chunk archive (.npz)")
        with archive:
            return {name: archive[name] for name in archive.files}

    @property
    def map_path(self) -> Path:
        return self.directory / MAP_FILE

    def write_map(self, ds: Any) -> Path:
        """Write the merged map to :attr:`map_path` (:func:`save_map`); returns the path."""
        return save_map(ds, self.map_path)


def save_map(ds: Any, path: str | Path) -> Path:
    """Write a merged map Dataset to netCDF (h5netcdf), atomically."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    _atomic_write(out, lambda p: write_netcdf(ds, p))
    return out


def load_map(path: str | Path) -> Any:
    """Read a map (a directory holding ``map.nc``, or the file itself) into memory."""
    import xarray as xr

    p = Path(path)
    if p.is_dir():
        p = p / MAP_FILE
    if not p.exists():
        raise ConfigError("map", str(path), f"a map directory holding {MAP_FILE} or a .nc file")
    try:
        with xr.open_dataset(p, engine="h5netcdf") as ds:
            return ds.load()
    except (OSError, ValueError) as err:
        raise ConfigError("map", str(path), f"a readable netCDF map ({err})") from None


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
