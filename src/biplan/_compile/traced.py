"""Traced JAX functions: traced once, reused by every later process (``jax.export``).

JAX's persistent compilation cache (:mod:`biplan._compile.setup`) skips XLA's compile on a warm
start, but every new process still *traces and lowers* each function to find its cache key: for
biplan's large functions that is most of a warm start (a warm ``biplan demo`` spent 28 of its
49 s tracing and lowering; docs/performance.md, "Warm starts: the trace store").

:func:`stored_jit` is ``jax.jit`` plus a store of the traced functions. On its first call for
an argument signature (pytree structure, shapes and dtypes) a function is exported
(:func:`jax.export.export`: traced and lowered to StableHLO once) and written to
``$BIPLAN_JAX_CACHE/kernels``; a later process (a new session, a Dask worker, the other test
worker) reads it back and only compiles it — a hit in the persistent compilation cache when
the cache is warm. The arithmetic is the function's own: results equal ``jax.jit``'s.

An entry is keyed by the function's name and static key (the tube layout, …), the signature,
the JAX and jaxlib versions, the backend, and a fingerprint of biplan's own source files, so
an edited or upgraded biplan never reads a stale kernel. The store follows the compilation
cache: ``BIPLAN_JAX_CACHE=off`` turns both off; ``BIPLAN_TRACE_STORE=off`` turns off only
the store. A kernel that cannot be exported (or an unreadable entry) falls back to plain
``jax.jit`` (or is exported again), so the store can only save time. An entry holds no
pickle: it is ``jax.export``'s serialized StableHLO module and a JSON description of the
output's pytree structure (tuples, lists, dicts, None and NamedTuples named by module and
class; :mod:`biplan._compile.trace_entries`), read back by looking the classes up among the
modules the process has already imported — loading an entry imports nothing and calls no code
but the NamedTuple constructors, so a store in a shared folder cannot run Python code. (The JAX
compilation cache beside it holds compiled executables: trust that folder as you trust
any cache of native code.)
"""

from __future__ import annotations

import collections
import functools
import hashlib
import os
import threading
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from biplan._compile import setup as _jax
from biplan._compile.setup import jax, jnp
from biplan._compile.trace_entries import entry_lock, read_entry, write_entry

__all__ = ["StoredJit", "Traced", "stored_jit", "trace_store", "traced"]

_OFF = {"", "0", "off", "none", "false"}  # as BIPLAN_JAX_CACHE, plus "false"
#: Bumped when the entry format changes.
_FORMAT = 2


def trace_store() -> Path | None:
    """Folder of the stored traces, or None when the store is off (read at each lookup)."""
    if os.environ.get("BIPLAN_TRACE_STORE", "on").lower() in _OFF:
        return None
    if _jax.CACHE_DIR is None:
        return None
    return _jax.CACHE_DIR / "kernels"


@functools.cache
def _source_fingerprint() -> str:
    """sha256 of every ``.py`` file of the installed biplan package (path and bytes)."""
    root = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _environment() -> str:
    import jaxlib

    return "|".join(
        [
            str(_FORMAT),
            _source_fingerprint(),
            jax.__version__,
            jaxlib.__version__,
            jax.default_backend(),
            str(jnp.asarray(0.0).dtype),  # float64 on
        ]
    )


