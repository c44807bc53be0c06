"""JAX set-up shared by every layer: float64 on, persistent compilation cache.

:func:`configure` (run once, when this module is first imported by biplan's numerical core;
``import biplan`` alone does not import it) enables ``jax_enable_x64`` (all energies are
float64) and points JAX's persistent compilation cache at ``$BIPLAN_JAX_CACHE`` (default
``$XDG_CACHE_HOME/biplan/jax``, ``~/.cache/biplan/jax`` without it) so that kernels compiled
in one process are reused by the next (cold-start time is user time).
Set ``BIPLAN_JAX_CACHE=off`` to disable the cache. Reads and writes of the cache are file-locked
(``filelock``), so processes running at once (Dask workers, test workers) can share it.

It also adds ``--xla_cpu_multi_thread_eigen=false`` to ``XLA_FLAGS`` (unless the user set that
flag): with JAX 0.10 on CPU, large ``vmap``-ped kernels with nested ``while`` loops (the batched
state relaxation, the stability map) intermittently wedge XLA's multi-threaded Eigen pool —
the process waits forever in ``block_until_ready`` with no CPU use (the same hang is reported
upstream for vmapped graphs, where this flag removes it). Single-threaded Eigen costs little
here (the kernels are many small matrices, parallelised by batching); set
``BIPLAN_EIGEN_THREADS=on`` to keep the multi-threaded pool. And it disables XLA:CPU's
"ynn" fusion (``--xla_cpu_experimental_ynn_fusion_type=``, unless set), which in jaxlib 0.10.2
hangs or crashes on some batched kernels on Linux x86-64 (jax-ml/jax#39257); the hang seen here
with the multi-threaded pool already off matches it.

And it runs the BLAS/LAPACK libraries (OpenBLAS of NumPy and SciPy, which jaxlib's CPU
LAPACK calls also use) on ``$BIPLAN_BLAS_THREADS`` threads (default 1) unless the user set
``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS`` or ``BLIS_NUM_THREADS``.
OpenBLAS's threads spin while they wait: with two processes on two cores (a test run with
two workers, a Dask cluster, a CLI run beside a notebook) a 505 × 505 LU took 138 ms instead
of 8 ms, and the 48-module Newton step 15× longer (docs/performance.md, "BLAS threads").
biplan's matrices are small (n ≤ a few thousand) and its parallelism is across points and
processes, so one thread each loses little even on an idle machine.

``BIPLAN_FAST_COMPILE=on`` compiles the JAX functions that compile long and run little (the
tests' oracle loops: the JAX Newton, dynamics, band relaxation, observation) with a cheap
pipeline (:data:`CHEAP_PIPELINE`, passed per function by :func:`xla_options`: LLVM at -O0
without its expensive passes, and XLA:CPU's loop emitters instead of its fusion emitters):
they compile 40–60 % faster and run up to ~2× slower, which pays where compilation dominates
(the test suite sets it; docs/performance.md, "Suite time"). The model's per-point autodiff
functions (:func:`biplan.model.assembly.autodiff_functions`: energy, residual, Jacobian,
state, …) and the sensitivities take it too (they compile in seconds and run in under a
millisecond either way). A function called hundreds of times per run (``runs_often``) takes
only :data:`LIGHT_PIPELINE` (compiles ~26 % faster, runs ~25 % slower).
"""

from __future__ import annotations

import functools
import importlib
import os
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

_ON = {"on", "1", "true"}
#: Environment variables by which a user sets the BLAS threads themselves (then left alone).
BLAS_THREAD_VARIABLES = (
    "OPENBLAS_NUM_THREADS",
    "OMP_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
)

#: The persistent compilation cache's folder (None: off, not writable, or not configured yet).
CACHE_DIR: Path | None = None
_CONFIGURED = False


def _stamp_unlocked_entries(path: Path) -> None:
    """Give entries written without the size limit (no ``-atime`` file) an access time.

    With the limit on, JAX reads every entry's ``-atime`` file before each write; one missing
    (a cache filled by an older biplan) makes every write fail with a warning.
    """
    import time

    stamp = time.time_ns().to_bytes(8, "little")
    for entry in path.glob("*-cache"):
        atime = entry.with_name(entry.name.removesuffix("-cache") + "-atime")
        if not atime.exists():
            atime.write_bytes(stamp)


