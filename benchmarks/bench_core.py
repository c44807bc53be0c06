"""Core timings: cold start, cache-warm start and warm equilibrium solves.

Run:  .venv/bin/python benchmarks/bench_core.py

Prints, for the semi-bistable paper design (6 modules, 64 unknowns):

* cold start — a fresh process with JAX's persistent cache disabled: import, build the model,
  relaxed reference, one displacement-controlled solve + stability classification;
* cache-warm start — the same in a fresh process reading the persistent cache, with the
  trace store (traced kernels, ``biplan._compile.traced``) off and on: the store's share is the
  tracing and lowering that a warm start no longer does;
* two processes at once on a fresh cache (e.g. two Dask workers starting on the same design),
  with the store's build lock (one process traces and compiles each kernel, the other waits
  and reads it) and without it (``_traced.entry_lock`` patched out): wall and CPU seconds;
* warm solves — 40 displacement-controlled steps (0.02 → 0.8 mm) in this process, per step;
* baseline — the same 40 steps with ``scipy.optimize.root`` (hybr, finite-difference
  Jacobian) on the *same jitted residual*, i.e. a favourable baseline (a plain NumPy residual
  would be slower still); the ratio isolates the autodiff Jacobian + fused Newton loop.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

SNIPPET = """
import time; t0 = time.perf_counter()
import biplan
t1 = time.perf_counter()
m = biplan.Model(biplan.designs.semi_bistable())
r = biplan.relaxed_reference(m)
s = biplan.solve_equilibrium(m, biplan.Newton(), r, biplan.Load.of_displacement(1.0))
biplan.classify(m, s)
t2 = time.perf_counter()
print(f"{t1 - t0:.2f} {t2 - t1:.2f}")
"""


def _start(cache: str, store: str = "on") -> tuple[float, float]:
    env = dict(os.environ, BIPLAN_JAX_CACHE=cache, BIPLAN_TRACE_STORE=store)
    out = subprocess.run(
        [sys.executable, "-c", SNIPPET], env=env, capture_output=True, text=True, check=True
    )
    a, b = out.stdout.split()
    return float(a), float(b)


UNLOCKED = """
import contextlib
from biplan._compile import traced as _traced
_traced.entry_lock = lambda file: contextlib.nullcontext()
"""


def _pair(locked: bool) -> tuple[float, float]:
    """Wall and CPU seconds of two concurrent cold starts sharing a fresh cache."""
    import resource

    code = SNIPPET if locked else UNLOCKED + SNIPPET
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, BIPLAN_JAX_CACHE=cache, BIPLAN_TRACE_STORE="on")
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        procs = [
            subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.DEVNULL)
            for _ in range(2)
        ]
        if any(p.wait() for p in procs):
            raise RuntimeError("a benchmark process failed")
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    imp, cold = _start("off")
    print(
        f"cold start (no cache):     import {imp:.2f} s, model+reference+solve+classify {cold:.2f} s"
    )
    for store in ("off", "on"):
        with tempfile.TemporaryDirectory() as cache:
            _start(cache, store)  # populate
            imp_w, warm_start = _start(cache, store)
        print(
            f"cache-warm start, store {store:3s}: import {imp_w:.2f} s, "
            f"model+reference+solve+classify {warm_start:.2f} s"
        )

    for locked in (True, False):
        wall, cpu = _pair(locked)
        print(
            f"two cold starts at once, build lock {'on ' if locked else 'off'}: "
            f"wall {wall:.1f} s, CPU {cpu:.1f} s"
        )

    import scipy.optimize

    import biplan

    model = biplan.Model(biplan.designs.semi_bistable())
    ref = biplan.relaxed_reference(model)
    targets = np.linspace(0.02, 0.8, 40)
    sol = biplan.solve_equilibrium(model, biplan.Newton(), ref, biplan.Load.of_displacement(0.01))
    t0 = time.perf_counter()
    s = ref
    for u in targets:
        s = biplan.solve_equilibrium(model, biplan.Newton(), s, biplan.Load.of_displacement(u))
        assert s.converged
    t_biplan = (time.perf_counter() - t0) / len(targets)

    z = ref.z.copy()
    t0 = time.perf_counter()
    n_ok = 0
    for u in targets:
        load = biplan.Load.of_displacement(u)
        res = scipy.optimize.root(
            lambda zz, ld=load: model.residual(zz, ld), z, method="hybr", tol=1e-12
        )
        n_ok += int(np.max(np.abs(model.residual(res.x, load))) < 1e-8)
        z = res.x
    t_base = (time.perf_counter() - t0) / len(targets)
    print(f"warm solve per step:       biplan {t_biplan * 1e3:.2f} ms")
    print(
        f"baseline per step:         scipy.optimize.root + FD Jacobian {t_base * 1e3:.2f} ms "
        f"({n_ok}/{len(targets)} steps reached ‖r‖∞ < 1e-8)"
    )
    print(f"ratio baseline / biplan:   {t_base / t_biplan:.1f}x")
    del sol


if __name__ == "__main__":
    main()
