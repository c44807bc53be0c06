"""The entries of the trace store (:mod:`biplan._compile.traced`) on disk.

An entry is one file: :data:`MAGIC` (the format version included), the length and JSON text of
the output's pytree structure (:func:`describe_tree`: tuples, lists, dicts, None and
NamedTuples named by module and class), then ``jax.export``'s serialized StableHLO module. It
holds no pickle: reading it back (:func:`read_entry`) looks the NamedTuple classes up among the
modules the process has already imported, so a store in a shared folder cannot run Python
code. Entries are written atomically (:func:`write_entry`), and one process builds an entry
while the others wait for it (:func:`entry_lock`).
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from biplan._compile.setup import jax

__all__ = [
    "LOCK_WAIT",
    "MAGIC",
    "describe_tree",
    "entry_lock",
    "read_entry",
    "tree_of_description",
    "write_entry",
]


#: Longest wait [s] for another process's build of an entry; past it this process builds the
#: kernel itself (a hung holder cannot hold the others up for ever).
LOCK_WAIT = 900.0


@contextlib.contextmanager
def entry_lock(file: Path) -> Iterator[None]:
    """An exclusive lock on ``<entry>.lock`` across processes (``flock``; released when the
    holder exits, even by a crash), waited for at most :data:`LOCK_WAIT` seconds. Where it
    cannot be had (no ``fcntl``, a read-only store, the wait ran out) the build goes on
    unlocked, as without the store."""
    try:
        import fcntl

        file.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(file.with_suffix(".lock"), os.O_RDWR | os.O_CREAT, 0o644)
    except (ImportError, OSError):
        yield
        return
    try:
        deadline, pause = time.monotonic() + LOCK_WAIT, 0.01
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() >= deadline:
                    break
                time.sleep(pause)
                pause = min(2 * pause, 0.5)
            except OSError:  # no locking on this file system
                break
        yield
    finally:
        os.close(fd)  # releases the lock


#: First bytes of an entry file (format version included).
MAGIC = b"BIPLANK2"


class _Leaf:
    """Placeholder leaf of a pytree skeleton."""


_LEAF = _Leaf()


def describe_tree(treedef: Any) -> Any:
    """A plain (JSON-ready) description of a pytree structure: tuples, lists, dicts with
    string keys, None, and NamedTuples (by module and qualified name). Raises ``TypeError``
    for any other node type (such a kernel is not stored)."""

    def walk(node: Any) -> Any:
        if node is _LEAF:
            return "*"
        if node is None:
            return None
        if isinstance(node, tuple) and hasattr(type(node), "_fields"):
            cls = type(node)
            return {
                "namedtuple": f"{cls.__module__}:{cls.__qualname__}",
                "of": [walk(x) for x in node],
            }
        if isinstance(node, tuple | list):
            return {type(node).__name__: [walk(x) for x in node]}
        if isinstance(node, dict) and all(isinstance(k, str) for k in node):
            return {"dict": [[k, walk(v)] for k, v in node.items()]}
        raise TypeError(f"pytree node {type(node).__name__} has no plain description")

    return walk(jax.tree_util.tree_unflatten(treedef, [_LEAF] * treedef.num_leaves))


def _namedtuple_class(name: str) -> type:
    """A NamedTuple class of a module this process has already imported (nothing is
    imported, nothing but the class's own constructor is ever called)."""
    module, _, qualname = name.partition(":")
    obj: Any = sys.modules.get(module)
    for part in qualname.split("."):
        obj = getattr(obj, part, None)
    if not (isinstance(obj, type) and issubclass(obj, tuple) and hasattr(obj, "_fields")):
        raise ValueError(f"{name} is not a loaded NamedTuple class")
    return obj


def tree_of_description(description: Any) -> Any:
    """The pytree structure (``PyTreeDef``) described by :func:`describe_tree`."""

    def build(d: Any) -> Any:
        if d == "*":
            return 0.0
        if d is None:
            return None
        if "namedtuple" in d:
            return _namedtuple_class(d["namedtuple"])(*(build(x) for x in d["of"]))
        ((kind, value),) = d.items()
        if kind == "tuple":
            return tuple(build(x) for x in value)
        if kind == "list":
            return [build(x) for x in value]
        if kind == "dict":
            return {k: build(v) for k, v in value}
        raise ValueError(f"unknown pytree node {kind!r}")

    return jax.tree_util.tree_structure(build(description))


def read_entry(file: Path) -> tuple[Any, Any] | None:
    """The stored (exported kernel, output pytree structure), or None (missing, damaged,
    another format, or naming a class this process has not loaded)."""
    try:
        data = file.read_bytes()
        if not data.startswith(MAGIC):
            return None
        size = int.from_bytes(data[len(MAGIC) : len(MAGIC) + 8], "big")
        start = len(MAGIC) + 8
        out_tree = tree_of_description(json.loads(data[start : start + size]))
        return jax.export.deserialize(bytearray(data[start + size :])), out_tree
    except Exception:
        return None


def write_entry(file: Path, entry: tuple[bytes, Any]) -> None:
    """Write atomically (another process may read the same entry meanwhile): the magic bytes,
    the JSON description of the output structure with its length, the serialized export."""
    blob, out_tree = entry
    try:
        text = json.dumps(describe_tree(out_tree)).encode()
    except TypeError:  # an output this format cannot describe: not stored
        return
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=file.parent, suffix=".tmp")
        with os.fdopen(fd, "wb") as f:
            f.write(MAGIC + len(text).to_bytes(8, "big") + text + blob)
        os.replace(tmp, file)
    except OSError:  # read-only cache: run without storing
        pass