def limit_blas_threads() -> int | None:
    """Run BLAS on ``$BIPLAN_BLAS_THREADS`` threads (default 1) unless the user chose (module
    docstring). Libraries already loaded are limited through ``threadpoolctl``; those loaded
    later (and child processes) read the environment variables set here. Returns the limit
    applied (None: the user's setting is kept)."""
    if any(os.environ.get(v) for v in BLAS_THREAD_VARIABLES):
        return None
    from biplan._errors import ConfigError

    raw = os.environ.get("BIPLAN_BLAS_THREADS", "1")
    try:
        threads = int(raw)
    except ValueError:
        threads = 0
    if threads < 1:
        raise ConfigError("BIPLAN_BLAS_THREADS", raw, "a whole number of threads ≥ 1")
    for variable in BLAS_THREAD_VARIABLES[:1] + BLAS_THREAD_VARIABLES[2:]:
        os.environ[variable] = str(threads)
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=threads, user_api="blas")
    return threads


def configure() -> None:
    """Apply biplan's JAX set-up, once per process: the only place biplan sets global state.

    Called when biplan's numerical core is first imported (any module that computes imports
    this one); ``import biplan`` alone, ``biplan --help`` and ``biplan --version`` do not
    call it. It

    * extends ``XLA_FLAGS`` with the two flags of the module docstring (a flag the user set
      is kept, never overwritten; XLA reads them when JAX starts its CPU backend, so they
      apply if no JAX computation ran before);
    * limits the BLAS threads (module docstring; ``BIPLAN_BLAS_THREADS``, default 1);
    * turns on float64 (``jax_enable_x64``): every biplan energy is float64;
    * points JAX's persistent compilation cache at ``$BIPLAN_JAX_CACHE`` (default
      ``$XDG_CACHE_HOME/biplan/jax``, else ``~/.cache/biplan/jax``; ``off`` disables it),
      unless the user configured a cache directory of their own.
    """
    global CACHE_DIR, _CONFIGURED
    if _CONFIGURED:
        return
    _CONFIGURED = True
    import jax

    flags = os.environ.get("XLA_FLAGS", "")
    wanted = ["--xla_cpu_experimental_ynn_fusion_type="]
    if os.environ.get("BIPLAN_EIGEN_THREADS", "").lower() not in _ON:
        wanted.append("--xla_cpu_multi_thread_eigen=false")
    for flag in wanted:  # a flag the user set wins
        if flag.split("=")[0].removeprefix("--") not in flags:
            flags += " " + flag
    os.environ["XLA_FLAGS"] = flags.strip()
    limit_blas_threads()
    jax.config.update("jax_enable_x64", True)
    user_cache = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    cache = os.environ.get("BIPLAN_JAX_CACHE", str(Path(user_cache) / "biplan" / "jax"))
    if cache.lower() in {"", "0", "off", "none"} or getattr(
        jax.config, "jax_compilation_cache_dir", None
    ):
        return
    try:
        Path(cache).mkdir(parents=True, exist_ok=True)
        jax.config.update("jax_compilation_cache_dir", cache)
        CACHE_DIR = Path(cache)
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.1)
        jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
        # A size limit turns on JAX's file lock around every cache read and write (without it
        # a process can read an entry that another — a Dask worker, a test worker — is still
        # writing). 8 GiB: far above what biplan's kernels need, least recently used evicted.
        jax.config.update("jax_compilation_cache_max_size", 8 * 2**30)
        _stamp_unlocked_entries(Path(cache))
    except OSError:  # read-only home: run without the persistent cache
        CACHE_DIR = None


class _Lazy:
    """A module imported, and :func:`configure` applied, on first attribute access: biplan's
    geometry, laws and compiled (Numba) core import ``jax``/``jnp`` from here without
    importing JAX, so a process that never evaluates a JAX function never starts JAX nor
    changes its settings."""

    def __init__(self, name: str) -> None:
        self._name = name
        self._module: ModuleType | None = None

    def __getattr__(self, attr: str) -> Any:
        module = self.__dict__.get("_module")
        if module is None:
            configure()
            module = importlib.import_module(self.__dict__["_name"])
            self.__dict__["_module"] = module
        return getattr(module, attr)


jax: Any = _Lazy("jax")
jnp: Any = _Lazy("jax.numpy")


