"""JAX set-up shared by every layer: float64 on, persistent compilation cache.

Importing this module enables ``jax_enable_x64`` (all energies are float64) and points JAX's
persistent compilation cache at ``$BIPLAN_JAX_CACHE`` (default ``~/.cache/biplan/jax``) so
that kernels compiled in one process are reused by the next (cold-start time is user time).
Set ``BIPLAN_JAX_CACHE=off`` to disable the cache.
"""

from __future__ import annotations

import os
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

_cache = os.environ.get("BIPLAN_JAX_CACHE", str(Path.home() / ".cache" / "biplan" / "jax"))
if _cache.lower() not in {"", "0", "off", "none"}:
    try:
        Path(_cache).mkdir(parents=True, exist_ok=True)
        jax.config.update("jax_compilation_cache_dir", _cache)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.1)
        jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    except OSError:  # read-only home: run without the persistent cache
        pass

import jax.numpy as jnp  # noqa: E402

__all__ = ["jax", "jnp"]
