"""Chunked, resumable sweep results on disk.

Layout of an output directory::

    DIR/manifest.json          what is being computed (config, grid, quantity, chunk size)
                               and which chunks are finished
    DIR/chunks/chunk-00012.nc  one netCDF file per finished chunk (flat point axis)
    DIR/map.nc                 the merged, labelled Dataset once every chunk is finished

A chunk file is written to a temporary name and renamed, then the manifest is rewritten the
same way, so a run killed at any moment leaves only complete chunk files. ``--resume`` checks
that the manifest describes the same sweep (same config, grid, quantity settings and chunk
size) and loads the finished chunks instead of recomputing them. netCDF stores float64 and
int64 exactly, so a resumed map equals an uninterrupted one bit for bit.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from biplan._errors import ConfigError

__all__ = ["MAP_FILE", "ChunkStore", "load_map", "save_map"]

#: File name of the merged map in an output directory.
MAP_FILE = "map.nc"
_MANIFEST = "manifest.json"


def _atomic_write(path: Path, write: Any) -> None:
    tmp = path.with_name(path.name + ".part")
    write(tmp)
    os.replace(tmp, path)


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
    """

    def __init__(
        self, directory: str | Path, description: dict[str, Any], n_chunks: int, resume: bool
    ) -> None:
        self.directory = Path(directory)
        self.chunk_dir = self.directory / "chunks"
        self.chunk_dir.mkdir(parents=True, exist_ok=True)
        self.description = json.loads(json.dumps(description))
        self.key = hashlib.sha256(json.dumps(self.description, sort_keys=True).encode()).hexdigest()
        self.n_chunks = n_chunks
        manifest = self.directory / _MANIFEST
        self.finished: set[int] = set()
        if manifest.exists():
            old = json.loads(manifest.read_text())
            if old.get("finished") and not resume:
                raise ConfigError(
                    "out", str(self.directory), "an empty directory, or --resume to continue"
                )
            if resume and old.get("key") != self.key:
                raise ConfigError(
                    "--resume",
                    str(self.directory),
                    "a directory of the same sweep (config, grid, settings and chunk size)",
                )
            if resume:
                self.finished = {c for c in old.get("finished", []) if self._path(c).exists()}
        self._write_manifest()

    def _path(self, chunk: int) -> Path:
        return self.chunk_dir / f"chunk-{chunk:05d}.nc"

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
        """Write one finished chunk (arrays with a leading point axis)."""
        import xarray as xr

        data = {
            name: (("point", *(f"{name}_{k}" for k in range(1, arr.ndim))), arr)
            for name, arr in result.items()
        }
        ds = xr.Dataset(data)
        _atomic_write(self._path(chunk), lambda p: ds.to_netcdf(p, engine="h5netcdf"))
        self.finished.add(chunk)
        self._write_manifest()

    def load(self, chunk: int) -> dict[str, np.ndarray]:
        """The arrays of a finished chunk."""
        import xarray as xr

        with xr.open_dataset(self._path(chunk), engine="h5netcdf") as ds:
            return {str(name): np.asarray(ds[name].values) for name in ds.data_vars}

    @property
    def map_path(self) -> Path:
        return self.directory / MAP_FILE


def save_map(ds: Any, path: str | Path) -> Path:
    """Write a merged map Dataset to netCDF (h5netcdf), atomically."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    _atomic_write(out, lambda p: ds.to_netcdf(p, engine="h5netcdf"))
    return out


def load_map(path: str | Path) -> Any:
    """Read a map (a directory holding ``map.nc``, or the file itself) into memory."""
    import xarray as xr

    p = Path(path)
    if p.is_dir():
        p = p / MAP_FILE
    if not p.exists():
        raise ConfigError("map", str(path), f"a map directory holding {MAP_FILE} or a .nc file")
    with xr.open_dataset(p, engine="h5netcdf") as ds:
        return ds.load()
