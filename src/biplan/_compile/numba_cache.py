"""Where biplan's compiled (Numba) kernels are cached, and when that cache is stale.

Numba's own cache (``cache=True``) keys each function on its own source file: a kernel that
calls a function of another module keeps its machine code when only that module changes, and
Numba's in-tree locator creates a ``__pycache__`` folder when a module is imported. biplan's
kernels call across modules (the Newton calls the assembly, which calls the elements), so
:class:`BiplanLocator` replaces both rules for biplan's own files, and only for them:

* the cache lives in ``$BIPLAN_NUMBA_CACHE``, else ``$NUMBA_CACHE_DIR/biplan``, else
  ``$XDG_CACHE_HOME/biplan/numba`` (default ``~/.cache/biplan/numba``), in a folder named by a
  fingerprint of every biplan module that imports Numba: any change to one of them starts a fresh
  cache, so no kernel is served with another module's old code;
* the folder is created when the first compiled kernel is saved, never at import.

Nothing else of Numba's configuration is touched on import: other packages' functions are cached
as Numba decides. In processes that are biplan's own (the ``biplan`` command and its workers, the
test suite), :func:`use_own_opt_level` compiles at LLVM -O1 instead of Numba's -O3 unless
``NUMBA_OPT`` is set: the one-time compile takes about a fifth less time and the compiled kernels
run as fast (docs/performance.md, "One-time compile"). :func:`is_warm` tells whether the kernels
of this install are compiled already (the first use after an install compiles them once, a few
minutes).

Every compiled function of biplan is declared with :func:`kernel` (Numba's ``njit`` with
``cache=True``), which compiles one specialisation per argument *types*: a constant argument of
a call from compiled code (``evaluate(d, x, load, True)``) is typed as its type, not as the
literal value, so a function called with ``True`` in one place and ``False`` in another
compiles once, not twice (each specialisation re-optimises all the code it calls:
docs/performance.md, "One-time compile").
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit, types
from numba.core import caching

__all__ = [
    "OPT_LEVEL",
    "BiplanLocator",
    "cache_dir",
    "fingerprint",
    "inlined_kernel",
    "is_warm",
    "kernel",
    "kernel_array",
    "use_own_opt_level",
]

_PACKAGE = Path(__file__).resolve().parent.parent

#: A line importing Numba (``import numba``, ``from numba… import``) or :func:`kernel`.
_IMPORTS_NUMBA = re.compile(
    rb"^\s*(?:(?:from|import)\s+numba\b|from\s+biplan\._compile\.numba_cache\s+import\b.*\bkernel\b)",
    re.MULTILINE,
)
#: LLVM optimisation level of the compile in biplan's own processes (:func:`use_own_opt_level`).
OPT_LEVEL = 1


@functools.cache
def fingerprint() -> str:
    """SHA-256 (first 16 hex digits) of the sources of every biplan module that imports Numba
    or :func:`kernel` (the modules of compiled functions; a module that only names them is not
    one)."""
    digest = hashlib.sha256()
    for path in sorted(_PACKAGE.rglob("*.py")):
        text = path.read_bytes()
        if _IMPORTS_NUMBA.search(text):
            digest.update(str(path.relative_to(_PACKAGE)).encode())
            digest.update(text)
    return digest.hexdigest()[:16]


def cache_dir() -> Path:
    """The folder of this install's compiled kernels (module docstring)."""
    root = os.environ.get("BIPLAN_NUMBA_CACHE")
    if root:
        base = Path(root)
    elif os.environ.get("NUMBA_CACHE_DIR"):
        base = Path(os.environ["NUMBA_CACHE_DIR"]) / "biplan"
    else:
        xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        base = Path(xdg) / "biplan" / "numba"
    return base / fingerprint()


def is_warm() -> bool:
    """Whether compiled kernels of this install's sources are in the cache."""
    folder = cache_dir()
    return folder.is_dir() and any(folder.rglob("*.nbi"))


def use_own_opt_level() -> None:
    """Compile at LLVM -O:data:`OPT_LEVEL` in this process unless ``NUMBA_OPT`` is set.

    For processes that are biplan's own (the CLI calls it first, the test suite before it
    imports biplan; child processes inherit it); a library import never calls it. The level
    applies to every Numba function compiled afterwards in the process; kernels already in the
    cache are loaded whatever level compiled them (their results are the same: no fast-math).
    """
    if "NUMBA_OPT" in os.environ:
        return
    os.environ["NUMBA_OPT"] = str(OPT_LEVEL)
    from numba.core import config

    config.reload_config()


def kernel(func: Callable[..., Any] | None = None, **options: Any) -> Any:
    """``numba.njit(cache=True, **options)`` whose calls from compiled code are typed by the
    arguments' types, never by a constant's value (module docstring): ``@kernel`` or
    ``@kernel(inline="always")``.

    A call with a constant argument from other compiled code would otherwise compile (and
    cache) a specialisation for that literal value, e.g. one for ``second=True`` and one for
    ``second=False``, each re-optimising every function below it.
    """

    def declare(f: Callable[..., Any]) -> Any:
        dispatcher = njit(cache=True, **options)(f)
        literal_call_template = dispatcher.get_call_template

        def get_call_template(args: tuple, kws: dict) -> Any:  # type: ignore[type-arg]
            args = tuple(types.unliteral(a) for a in args)
            kws = {k: types.unliteral(v) for k, v in kws.items()}
            return literal_call_template(args, kws)

        dispatcher.get_call_template = get_call_template
        return dispatcher

    return declare if func is None else declare(func)


#: The decorator of the small element kernels: compiled once per signature and inlined by LLVM
#: into their callers (``forceinline``), with NumPy's error model (a division by zero gives ±inf
#: or nan, as JAX does, instead of raising), so that an element costs no call and Numba prunes
#: the reference counting of its arrays (:mod:`biplan.model.system.elements`).
inlined_kernel = kernel(forceinline=True, error_model="numpy")


def kernel_array(a: Any, dtype: Any = None) -> Any:
    """``a`` as an array a kernel takes without compiling again: writable and C-contiguous
    (copied only where it is not). Numba types a read-only array (a JAX array seen through
    NumPy, a global constant, a view of a frozen buffer) or a strided one as another argument
    type, so each would compile every kernel below the call once more."""
    return np.require(a, dtype=dtype, requirements=("C", "W"))


class BiplanLocator(caching._CacheLocator):
    """Numba cache locator for functions defined in biplan's own files (module docstring)."""

    def __init__(self, py_func: Any, py_file: str) -> None:
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        relative = Path(py_file).resolve().relative_to(_PACKAGE)
        self._cache_path = str(cache_dir() / relative.parent)

    def ensure_cache_path(self) -> None:
        Path(self._cache_path).mkdir(parents=True, exist_ok=True)

    def get_cache_path(self) -> str:
        return self._cache_path

    def get_source_stamp(self) -> Any:
        return fingerprint()

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func: Any, py_file: str) -> BiplanLocator | None:
        try:
            Path(py_file).resolve().relative_to(_PACKAGE)
        except (ValueError, OSError):
            return None
        return cls(py_func, py_file)


def register() -> None:
    """Put :class:`BiplanLocator` first among Numba's locators (once; it declines every file
    outside biplan)."""
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl")  # noqa: B009  (renamed in Numba 0.61)
    classes = impl._locator_classes
    if BiplanLocator not in classes:
        classes.insert(0, BiplanLocator)


register()