class StoredJit:
    """A jitted function whose traced form is stored on disk (:func:`stored_jit`).

    Call it like the ``jax.jit`` of ``fun``. Arguments are pytrees of arrays (NumPy or JAX)
    and scalars; every leaf is traced (no static arguments: bind those with
    :func:`functools.partial` and name them in ``key``).
    """

    def __init__(
        self,
        fun: Callable[..., Any],
        name: str,
        key: Any = None,
        compiler_options: dict[str, Any] | None = None,
    ) -> None:
        self._fun = fun
        self._name = name
        self._key = repr(key)
        self._options = compiler_options
        self._jit: Any = jax.jit(fun, compiler_options=compiler_options)
        # JAX takes compiler options only on a top-level jit: inside another kernel's trace
        # this one is inlined as a plain jit
        self._nested: Any = jax.jit(fun) if compiler_options else self._jit
        self._calls: dict[Any, tuple[Any, Any]] = {}
        self._lock = threading.Lock()

    def __repr__(self) -> str:
        return f"StoredJit({self._name}, {len(self._calls)} signature(s))"

    def _cache_size(self) -> int:
        """Compilations in this process (as ``jax.jit``'s ``_cache_size``)."""
        stored = [out_tree is not None for _, out_tree in self._calls.values()]
        return sum(stored) + (0 if all(stored) else int(self._jit._cache_size()))

    def clear_cache(self) -> None:
        """Forget this process's signatures (as ``jax.jit``'s; the store is kept)."""
        with self._lock:
            self._calls.clear()
        self._jit.clear_cache()
        self._nested.clear_cache()

    def __call__(self, *args: Any) -> Any:
        leaves, tree = jax.tree_util.tree_flatten(args)
        if any(isinstance(x, jax.core.Tracer) for x in leaves):  # inside a transformation
            return self._nested(*args)
        leaves = [_as_array(x) for x in leaves]
        signature = (tree, tuple((x.shape, x.dtype) for x in leaves))
        entry = self._calls.get(signature)
        if entry is None:
            with self._lock:
                entry = self._calls.get(signature)
                if entry is None:
                    entry = self._calls[signature] = self._build(tree, leaves)
        call, out_tree = entry
        if out_tree is None:  # not exportable: plain jit
            return call(*args)
        return jax.tree_util.tree_unflatten(out_tree, call(*leaves))

    # --- building a signature's callable --------------------------------------------------
    def _build(self, tree: Any, leaves: list[Any]) -> tuple[Callable[..., Any], Any]:
        store = trace_store()
        if store is None:
            return self._jit, None
        avals = [jax.ShapeDtypeStruct(x.shape, x.dtype) for x in leaves]
        text = "|".join([_environment(), self._name, self._key, str(tree), repr(avals)])
        file = store / f"{self._name}-{hashlib.sha256(text.encode()).hexdigest()[:32]}.kernel"
        # One process at a time builds an entry: another that needs the same kernel meanwhile
        # (a test worker, a Dask worker) waits, then reads the entry and finds the executable
        # in the persistent compilation cache instead of tracing and compiling it again.
        with entry_lock(file):
            loaded = read_entry(file)
            if loaded is None:  # missing, damaged or unreadable: trace and store
                made = self._export(tree, avals)
                if made is None:
                    return self._jit, None
                write_entry(file, made)
                loaded = jax.export.deserialize(bytearray(made[0])), made[1]
            exported, out_tree = loaded
            # compiled ahead of time for the signature: one executable whatever the arguments'
            # weak types and placement (``jax.jit`` compiles again for a committed argument)
            call = jax.jit(_named(exported.call, self._name), compiler_options=self._options)
            return call.lower(*avals).compile(), out_tree

    def _export(self, tree: Any, avals: list[Any]) -> tuple[bytes, Any] | None:
        out_tree: list[Any] = []

        def flat(*leaves: Any) -> Any:
            out, treedef = jax.tree_util.tree_flatten(
                self._fun(*jax.tree_util.tree_unflatten(tree, leaves))
            )
            out_tree.append(treedef)
            return out

        try:
            exported = jax.export.export(jax.jit(flat))(*avals)
            return bytes(exported.serialize()), out_tree[-1]
        except Exception:
            return None


def _named(call: Callable[..., Any], name: str) -> Callable[..., Any]:
    """``call`` under the kernel's name: JAX's compile logs and profiles then say
    ``jit(<name>)`` rather than ``jit(call)`` for every stored kernel."""

    def kernel(*args: Any) -> Any:
        return call(*args)

    kernel.__name__ = kernel.__qualname__ = name
    return kernel


def _as_array(x: Any) -> Any:
    """A leaf as a JAX array of its NumPy dtype (a Python float is float64, not weak)."""
    return x if isinstance(x, jax.Array) else jnp.asarray(np.asarray(x))


_KERNELS: weakref.WeakSet[StoredJit] = weakref.WeakSet()


def _forget_compiled() -> None:
    """Drop every stored kernel's executables (they are rebuilt from the store on demand)."""
    for kernel in list(_KERNELS):
        kernel.clear_cache()


_jax.CLEAR_HOOKS.append(_forget_compiled)


