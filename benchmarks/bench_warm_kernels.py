"""Warm hot loops of the compiled core: one Newton solve (N = 6, 48) and a short arclength path.

Run:  .venv/bin/python benchmarks/bench_warm_kernels.py [--reference 6 48 200 400] [--pieces 48 400]

Semi-bistable laws and SI Table geometry on a base fold, N modules. Per N: the Newton solve at
F = 0.5 N from the relaxed reference (``iteration.solve_system`` on the model's ``System``,
best of 200 at N = 6, 20 at N = 48); at N = 6 the displacement-controlled arclength path to
1.2 mm (best of 5). The kernels load from the cache (or compile once first, not timed). To compare
LLVM levels, fill two caches at two levels (``benchmarks/bench_compile.py`` or ``NUMBA_OPT=k
BIPLAN_NUMBA_CACHE=DIR biplan respond ...``) and run this with ``BIPLAN_NUMBA_CACHE=DIR``: the
kernels are loaded as compiled, whatever ``NUMBA_OPT`` this process has.

``--reference N …`` instead times the first relaxed reference of a tube never seen, per N, in a
new process each (kernels cached): the process's wall time, and inside it the model, its
``System`` (with the banded layout) and the Newton. ``--pieces N …`` times, warm and best of 5,
the pieces of one of that Newton's steps at q = 0: zeroing the Jacobian in place, assembling it
(``assemble.evaluate_into``), the bordered banded solve (``bordered.banded_solve``), the dense
product J x that checks it, and the whole relaxed-reference Newton (``iteration.solve_system``).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections.abc import Callable

import numpy as np

import biplan
from biplan._compile.setup import limit_blas_threads
from biplan.solvers import iteration


def best(f: Callable[[], object], n: int) -> float:
    """Smallest wall time of ``n`` calls [s]."""
    times = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def semi_bistable_model(n: int) -> biplan.Model:
    """The semi-bistable laws and SI Table geometry with N modules on a base fold."""
    laws = biplan.designs.semi_bistable()
    tube = biplan.Tube.uniform(
        radius=2.0,
        pitch=3.6,
        helical_angle=60.0,
        n_modules=n,
        helical=laws.helical_laws[0],
        circular=laws.circular_laws[0],
        base_fold=True,
    )
    return biplan.Model(tube)


def measure(n: int) -> None:
    """Print the warm timings of an N-module tube."""
    settings = iteration.newton_settings(1e-9, 60, 30, 1e-4, 0)
    model = semi_bistable_model(n)
    ref = biplan.relaxed_reference(model)
    system = model.system(biplan.Load.of_force(0.5))
    iteration.solve_system(system, ref.z, settings)
    t = best(lambda: iteration.solve_system(system, ref.z, settings), 200 if n == 6 else 20)
    print(f"N = {n}: Newton solve from the reference at F = 0.5 N: {t * 1e3:.3f} ms")
    if n == 6:
        control = biplan.Control.displacement(1.2)
        path = biplan.trace_path(model, biplan.ArcLength(), ref, control)
        t = best(lambda: biplan.trace_path(model, biplan.ArcLength(), ref, control), 5)
        print(f"N = 6: path to 1.2 mm: {t * 1e3:.1f} ms, {len(path.load_parameter)} states")


#: The child of ``--reference``: one tube never seen, timed by piece.
REFERENCE = """
import sys, time
import biplan
from biplan._compile.setup import limit_blas_threads
limit_blas_threads()
laws = biplan.designs.semi_bistable()
t0 = time.perf_counter()
tube = biplan.Tube.uniform(radius=2.0, pitch=3.6, helical_angle=60.0, n_modules=int(sys.argv[1]),
    helical=laws.helical_laws[0], circular=laws.circular_laws[0], base_fold=True)
model = biplan.Model(tube)
t1 = time.perf_counter()
model.system()
t2 = time.perf_counter()
ref = biplan.relaxed_reference(model)
t3 = time.perf_counter()
print(f"model {t1 - t0:.2f} s, System {t2 - t1:.2f} s, Newton {t3 - t2:.2f} s, {ref.status.name}")
"""


def reference(n: int) -> None:
    """Print the first relaxed reference of an N-module tube in a new process."""
    start = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", REFERENCE, str(n)], capture_output=True, text=True, check=True
    )
    wall = time.perf_counter() - start
    print(f"N = {n}: new process {wall:.2f} s wall ({out.stdout.strip()})")


def pieces(n: int) -> None:
    """Print the pieces of a relaxed-reference Newton step of an N-module tube [ms]."""
    from biplan.model.system import assemble
    from biplan.solvers import bordered
    from biplan.solvers.newton import _start_vector

    model = semi_bistable_model(n)
    system = model.system()
    d = system.data
    z = _start_vector(model, model.zeros())
    jac = np.zeros((z.size, z.size))
    rhs = -assemble.evaluate_into(d, z, system.load, True, jac)[0]
    band = d.solve_band
    if band.size == 0:
        print(f"N = {n}: no banded layout (dense LU below {z.size} unknowns)")
        return
    x = bordered.banded_solve(jac, rhs, d.solve_order, *band)[0]
    settings = biplan.Newton().loop_settings()
    times = {
        "zero": best(lambda: jac.fill(0.0), 5),
        "assemble": best(lambda: assemble.evaluate_into(d, z, system.load, True, jac), 5),
        "banded solve": best(lambda: bordered.banded_solve(jac, rhs, d.solve_order, *band), 5),
        "check product": best(lambda: jac @ x, 5),
        "Newton": best(lambda: iteration.solve_system(system, z, settings), 3),
    }
    steps = iteration.solve_system(system, z, settings)[4]
    text = ", ".join(f"{k} {1e3 * v:.1f} ms" for k, v in times.items())
    print(f"N = {n} ({z.size} unknowns): {text} ({steps} steps)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", type=int, nargs="+", default=None)
    parser.add_argument("--pieces", type=int, nargs="+", default=None)
    args = parser.parse_args()
    if args.reference:
        for n in args.reference:
            reference(n)
        return
    if args.pieces:
        limit_blas_threads()
        for n in args.pieces:
            pieces(n)
        return
    limit_blas_threads()
    for n in (6, 48):
        measure(n)


if __name__ == "__main__":
    main()
