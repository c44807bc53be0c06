"""The compiled system (Numba, layout as data) against the JAX core: kernel time vs N, cold start.

Run:  .venv/bin/python benchmarks/bench_system.py [--sizes 6 12 24 48 96 192 400]
      [--jax-sizes 6 12 24 48] [--cold-n 37] [--quick]

Semi-bistable tubes of N modules (the SI Table laws and geometry on a base fold), at a
random-ish configuration z (fixed seed; q amplitude 0.05, multipliers 0.1) under a dead force
F = 1.3 N. Prints:

* kernel time vs N — warm per-call time [ms] of the KKT residual r(z) and Jacobian ∂r/∂z:
  Numba through the Python methods ``System.residual/jacobian`` ("py"), Numba inside an
  ``@numba.njit`` loop calling ``assemble.evaluate`` (what a compiled Newton pays: no
  dispatch, "loop"), and JAX ``Model.residual/jacobian`` (jitted, NumPy out) at
  ``--jax-sizes``; the ratio JAX / Numba-py. Beside them, the one-time cost of a new N in
  this process: JAX's compile of residual + Jacobian (first call minus warm call, with
  JAX's persistent cache and biplan's trace store off in this process, so it is a real
  compile) and Numba's first residual + Jacobian call for that N (≈ 0: a new N is only new
  array sizes). Numba's own one-time load of its cached kernels into this process is timed
  on N = 3 before the table and printed apart;
* cold start in a new process — import ``biplan.model.system``, ``System.of`` a tube with an
  N never seen (``--cold-n``) and one residual + Jacobian: (a) with Numba's cache warm (the
  normal case: the cache next to the package, populated by an untimed run first; best of
  three), (b) the one-time compile, with ``NUMBA_CACHE_DIR`` pointed at a fresh temporary
  directory (Numba then neither reads nor writes the in-tree cache); and ``import jax``
  alone, which ``biplan.model.system`` pulls in through ``biplan.geometry``;
* a summary line against the targets: warm Jacobian at N = 48 ≤ 10× N = 6 (Numba, py and
  loop) and cold start with a warm cache ≤ 2 s; the load average at start and end (on a
  2-core machine another busy process doubles the JAX compiles and skews the rest), and a
  warning if the system's sources changed during the run (Numba then recompiled).

``--quick``: N = 6, 12 and JAX at N = 6 only (a fast check that everything runs).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

# JAX compile times below are real compiles: no persistent cache, no trace store. Set before
# biplan (and so JAX) is imported.
os.environ["BIPLAN_JAX_CACHE"] = "off"
os.environ["BIPLAN_TRACE_STORE"] = "off"
os.environ.pop("BIPLAN_FAST_COMPILE", None)

import numba
import numpy as np

import biplan
from biplan.model.params import Load
from biplan.model.system import System, assemble

FORCE = 1.3


def tube_of(n: int) -> biplan.Tube:
    t = biplan.designs.semi_bistable()
    return biplan.Tube.uniform(
        radius=2.0,
        pitch=3.6,
        helical_angle=60.0,
        n_modules=n,
        helical=t.helical_laws[0],
        circular=t.circular_laws[0],
        base_fold=True,
    )


def configuration(n_q: int, n_z: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.concatenate([0.05 * rng.standard_normal(n_q), 0.1 * rng.standard_normal(n_z - n_q)])


@numba.njit
def _loop(d, z, load, second, reps):  # type: ignore[no-untyped-def]
    """``reps`` evaluations inside compiled code (the result is used so none is dropped)."""
    acc = 0.0
    for _ in range(reps):
        out = assemble.evaluate(d, z, load, second)
        acc += out[0][0]
        if second:
            acc += out[1][0, 0]
    return acc


def per_call(f, budget: float = 0.15, repeats: int = 5) -> float:  # type: ignore[no-untyped-def]
    """Best-of-``repeats`` mean time [s] of f() over batches of about ``budget`` seconds."""
    t0 = time.perf_counter()
    f()
    once = max(time.perf_counter() - t0, 1e-7)
    k = max(1, int(budget / once))
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(k):
            f()
        best = min(best, (time.perf_counter() - t0) / k)
    return best


def loop_per_call(s: System, z: np.ndarray, second: bool, budget: float = 0.15) -> float:
    """Per-evaluation time [s] of ``assemble.evaluate`` inside the njit loop."""
    t0 = time.perf_counter()
    _loop(s.data, z, s.load, second, 1)
    once = max(time.perf_counter() - t0, 1e-7)
    reps = max(1, int(budget / once))
    return per_call(lambda: _loop(s.data, z, s.load, second, reps), budget=0.0, repeats=5) / reps


def numba_row(n: int) -> dict:
    tube = tube_of(n)
    s = System.of(tube, force=FORCE)
    z = configuration(s.sizes[0], s.n_unknowns)
    t0 = time.perf_counter()
    s.residual(z)
    t1 = time.perf_counter()
    s.jacobian(z)
    t2 = time.perf_counter()
    _loop(s.data, z, s.load, False, 1)
    _loop(s.data, z, s.load, True, 1)
    return dict(
        n=n,
        n_z=s.n_unknowns,
        nb_first=(t1 - t0) + (t2 - t1),
        nb_r=per_call(lambda: s.residual(z)),
        nb_J=per_call(lambda: s.jacobian(z)),
        loop_r=loop_per_call(s, z, False),
        loop_J=loop_per_call(s, z, True),
        z=z,
        tube=tube,
    )


def jax_row(row: dict) -> None:
    load = Load.of_force(FORCE)
    z = row["z"]
    t0 = time.perf_counter()
    model = biplan.Model(row["tube"])
    t1 = time.perf_counter()
    model.residual(z, load)
    t2 = time.perf_counter()
    model.jacobian(z, load)
    t3 = time.perf_counter()
    jr = per_call(lambda: model.residual(z, load))
    jj = per_call(lambda: model.jacobian(z, load))
    s = System.of(row["tube"], force=FORCE)
    err = max(
        float(np.max(np.abs(model.residual(z, load) - s.residual(z)))),
        float(np.max(np.abs(model.jacobian(z, load) - s.jacobian(z)))),
    )
    row.update(
        jax_model=t1 - t0,
        jax_compile=(t2 - t1 - jr) + (t3 - t2 - jj),
        jax_r=jr,
        jax_J=jj,
        err=err,
    )


COLD = r"""
import json, sys, time
t0 = time.perf_counter()
import numpy as np
from biplan.model.system import System
t1 = time.perf_counter()
import biplan
tp = biplan.designs.semi_bistable()
tube = biplan.Tube.uniform(radius=2.0, pitch=3.6, helical_angle=60.0, n_modules={n},
    helical=tp.helical_laws[0], circular=tp.circular_laws[0], base_fold=True)