def stored_jit(
    fun: Callable[..., Any],
    name: str,
    key: Any = None,
    compiler_options: dict[str, Any] | None = None,
) -> StoredJit:
    """``jax.jit(fun, compiler_options=…)`` whose traced kernels are stored on disk.

    Parameters
    ----------
    fun : callable
        The kernel; every argument is traced.
    name : str
        Function name (the entries' file prefix).
    key : object
        What else determines the traced function — whatever ``fun`` closes over (a tube
        layout, a lane count); its ``repr`` enters the entry's key and must be deterministic.
    compiler_options : dict, optional
        As ``jax.jit``'s.
    """
    kernel = StoredJit(fun, name, key, compiler_options)
    _KERNELS.add(kernel)
    return kernel


#: Compiled forms a :class:`Traced` keeps (most recently used static arguments).
KEPT = 32


class Traced:
    """A pure kernel function and its compiled forms: the one kernel mechanism of biplan.

    ``traced(name)`` turns ``fun(*static, *traced)`` — a pure function whose first ``statics``
    arguments (a tube layout, a lane count, …) fix the traced graph — into a :class:`Traced`.
    Calling it calls ``fun`` itself (so other kernels inline it, ``vmap`` it, differentiate
    it); :meth:`compiled` returns the stored, jitted kernel of the static arguments
    (:func:`stored_jit`), built once per process and traced once per machine.

    Parameters
    ----------
    fun : callable
        The pure function.
    name : str
        Function name (file prefix of the stored entries; ``jit(<name>)`` in JAX's logs).
    statics : int
        How many leading arguments are static (hashable; their ``repr`` keys the store).
    in_axes : tuple, optional
        ``jax.vmap`` axes of the traced arguments: the compiled kernel is the batched one.
    axis_name : str, optional
        With ``in_axes``: the name of the batch axis, also passed to ``fun`` as its
        ``axis_name`` keyword (collectives over the lanes, e.g. skipping work no lane needs).
    runs_often : bool
        Compiled with the light pipeline under ``BIPLAN_FAST_COMPILE`` (a kernel called
        hundreds of times per run; :func:`biplan._compile.setup.xla_options`).
    """

    def __init__(
        self,
        fun: Callable[..., Any],
        name: str,
        statics: int = 1,
        in_axes: tuple | None = None,
        axis_name: str | None = None,
        runs_often: bool = False,
    ) -> None:
        self.fun = fun
        self.name = name
        self.statics = statics
        self.in_axes = in_axes
        self.axis_name = axis_name
        self.runs_often = runs_often
        self._compiled: collections.OrderedDict[tuple, StoredJit] = collections.OrderedDict()
        self._lock = threading.Lock()
        functools.update_wrapper(self, fun)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.fun(*args, **kwargs)

    def __repr__(self) -> str:
        return f"Traced({self.name}, {len(self._compiled)} compiled)"

    def compiled(self, *static: Any) -> StoredJit:
        """The stored, jitted kernel of these static arguments (built once per process; the
        :data:`KEPT` most recently used are kept, so a process that sees many tube layouts
        frees the executables of old ones)."""
        if len(static) != self.statics:
            raise TypeError(f"kernel {self.name} takes {self.statics} static argument(s)")
        with self._lock:
            found = self._compiled.get(static)
            if found is not None:
                self._compiled.move_to_end(static)
            else:
                named = {} if self.axis_name is None else {"axis_name": self.axis_name}
                fn = functools.partial(self.fun, *static, **named)
                if self.in_axes is not None:
                    fn = jax.vmap(fn, in_axes=self.in_axes, axis_name=self.axis_name)
                key = static[0] if self.statics == 1 else static
                found = stored_jit(fn, self.name, key, _jax.xla_options(self.runs_often))
                self._compiled[static] = found
                if len(self._compiled) > KEPT:
                    self._compiled.popitem(last=False)
            return found


def traced(
    name: str,
    *,
    statics: int = 1,
    in_axes: tuple | None = None,
    axis_name: str | None = None,
    runs_often: bool = False,
) -> Callable[[Callable[..., Any]], Traced]:
    """Decorator: the pure function as a :class:`Traced` named ``name`` (its parameters:
    :class:`Traced`)."""

    def wrap(fun: Callable[..., Any]) -> Traced:
        return Traced(fun, name, statics, in_axes, axis_name, runs_often)

    return wrap
