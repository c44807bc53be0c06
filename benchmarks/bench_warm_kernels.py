"""Warm hot loops of the compiled core: one Newton solve (N = 6, 48) and a short arclength path.

Run:  .venv/bin/python benchmarks/bench_warm_kernels.py

Semi-bistable laws and SI Table geometry on a base fold, N modules. Per N: the Newton solve at
F = 0.5 N from the relaxed reference (``iteration.solve_system`` on the model's ``System``,
best of 200 at N = 6, 20 at N = 48); at N = 6 the displacement-controlled arclength path to
1.2 mm (best of 5). Kernels load from the cache (or compile once first, not timed). To compare
LLVM levels, fill two caches at two levels (``benchmarks/bench_compile.py`` or ``NUMBA_OPT=k
BIPLAN_NUMBA_CACHE=DIR biplan respond ...``) and run this with ``BIPLAN_NUMBA_CACHE=DIR``: the
kernels are loaded as compiled, whatever ``NUMBA_OPT`` this process has.
"""

from __future__ import annotations

import time
from collections.abc import Callable

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


def measure(n: int) -> None:
    """Print the warm timings of an N-module tube."""
    laws = biplan.designs.semi_bistable()
    settings = iteration.settings_array(1e-9, 60, 30, 1e-4, 0)
    tube = biplan.Tube.uniform(
        radius=2.0,
        pitch=3.6,
        helical_angle=60.0,
        n_modules=n,
        helical=laws.helical_laws[0],
        circular=laws.circular_laws[0],
        base_fold=True,
    )
    model = biplan.Model(tube)
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


def main() -> None:
    limit_blas_threads()
    for n in (6, 48):
        measure(n)


if __name__ == "__main__":
    main()
