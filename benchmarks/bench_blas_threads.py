"""BLAS threads under contention: one thread per process against OpenBLAS's default.

Run:  .venv/bin/python benchmarks/bench_blas_threads.py [--n 505] [--threads 2]

Two processes share the machine, as two test workers, two Dask workers or a CLI run beside a
notebook do: this one, and a companion started here that factorises matrices of the same size
in a loop with the same thread setting. For each setting (``--threads`` threads, then one) this
process times a dense solve of an n × n system (NumPy/LAPACK and ``jnp.linalg.solve``, which
calls the same OpenBLAS) and prints the ratio. n = 505 is the KKT system of the 48-module
semi-bistable tube. biplan runs BLAS on one thread per process by default
(``biplan._compile.setup``, ``BIPLAN_BLAS_THREADS``); docs/performance.md, "BLAS threads".
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

COMPANION = r"""
import sys, numpy as np
from threadpoolctl import threadpool_limits
n, threads = int(sys.argv[1]), int(sys.argv[2])
a = np.random.default_rng(1).normal(size=(n, n)) + n * np.eye(n)
with threadpool_limits(limits=threads, user_api="blas"):
    while True:
        np.linalg.solve(a, np.ones(n))
"""


def _time(fn, repeat: int = 20) -> float:
    fn()
    start = time.perf_counter()
    for _ in range(repeat):
        fn()
    return (time.perf_counter() - start) / repeat * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=505)
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()

    import numpy as np
    from threadpoolctl import threadpool_limits

    import biplan.model.assembly  # noqa: F401  (biplan's set-up: float64, one BLAS thread)
    from biplan._compile.setup import jax, jnp

    a = np.random.default_rng(0).normal(size=(args.n, args.n)) + args.n * np.eye(args.n)
    b = np.ones(args.n)
    aj, bj = jnp.asarray(a), jnp.asarray(b)
    solve = jax.jit(jnp.linalg.solve)
    solve(aj, bj).block_until_ready()  # loads jaxlib's LAPACK (SciPy's OpenBLAS) before limiting
    rows = {}
    for threads in (args.threads, 1):
        companion = subprocess.Popen(
            [sys.executable, "-c", COMPANION, str(args.n), str(threads)],
            stdout=subprocess.DEVNULL,
        )
        try:
            time.sleep(1.0)
            with threadpool_limits(limits=threads, user_api="blas"):
                rows[threads] = (
                    _time(lambda: np.linalg.solve(a, b)),
                    _time(lambda: solve(aj, bj).block_until_ready()),
                )
        finally:
            companion.kill()
            companion.wait()
    print(f"dense solve, n = {args.n}, beside a companion process doing the same")
    print(f"{'BLAS threads':>13} {'numpy [ms]':>11} {'jax [ms]':>9}")
    for threads, (t_np, t_jax) in rows.items():
        print(f"{threads:>13} {t_np:>11.2f} {t_jax:>9.2f}")
    many, one = rows[args.threads], rows[1]
    print(f"ratio {args.threads} threads / 1 thread: numpy {many[0] / one[0]:.1f}×, "
          f"jax {many[1] / one[1]:.1f}×")  # fmt: skip


if __name__ == "__main__":
    main()