s = System.of(tube, force={force})
t2 = time.perf_counter()
rng = np.random.default_rng(0)
nq, nz = s.sizes[0], s.n_unknowns
z = np.concatenate([0.05 * rng.standard_normal(nq), 0.1 * rng.standard_normal(nz - nq)])
s.residual(z)
t3 = time.perf_counter()
s.jacobian(z)
t4 = time.perf_counter()
print(json.dumps(dict(imp=t1 - t0, of=t2 - t1, r=t3 - t2, J=t4 - t3, total=t4 - t0,
    jax="jax" in sys.modules)))
"""

JAX_IMPORT = r"""
import time; t0 = time.perf_counter(); import jax; print(time.perf_counter() - t0)
"""


def cold(n: int, cache_dir: str | None) -> dict:
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = cache_dir
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", COLD.format(n=n, force=FORCE)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["wall"] = time.perf_counter() - t0
    return res


def jax_import() -> float:
    out = subprocess.run(
        [sys.executable, "-c", JAX_IMPORT], capture_output=True, text=True, check=True
    )
    return float(out.stdout.strip().splitlines()[-1])


def source_stamp() -> float:
    """Latest modification time of the compiled system's sources (Numba's cache key)."""
    from pathlib import Path

    import biplan.model.system as package

    return max(p.stat().st_mtime for p in Path(package.__file__).parent.glob("*.py"))


def ms(x: float | None) -> str:
    return "      -" if x is None else f"{1e3 * x:7.3f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[6, 12, 24, 48, 96, 192, 400])
    ap.add_argument("--jax-sizes", type=int, nargs="*", default=[6, 12, 24, 48])
    ap.add_argument("--cold-n", type=int, default=37, help="N of the cold-start tube")
    ap.add_argument("--quick", action="store_true", help="N = 6, 12; JAX at N = 6")
    args = ap.parse_args()
    if args.quick:
        args.sizes, args.jax_sizes = [6, 12], [6]
    sizes = sorted(set(args.sizes) | set(args.jax_sizes))
    stamp = source_stamp()

    # one-time costs of this process, apart from the per-N ones
    s3 = System.of(tube_of(3), force=FORCE)
    z3 = configuration(s3.sizes[0], s3.n_unknowns)
    t0 = time.perf_counter()
    s3.residual(z3)
    s3.jacobian(z3)
    t1 = time.perf_counter()
    _loop(s3.data, z3, s3.load, False, 1)
    _loop(s3.data, z3, s3.load, True, 1)
    t2 = time.perf_counter()
    import jax

    jax.block_until_ready(jax.jit(lambda x: x + 1.0)(np.ones(3)))
    t3 = time.perf_counter()
    print(
        f"one-time in this process: Numba cached kernels loaded {t1 - t0:.2f} s (N = 3), "
        f"benchmark njit loop compiled {t2 - t1:.2f} s, JAX backend up {t3 - t2:.2f} s"
    )
    print(
        f"threads: numba {numba.get_num_threads()}, CPUs {os.cpu_count()}; load average "
        f"{os.getloadavg()[0]:.1f} at start (other processes skew every number here)\n"
    )

    rows = []
    for n in sizes:
        row = numba_row(n)
        if n in args.jax_sizes:
            jax_row(row)
        rows.append(row)
        print(
            f"  N = {n:3d} done (n_z = {row['n_z']}"
            + (f", JAX compile {row['jax_compile']:.1f} s)" if "jax_r" in row else ")"),
            flush=True,
        )

    print()
    print("Kernel time vs N: warm per call [ms]; new N in this process [s]; F = 1.3 N")
    head = (
        f"{'N':>4} {'n_z':>5} | {'r nb-py':>7} {'r loop':>7} {'r JAX':>7} {'JAX/nb':>6} | "
        f"{'J nb-py':>7} {'J loop':>7} {'J JAX':>7} {'JAX/nb':>6} | "
        f"{'JAX compile':>11} {'nb first':>9} | {'max|Δ|':>7}"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        has = "jax_r" in r
        print(
            f"{r['n']:4d} {r['n_z']:5d} | {ms(r['nb_r'])} {ms(r['loop_r'])} "
            f"{ms(r.get('jax_r'))} "
            + (f"{r['jax_r'] / r['nb_r']:6.1f}" if has else f"{'-':>6}")
            + f" | {ms(r['nb_J'])} {ms(r['loop_J'])} {ms(r.get('jax_J'))} "
            + (f"{r['jax_J'] / r['nb_J']:6.1f}" if has else f"{'-':>6}")
            + " | "
            + (f"{r['jax_compile']:10.1f}s" if has else f"{'-':>11}")
            + f" {r['nb_first']:8.4f}s | "
            + (f"{r['err']:7.1e}" if has else f"{'-':>7}")
        )
    print(
        "  nb-py: System.residual/jacobian; loop: assemble.evaluate in an njit loop; "
        "JAX: Model.residual/jacobian;\n  JAX compile: residual + Jacobian, first call "
        "minus warm; nb first: Numba's first r + J call at that N; max|Δ|: JAX vs Numba"
    )

    print("\nCold start in a new process (import biplan.model.system, System.of, r + J once)")
    n = args.cold_n
    cold(n, None)  # populate the in-tree cache should it be stale
    warm = min((cold(n, None) for _ in range(3)), key=lambda c: c["total"])
    with tempfile.TemporaryDirectory() as cache:
        fresh = cold(n, cache)
        written = sum(len(f) for _, _, f in os.walk(cache))
    t_jax = jax_import()
    for name, c in (("(a) Numba cache warm", warm), ("(b) fresh NUMBA_CACHE_DIR", fresh)):
        print(
            f"  {name:26s} N = {n}: import {c['imp']:.2f} s, System.of {c['of']:.3f} s, "
            f"first r {c['r']:.2f} s, first J {c['J']:.2f} s — total {c['total']:.2f} s "
            f"(process wall {c['wall']:.2f} s)"
        )
    print(
        f"  (b) wrote {written} files in the fresh cache directory; "
        f"biplan.model.system imports JAX: {'yes' if warm['jax'] else 'no'} "
        f"(import jax alone in a fresh process: {t_jax:.2f} s)"
    )

    by_n = {r["n"]: r for r in rows}
    print()
    parts = []
    if 6 in by_n and 48 in by_n:
        py = by_n[48]["nb_J"] / by_n[6]["nb_J"]
        lp = by_n[48]["loop_J"] / by_n[6]["loop_J"]
        ok = "PASS" if py <= 10 and lp <= 10 else "FAIL"
        parts.append(f"warm J N=48 / N=6 = {py:.1f}x py, {lp:.1f}x loop (≤ 10x: {ok})")
    ok = "PASS" if warm["total"] <= 2.0 else "FAIL"
    parts.append(f"cold start, cache warm = {warm['total']:.2f} s (≤ 2 s: {ok})")
    parts.append(f"one-time compile = {fresh['total']:.1f} s")
    print("Summary: " + "; ".join(parts))
    print(f"(load average {os.getloadavg()[0]:.1f} at the end)")
    if source_stamp() != stamp:
        print(
            "WARNING: biplan/model/system/*.py changed during the run: Numba recompiled, "
            "the first-call and cold-start numbers are not the cache-warm ones"
        )


if __name__ == "__main__":
    main()
