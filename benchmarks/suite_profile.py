"""Where the test suite's time goes: JAX tracing and XLA compilation, and Numba compiles, per
test file and function.

Runs pytest (two xdist workers, as ``make test``) on empty JAX caches with a plugin that listens
to ``jax.monitoring`` and to Numba's ``numba:compile`` events in every worker, then prints, per
test file, the wall time and the seconds spent tracing and compiling, and per function the
compile and trace seconds and how many times each happened. The Numba kernels come from this
install's cache (``biplan compile`` fills it): a Numba compile during the suite is a kernel, or
a specialisation of one, that the compile workloads do not cover (each biplan function's own
time, exclusive of the functions compiled on the way).

Run from the repository root (a fresh cache is made in a temporary folder)::

    .venv/bin/python benchmarks/suite_profile.py                 # the whole suite
    .venv/bin/python benchmarks/suite_profile.py tests/test_batched_linalg.py --top 10

Extra arguments go to pytest. ``--keep-cache`` uses the suite's own cache folder
(``.jax-cache-tests``) instead of an empty one (a warm run).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

COMPILE = "/jax/core/compile/backend_compile_duration"
NUMBA = "numba:compile"
TRACE = "/jax/core/compile/jaxpr_trace_duration"
LOWER = "/jax/core/compile/jaxpr_to_mlir_module_duration"


# --- the plugin (loaded in every worker by ``-p suite_profile``) --------------------------------
class _Recorder:
    def __init__(self) -> None:
        self.events: collections.Counter[str] = collections.Counter()
        self.kernels: collections.Counter[tuple[str, str]] = collections.Counter()
        self.counts: collections.Counter[tuple[str, str]] = collections.Counter()
        self.numba: collections.Counter[str] = collections.Counter()
        self.installed = False

    def install(self) -> None:
        if self.installed:
            return
        import jax.monitoring

        def listen(event: str, duration: float, **kwargs: object) -> None:
            self.events[event] += duration
            if event in (COMPILE, TRACE):
                key = ("compile" if event == COMPILE else "trace", str(kwargs.get("fun_name")))
                self.kernels[key] += duration
                self.counts[key] += 1

        jax.monitoring.register_event_duration_secs_listener(listen)
        self._install_numba()
        self.installed = True

    def _install_numba(self) -> None:
        from numba.core import event

        recorder = self

        class Compiles(event.Listener):
            def __init__(self) -> None:
                self.stack: list[tuple[str, float]] = []

            def on_start(self, ev: event.Event) -> None:
                f = ev.data["dispatcher"].py_func
                self.stack.append((f"{f.__module__}.{f.__qualname__}", time.perf_counter()))

            def on_end(self, ev: event.Event) -> None:
                name, t0 = self.stack.pop()
                seconds = time.perf_counter() - t0
                if self.stack:  # the caller's own time excludes this one
                    recorder.numba[self.stack[-1][0]] -= seconds
                recorder.numba[name] += seconds

        event.register(NUMBA, Compiles())

    def clear(self) -> None:
        self.events.clear()
        self.kernels.clear()
        self.counts.clear()
        self.numba.clear()


_RECORDER = _Recorder()


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None):
    _RECORDER.install()
    _RECORDER.clear()
    start = time.perf_counter()
    yield
    record = {
        "test": item.nodeid,
        "wall": time.perf_counter() - start,
        "events": dict(_RECORDER.events),
        "kernels": [[k[0], k[1], v, _RECORDER.counts[k]] for k, v in _RECORDER.kernels.items()],
        "numba": {k: v for k, v in _RECORDER.numba.items() if k.startswith("biplan.")},
    }
    out = Path(os.environ["SUITE_PROFILE_DIR"])
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with open(out / f"{worker}.jsonl", "a") as f:
        f.write(json.dumps(record) + "\n")


# --- the driver ----------------------------------------------------------------------------------
def report(folder: Path, top: int) -> None:
    """Print the per-file and per-kernel tables of the records in ``folder``."""
    rows = [json.loads(line) for f in folder.glob("*.jsonl") for line in f.open()]
    files: dict[str, list[float]] = collections.defaultdict(lambda: [0.0, 0.0, 0.0, 0.0, 0, 0.0])
    numba: collections.Counter[str] = collections.Counter()
    kernels: collections.Counter[tuple[str, str]] = collections.Counter()
    counts: collections.Counter[tuple[str, str]] = collections.Counter()
    for r in rows:
        f = files[r["test"].split("::")[0]]
        ev = r["events"]
        f[0] += r["wall"]
        f[1] += ev.get(COMPILE, 0.0)
        f[2] += ev.get(TRACE, 0.0)
        f[3] += ev.get(LOWER, 0.0)
        f[4] += 1
        f[5] += sum(r.get("numba", {}).values())
        numba.update(r.get("numba", {}))
        for kind, name, seconds, n in r["kernels"]:
            kernels[(kind, name)] += seconds
            counts[(kind, name)] += n
    total = [sum(f[i] for f in files.values()) for i in range(6)]
    print(f"{len(rows)} tests, {total[0]:.0f} worker-seconds: XLA compile {total[1]:.0f}, "
          f"tracing {total[2]:.0f}, lowering {total[3]:.0f}, Numba compile {total[5]:.0f}")  # fmt: skip
    print(
        "\n| file | tests | wall [s] | XLA compile [s] | tracing [s] | lowering [s] | Numba [s] |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, f in sorted(files.items(), key=lambda kv: -kv[1][0])[:top]:
        print(
            f"| {name} | {f[4]} | {f[0]:.1f} | {f[1]:.1f} | {f[2]:.1f} | {f[3]:.1f} | {f[5]:.1f} |"
        )
    print("\n| Numba function (own compile time) | seconds |")
    print("|---|---|")
    for name, seconds in numba.most_common(top):
        print(f"| {name} | {seconds:.1f} |")
    print("\n| kernel | compile or trace | seconds | times |")
    print("|---|---|---|---|")
    for (kind, name), seconds in kernels.most_common(top):
        print(f"| {name} | {kind} | {seconds:.1f} | {counts[(kind, name)]} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=25, help="rows of each table")
    parser.add_argument("--keep-cache", action="store_true", help="use .jax-cache-tests")
    args, pytest_args = parser.parse_known_args()
    root = Path(__file__).resolve().parent.parent
    with tempfile.TemporaryDirectory() as tmp:
        env = dict(os.environ, SUITE_PROFILE_DIR=tmp)
        env["PYTHONPATH"] = os.pathsep.join(
            [str(Path(__file__).resolve().parent), env.get("PYTHONPATH", "")]
        )
        if not args.keep_cache:
            env["BIPLAN_JAX_CACHE"] = str(Path(tmp) / "cache")
        command = [sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist", "loadfile"]
        command += ["-p", "suite_profile", "-p", "no:cacheprovider", *pytest_args]
        start = time.perf_counter()
        code = subprocess.call(command, cwd=root, env=env)
        print(f"\npytest: exit {code}, {time.perf_counter() - start:.1f} s wall\n")
        report(Path(tmp), args.top)
    sys.exit(code)


if __name__ == "__main__":
    main()
