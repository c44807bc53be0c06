"""Dense LU against SciPy's sparse SuperLU on the KKT matrices of N-module tubes.

Run:  .venv/bin/python benchmarks/bench_lu.py [--sizes 6 12 24 48 96]

For each N: the semi-bistable layout (SI Table laws and geometry, N modules on a base fold),
its KKT Jacobian at a random small configuration under a 1.5 N end force (so the chain's
dense ∇²z_p is in K), then the best of 5 timings of ``scipy.linalg.lu_factor`` +
``lu_solve`` and of ``scipy.sparse.linalg.splu(csc).solve``. Prints the nonzero fraction and
the ratio sparse/dense (below 1: sparse wins).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spl

import biplan


def best(fn, repeat: int) -> float:
    """Best of 5 mean times of ``repeat`` calls [ms]."""
    out = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(repeat):
            fn()
        out = min(out, (time.perf_counter() - t0) / repeat)
    return 1e3 * out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[6, 12, 24, 48, 96])
    args = ap.parse_args()
    table = biplan.designs.semi_bistable()
    print("   N   n_z  fill (K)      dense [ms]  SuperLU [ms]  sparse/dense")
    for n in args.sizes:
        tube = biplan.Tube.uniform(
            radius=2.0,
            pitch=3.6,
            helical_angle=60.0,
            n_modules=n,
            helical=table.helical_laws[0],
            circular=table.circular_laws[0],
            base_fold=True,
        )
        model = biplan.Model(tube)
        rng = np.random.default_rng(0)
        z = model.pack(rng.normal(scale=0.02, size=model.n_coordinates))
        jac = model.jacobian(z, biplan.Load.of_force(1.5))
        rhs = np.ones(jac.shape[0])
        csc = sp.csc_matrix(jac)
        nq = model.n_coordinates
        k_fill = np.count_nonzero(jac[:nq, :nq]) / nq**2
        repeat = max(1, 2000 // jac.shape[0])
        dense = best(lambda: sl.lu_solve(sl.lu_factor(jac), rhs), repeat)  # noqa: B023
        sparse = best(lambda: spl.splu(csc).solve(rhs), repeat)  # noqa: B023
        print(
            f"{n:4d} {jac.shape[0]:5d}  {csc.nnz / jac.size:.3f} ({k_fill:.2f})"
            f"  {dense:12.3f}  {sparse:12.3f}  {sparse / dense:12.2f}"
        )


if __name__ == "__main__":
    main()
