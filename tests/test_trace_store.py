"""The trace store (``biplan._compile.traced``): kernels exported once, reloaded without
tracing."""

from __future__ import annotations

import functools
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from biplan._compile import setup as _jax
from biplan._compile import trace_entries
from biplan._compile import traced as _traced
from biplan._compile.setup import jax, jnp, xla_options
from biplan._compile.traced import StoredJit, stored_jit
from biplan.model.lagrangian import residual
from biplan.model.params import Load


class Pair(NamedTuple):
    value: jax.Array
    slope: jax.Array


def _cubic(params: dict, x: jax.Array) -> Pair:
    """A pytree in, a NamedTuple out, a loop inside."""

    def body(i: jax.Array, y: jax.Array) -> jax.Array:
        return y - (y**3 - params["c"]) / (3 * y**2)

    y = jax.lax.fori_loop(0, 30, body, x)
    return Pair(y, 3 * y**2)


@pytest.fixture
def store(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setattr(_jax, "CACHE_DIR", tmp_path)
    monkeypatch.delenv("BIPLAN_TRACE_STORE", raising=False)
    return tmp_path / "kernels"


def _refuse_export(*_args: object) -> None:
    raise AssertionError("traced again: the stored kernel was not used")


def test_a_stored_kernel_equals_jit_and_is_read_back(store, monkeypatch) -> None:
    params, x = {"c": jnp.asarray(2.0)}, np.linspace(1.0, 3.0, 4)
    first = stored_jit(_cubic, "cubic", key="k1")
    out = first(params, x)
    reference = jax.jit(_cubic)(params, x)
    assert isinstance(out, Pair)
    np.testing.assert_array_equal(out.value, reference.value)
    np.testing.assert_array_equal(out.slope, reference.slope)
    np.testing.assert_allclose(out.value, 2.0 ** (1 / 3), rtol=1e-15)
    assert len(list(store.glob("cubic-*.kernel"))) == 1
    # a new kernel object (a new process) reads the entry instead of tracing
    monkeypatch.setattr(StoredJit, "_export", _refuse_export)
    again = stored_jit(_cubic, "cubic", key="k1")
    np.testing.assert_array_equal(again(params, x).value, reference.value)
    assert again._cache_size() == 1
    # another shape, another key: new entries
    monkeypatch.undo()  # (the store fixture's settings too: set them again)
    monkeypatch.setattr(_jax, "CACHE_DIR", store.parent)
    monkeypatch.delenv("BIPLAN_TRACE_STORE", raising=False)
    stored_jit(_cubic, "cubic", key="k1")(params, x[:2])
    stored_jit(_cubic, "cubic", key="k2")(params, x)
    assert len(list(store.glob("cubic-*.kernel"))) == 3


def test_an_edited_biplan_never_reads_a_stale_kernel(store, monkeypatch) -> None:
    params, x = {"c": jnp.asarray(2.0)}, np.ones(3)
    stored_jit(_cubic, "cubic")(params, x)
    monkeypatch.setattr(_traced, "_source_fingerprint", lambda: "edited")
    stored_jit(_cubic, "cubic")(params, x)
    assert len(list(store.glob("cubic-*.kernel"))) == 2


def test_the_fingerprint_covers_every_module_of_the_package(tmp_path, monkeypatch) -> None:
    """An edit anywhere in biplan (a solver, not only the kernel machinery) changes the
    fingerprint: the store must never serve a kernel compiled from older physics."""
    import biplan

    package = Path(biplan.__file__).resolve().parent
    copy = tmp_path / "biplan"
    shutil.copytree(package, copy, ignore=shutil.ignore_patterns("__pycache__"))
    fake = copy / "_compile" / "kernel.py"
    monkeypatch.setattr(_traced, "__file__", str(fake))
    _traced._source_fingerprint.cache_clear()
    try:
        before = _traced._source_fingerprint()
        solver = copy / "solvers" / "dynamics.py"
        solver.write_text(solver.read_text() + "\n# edited\n")
        _traced._source_fingerprint.cache_clear()
        assert _traced._source_fingerprint() != before
    finally:
        _traced._source_fingerprint.cache_clear()


def test_a_damaged_entry_is_exported_again(store) -> None:
    params, x = {"c": jnp.asarray(5.0)}, np.ones(2)
    stored_jit(_cubic, "cubic")(params, x)
    (entry,) = store.glob("cubic-*.kernel")
    entry.write_bytes(b"truncated")
    out = stored_jit(_cubic, "cubic")(params, x)
    np.testing.assert_allclose(out.value, 5.0 ** (1 / 3), rtol=1e-15)
    assert entry.stat().st_size > 100  # rewritten


def test_store_off_is_plain_jit(store, monkeypatch) -> None:
    monkeypatch.setenv("BIPLAN_TRACE_STORE", "off")
    params, x = {"c": jnp.asarray(2.0)}, np.ones(2)
    out = stored_jit(_cubic, "cubic")(params, x)
    np.testing.assert_allclose(out.value, 2.0 ** (1 / 3), rtol=1e-15)
    assert not store.exists()


def test_a_stored_kernel_inside_a_transformation_traces_through(store) -> None:
    """Under grad/vmap the kernel is traced as the plain jit (the exported form is not
    differentiable); the derivative matches the closed form d(c^(1/3))/dc."""
    kernel = stored_jit(_cubic, "cubic")
    grad = jax.grad(lambda c: kernel({"c": c}, jnp.ones(()))[0])(8.0)
    assert float(grad) == pytest.approx(1 / 12, rel=1e-12)


def test_a_model_kernel_equals_the_jit_of_its_function(model1) -> None:
    """A tube kernel through the store returns the numbers of jax.jit (same compiler options)
    bit for bit."""
    model = model1
    z = np.asarray(model.pack(model.zeros())) + 0.01
    load = Load.of_force(0.3).for_jax()
    stored = model.autodiff.residual(model.params, jnp.asarray(z), load)
    plain = jax.jit(functools.partial(residual, model.layout), compiler_options=xla_options())(
        model.params, jnp.asarray(z), load
    )
    np.testing.assert_array_equal(np.asarray(stored), np.asarray(plain))


SCRIPT = """
import numpy as np
from biplan._compile import traced as _traced
from biplan._compile.setup import jnp
def f(p, x):
    return {"y": jnp.sin(x) * p}
if {refuse}:
    def refuse(*_):
        raise SystemExit("traced again")
    _traced.StoredJit._export = refuse
print(float(_traced.stored_jit(f, "sine")(2.0, np.ones(3))["y"][0]))
"""


def test_a_later_process_reads_the_kernel_without_tracing(tmp_path: Path) -> None:
    env = {**os.environ, "BIPLAN_JAX_CACHE": str(tmp_path)}
    env.pop("BIPLAN_TRACE_STORE", None)
    outs = []
    for refuse in (False, True):
        run = subprocess.run(
            [sys.executable, "-c", SCRIPT.replace("{refuse}", str(refuse))],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert run.returncode == 0, run.stderr
        outs.append(float(run.stdout.split()[-1]))
    assert outs[0] == outs[1] == pytest.approx(2 * np.sin(1.0), rel=1e-15)


RACE = """
import sys, time
from biplan._compile import traced as _traced
from biplan._compile.setup import jnp
def f(x):
    print("traced", file=sys.stderr, flush=True)
    time.sleep(2.0)  # a slow trace: without the lock both processes would trace
    return jnp.cos(x)
print(float(_traced.stored_jit(f, "slow")(jnp.zeros(2))[0]))
"""


def test_processes_building_the_same_kernel_trace_it_once(tmp_path: Path) -> None:
    """Two processes that need the same kernel at the same time: one traces and compiles,
    the other waits on the entry's lock and reads what the first stored."""
    env = {**os.environ, "BIPLAN_JAX_CACHE": str(tmp_path)}
    env.pop("BIPLAN_TRACE_STORE", None)
    procs = [
        subprocess.Popen(
            [sys.executable, "-c", RACE],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for _ in range(2)
    ]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [err for _, err in outs]
    assert [float(out.split()[-1]) for out, _ in outs] == [1.0, 1.0]
    assert sum(err.count("traced") for _, err in outs) == 1


def test_a_held_entry_lock_is_waited_for_then_passed(tmp_path: Path, monkeypatch) -> None:
    """A build waits for another holder of its entry's lock, but at most LOCK_WAIT seconds
    (a hung holder cannot stop the others); a free lock is taken at once."""
    import time

    monkeypatch.setattr(trace_entries, "LOCK_WAIT", 0.3)
    entry = tmp_path / "kernel.kernel"
    t0 = time.perf_counter()
    with trace_entries.entry_lock(entry):
        free = time.perf_counter() - t0
        t0 = time.perf_counter()
        with trace_entries.entry_lock(entry):  # a second open file description: a second holder
            waited = time.perf_counter() - t0
    assert free < 2.0 and 0.3 <= waited < 10.0  # generous bounds: a loaded CI machine
    assert (tmp_path / "kernel.lock").exists()


def test_release_jax_executables_drops_the_stored_executables(store) -> None:
    """The memory-map guard (``release_jax_executables``) reaches the executables that
    stored kernels hold; the next call rebuilds them from the store."""
    from biplan._compile.setup import release_jax_executables

    params, x = {"c": jnp.asarray(3.0)}, np.ones(2)
    kernel = stored_jit(_cubic, "cubic")
    kernel(params, x)
    assert kernel._cache_size() == 1
    assert release_jax_executables(0.0)
    assert kernel._cache_size() == 0
    np.testing.assert_allclose(kernel(params, x).value, 3.0 ** (1 / 3), rtol=1e-15)
    assert kernel._cache_size() == 1


def test_an_entry_holds_no_pickle_and_names_only_loaded_namedtuples(store) -> None:
    """An entry is magic bytes, a JSON description of the output structure and the serialized
    export: no pickle. A description naming a class no loaded module defines is not read."""
    params, x = {"c": jnp.asarray(3.0)}, np.ones(2)
    stored_jit(_cubic, "cubic")(params, x)
    (entry,) = store.glob("cubic-*.kernel")
    data = entry.read_bytes()
    assert data.startswith(trace_entries.MAGIC)
    assert b"\x80\x04" not in data[:16]  # not a pickle stream
    size = int.from_bytes(data[8:16], "big")
    described = json.loads(data[16 : 16 + size])
    assert described == {"namedtuple": f"{__name__}:Pair", "of": ["*", "*"]}
    tree = jax.tree_util.tree_structure(Pair(0.0, 0.0))
    assert trace_entries.tree_of_description(described) == tree
    nested = {"a": (1.0, [2.0, None]), "b": Pair(3.0, 4.0)}
    treedef = jax.tree_util.tree_structure(nested)
    assert trace_entries.tree_of_description(trace_entries.describe_tree(treedef)) == treedef
    # a class that no imported module defines (e.g. a planted entry) is never resolved
    text = json.dumps({"namedtuple": "os:system", "of": ["*"]}).encode()
    entry.write_bytes(data[:8] + len(text).to_bytes(8, "big") + text + data[16 + size :])
    assert trace_entries.read_entry(entry) is None
    # and the kernel is then exported again, giving the same numbers
    again = stored_jit(_cubic, "cubic")(params, x)
    np.testing.assert_allclose(again.value, 3.0 ** (1 / 3), rtol=1e-15)