def array_module(*values: Any) -> Any:
    """NumPy where every value is a NumPy array or a Python or NumPy number, else ``jnp``.

    A geometry function written against it evaluates NumPy input (a figure's kinematics) in
    NumPy, where ``jnp`` would compile one XLA kernel per operation and shape, and stays
    traceable (JAX arrays, tracers).
    """
    import numpy as np

    if all(isinstance(v, (np.ndarray, np.generic, float, int)) for v in values):
        return np
    return jnp


def lazy_jit(**options: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``functools.partial(jax.jit, **options)`` as a decorator that builds the jitted function
    on its first call, so that defining it does not import JAX."""

    def decorate(fn: Callable[..., Any]) -> Callable[..., Any]:
        @functools.cache
        def build() -> Any:
            return jax.jit(fn, **options)

        @functools.wraps(fn)
        def call(*args: Any, **kwargs: Any) -> Any:
            return build()(*args, **kwargs)

        return call

    return decorate


__all__ = [
    "CACHE_DIR",
    "CHEAP_PIPELINE",
    "array_module",
    "configure",
    "jax",
    "jnp",
    "lazy_jit",
    "memory_map_count",
    "release_jax_executables",
    "xla_options",
]

#: Called by :func:`release_jax_executables` after ``jax.clear_caches()``: modules that hold
#: compiled executables themselves register a function here that drops them.
CLEAR_HOOKS: list[Callable[[], None]] = []

#: XLA debug options of LLVM's cheap pipeline (``BIPLAN_FAST_COMPILE=on``): LLVM at -O0
#: without its expensive passes, and XLA:CPU's loop emitters instead of its MLIR fusion
#: emitters (those alone compile the Newton loop ~26 % faster and run it ~25 % slower).
CHEAP_PIPELINE: dict[str, int | bool] = {
    "xla_backend_optimization_level": 0,
    "xla_llvm_disable_expensive_passes": True,
    "xla_cpu_use_fusion_emitters": False,
}
#: The part of :data:`CHEAP_PIPELINE` that kernels run many times take (the scalar Newton
#: loop): it keeps LLVM's optimisation.
LIGHT_PIPELINE: dict[str, int | bool] = {"xla_cpu_use_fusion_emitters": False}


def xla_options(runs_often: bool = False) -> dict[str, int | bool] | None:
    """``compiler_options`` for ``jax.jit`` of a kernel: with ``BIPLAN_FAST_COMPILE`` on (read
    when the kernel is built) :data:`CHEAP_PIPELINE` for a kernel that compiles long and runs
    little, :data:`LIGHT_PIPELINE` for one that ``runs_often``; else None (XLA's default).

    A pipeline option the user set in ``XLA_FLAGS`` wins (it is left out here).
    """
    if os.environ.get("BIPLAN_FAST_COMPILE", "").lower() not in _ON:
        return None
    flags = os.environ.get("XLA_FLAGS", "")
    chosen = LIGHT_PIPELINE if runs_often else CHEAP_PIPELINE
    return {k: v for k, v in chosen.items() if k not in flags}


def memory_map_count() -> int:
    """Number of memory mappings of this process (``/proc/self/maps``; 0 where unavailable).

    Every executable that XLA:CPU compiles keeps about three mappings (code, constants, data)
    until JAX's caches drop it, and Linux caps a process at ``vm.max_map_count`` mappings
    (65,530 by default). A process that compiles ~20,000 executables — many tube layouts,
    or long eager (op-by-op) computations over many array shapes — then crashes with a
    segmentation fault inside XLA's compiler. :func:`release_jax_executables` prevents it.
    """
    try:
        with open("/proc/self/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:
        return 0


def _map_limit() -> int:
    try:
        return int(Path("/proc/sys/vm/max_map_count").read_text())
    except (OSError, ValueError):
        return 65530


def release_jax_executables(fraction: float = 0.5) -> bool:
    """Drop every compiled JAX executable if this process uses over ``fraction`` of its maps.

    AutodiffFunctions compile again on their next call (seconds to minutes), so call this between
    independent pieces of work in long-running processes (test-suites, notebooks that build
    many layouts), not inside loops. Returns whether the caches were cleared.
    """
    from biplan._errors import check_range

    fraction = check_range("fraction", fraction, low=0.0, high=1.0, low_open=False, high_open=False)
    if memory_map_count() <= fraction * _map_limit():
        return False
    import gc

    jax.clear_caches()
    for hook in CLEAR_HOOKS:  # executables held outside JAX's caches (biplan._compile.traced)
        hook()
    gc.collect()
    return True
