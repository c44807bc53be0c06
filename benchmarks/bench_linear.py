"""Dense LU against structured (sparse, banded, Woodbury) solves of the KKT Jacobian.

Run:  .venv/bin/python benchmarks/bench_linear.py [--sizes 6 12 24 48 96 200 400] [--quick]
      [--markdown] [--threads 1]

For each N: the calibration tube of ``tests/conftest.py::make_tube`` (SI Table geometry and
laws, N modules on a base fold), its relaxed reference z_0 (``relaxed_reference``) and its
equilibrium z_F under a 1 N end force (``solve_equilibrium`` started at z_0). Two load cases:

* ``rest``: J = ∂r/∂z of ``model.system()`` at z_0 (block-banded), right-hand side the rest
  system's residual at z_F (the unloading Newton step);
* ``force``: J of ``model.system(Load.of_force(1))`` at z_F (the chain term −F ∇²z_p fills the
  rows and columns of the chain's coordinates densely), right-hand side the forced residual at
  z_0 (the loading Newton step).

Per case: n_z, the nonzero fraction, the bandwidth max |i − j| after a reverse Cuthill–McKee
ordering (``scipy.sparse.csgraph.reverse_cuthill_mckee``, computed once: the structure is the
layout's), and the best-of-several time [ms] of one factorisation + one solve, what a Newton
pass pays, on one BLAS thread (``--threads``; biplan's documented default):

* ``lu``: ``scipy.linalg.lu_factor`` + ``lu_solve``; ``np``: ``np.linalg.solve`` (LAPACK gesv,
  what the compiled Newton calls inside Numba);
* ``csc``: converting the dense J to CSC (not in the sparse times: a sparse assembly would
  produce CSC directly, today's assembly fills a dense array);
* ``splu`` (``permc_spec`` 'COLAMD', SciPy's default) and ``mmd`` ('MMD_AT_PLUS_A'): SuperLU
  factor / solve times and their sum;
* ``band``: LAPACK gbtrf + gbtrs (what ``scipy.linalg.solve_banded`` calls: LU with partial
  pivoting inside the band) on the RCM-permuted J, gathered from the dense J with precomputed
  indices (the gather is in the time); only where the RCM bandwidth is ≤ n_z / 8;
* ``wood`` (force case): Woodbury. J = A + E C Eᵀ with A the rest system's Jacobian at the
  same z_F (sparse, RCM bandwidth ~9) and C = (J − A)[S, S] on the support S of the chain term
  (k = |S| coordinates, E the columns of the identity on S). A and C are taken apart outside
  the timing (an assembly would produce them separately). Timed: the factorisation of A,
  [y, W] = A⁻¹[b, E] (k + 1 right-hand sides), the k × k capacitance I + C W[S] by dense LU
  and x = y − W (I + C W[S])⁻¹ C y[S]; A by ``splu`` and by gbtrf/gbtrs on its RCM order
  (as ``band``: LAPACK only, what compiled code could call through
  ``scipy.linalg.cython_lapack``).

Every solve's relative residual ‖J dz + r‖ / ‖r‖ is checked; the worst is printed (the
banded and Woodbury ones apart, without ``--markdown``). "best/dense": the best structured
time over the better dense one, and which; "+csc": the same with the CSC conversion added
to the SuperLU-based solves. The summary gives, per case, the crossover: the smallest N from
which on (at every larger N measured) the best structured solve beats the best dense one,
without and with the conversion, and the ratios at N = 48.
``--quick``: N = 6, 12, 24, 48. ``--markdown``: the table as Markdown.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from scipy.linalg import lapack
from scipy.sparse.csgraph import reverse_cuthill_mckee
from threadpoolctl import threadpool_info, threadpool_limits

import biplan

#: tests/conftest.py: geometry and laws of the SI calibration table.
GEOMETRY = {"radius": 2.0, "pitch": 3.6, "helical_angle": 60.0}
CIRCULAR = biplan.TrilinearLaw(stiffness=(0.9, -0.2, 0.6), transitions=(0.2, 1.3))
HELICAL = biplan.LinearLaw(stiffness=1.3)
FORCE = 1.0
SIZES = [6, 12, 24, 48, 96, 200, 400]
QUICK = [6, 12, 24, 48]


def best(fn, budget: float = 0.25, most: int = 30) -> float:
    """Best time [ms] of ``fn()`` over at least 3 calls (2 when one takes over 1 s), more while
    within ``budget`` seconds (at most ``most``)."""
    t0 = time.perf_counter()
    fn()
    first = time.perf_counter() - t0
    times = [first]
    reps = 1 if first > 1.0 else max(2, min(most, int(budget / max(first, 1e-6))))
    for _ in range(reps):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * min(times)


def rcm_band(jac: np.ndarray) -> tuple[np.ndarray, int, int]:
    """The RCM permutation p and the lower/upper bandwidths of J[p][:, p]."""
    p = reverse_cuthill_mckee(sp.csr_matrix(jac), symmetric_mode=False)
    rows, cols = np.nonzero(jac[np.ix_(p, p)])
    return p, int(np.max(rows - cols, initial=0)), int(np.max(cols - rows, initial=0))


def banded(jac: np.ndarray, p: np.ndarray, kl: int, ku: int):
    """``factor(a)``: gbtrf of a[p][:, p] (a of J's structure; indices precomputed here),
    returning a solver of a x = b (b of one or more columns) by gbtrs."""
    n = jac.shape[0]
    j = np.arange(n)[None, :]
    i = j + np.arange(-ku, kl + 1)[:, None]  # ab[kl + ku + i − j, j] = a[i, j]
    ok = (i >= 0) & (i < n)
    ri, rj = p[np.where(ok, i, 0)], p[np.broadcast_to(j, i.shape)]

    def factor(a: np.ndarray):
        ab = np.zeros((2 * kl + ku + 1, n))
        ab[kl:] = np.where(ok, a[ri, rj], 0.0)
        lu, piv, info = lapack.dgbtrf(ab, kl, ku, overwrite_ab=True)

        def solve(b: np.ndarray) -> np.ndarray:
            xp, info2 = lapack.dgbtrs(lu, kl, ku, b[p], piv)
            x = np.empty_like(xp)
            x[p] = xp
            return x if info == 0 == info2 else np.full_like(xp, np.nan)

        return solve

    return factor


def woodbury(solve_a, s: np.ndarray, c: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(A + E C Eᵀ)⁻¹ b, E the identity's columns on s, given a solver of A (module
    docstring)."""
    k = s.shape[0]
    rhs = np.zeros((b.shape[0], k + 1))
    rhs[:, 0] = b
    rhs[s, 1 + np.arange(k)] = 1.0
    x = solve_a(rhs)
    y, w = x[:, 0], x[:, 1:]
    m = np.eye(k) + c @ w[s]
    return y - w @ sl.lu_solve(sl.lu_factor(m), c @ y[s])


def measure(jac: np.ndarray, rhs: np.ndarray, rest_part: np.ndarray | None) -> dict:
    """The row of one Jacobian (module docstring)."""
    n = jac.shape[0]
    b = -rhs
    csc = sp.csc_matrix(jac)
    p, kl, ku = rcm_band(jac)
    row: dict = {"n_z": n, "fill": csc.nnz / jac.size, "bw": max(kl, ku)}
    sols = {}
    row["lu"] = best(lambda: sl.lu_solve(sl.lu_factor(jac), b))
    sols["lu"] = sl.lu_solve(sl.lu_factor(jac), b)
    row["np"] = best(lambda: np.linalg.solve(jac, b))
    sols["np"] = np.linalg.solve(jac, b)
    row["csc"] = best(lambda: sp.csc_matrix(jac))
    for name, spec in (("splu", "COLAMD"), ("mmd", "MMD_AT_PLUS_A")):
        lu = spl.splu(csc, permc_spec=spec)
        row[name + "_f"] = best(lambda spec=spec: spl.splu(csc, permc_spec=spec))
        row[name + "_s"] = best(lambda lu=lu: lu.solve(b))
        row[name] = row[name + "_f"] + row[name + "_s"]
        sols[name] = lu.solve(b)
    if max(kl, ku) <= n / 8:
        factor = banded(jac, p, kl, ku)
        row["band"] = best(lambda: factor(jac)(b))
        sols["band"] = factor(jac)(b)
    if rest_part is not None:
        d = jac - rest_part
        s = np.flatnonzero(np.any(d != 0, axis=0) | np.any(d != 0, axis=1))
        a_csc, c = sp.csc_matrix(rest_part), d[np.ix_(s, s)]
        row["k"] = s.shape[0]
        row["wood"] = best(lambda: woodbury(spl.splu(a_csc).solve, s, c, b))
        sols["wood"] = woodbury(spl.splu(a_csc).solve, s, c, b)
        p_a, kl_a, ku_a = rcm_band(rest_part)
        factor_a = banded(rest_part, p_a, kl_a, ku_a)
        row["woodb"] = best(lambda: woodbury(factor_a(rest_part), s, c, b))
        sols["woodb"] = woodbury(factor_a(rest_part), s, c, b)
    res = {k: np.linalg.norm(jac @ x - b) / np.linalg.norm(b) for k, x in sols.items()}
    row["res"] = max(res.values())
    row["res_band"] = res.get("band", np.nan)
    row["res_wood"] = max(res.get("wood", np.nan), res.get("woodb", np.nan))
    row["dense"] = min(row["lu"], row["np"])
    structured = {k: row[k] for k in ("splu", "mmd", "band", "wood", "woodb") if k in row}
    row["best"] = min(structured, key=structured.__getitem__)
    row["ratio"] = row[row["best"]] / row["dense"]
    sparse_only = min(row["splu"], row["mmd"])  # conversion applies to the CSC solvers only
    alt = [sparse_only + row["csc"], row.get("wood", np.inf) + row["csc"]]
    alt += [row[k] for k in ("band", "woodb") if k in row]  # gathered from the dense J
    row["ratio_csc"] = min(alt) / row["dense"]
    return row


def case_rows(n: int) -> list[tuple[str, dict]]:
    tube = biplan.Tube.uniform(
        **GEOMETRY, n_modules=n, helical=HELICAL, circular=CIRCULAR, base_fold=True
    )
    model = biplan.Model(tube)
    t0 = time.perf_counter()
    ref = biplan.relaxed_reference(model)
    sol = biplan.solve_equilibrium(model, start=ref, load=biplan.Load.of_force(FORCE))
    took = time.perf_counter() - t0
    if not (ref.converged and sol.converged):
        print(f"# N = {n}: reference {ref.status}, forced {sol.status} (timed anyway)")
    rest, forced = model.system(), model.system(biplan.Load.of_force(FORCE))
    j_rest = rest.jacobian(ref.z)
    j_force = forced.jacobian(sol.z)
    out = [
        ("rest", measure(j_rest, rest.residual(sol.z), None)),
        ("force", measure(j_force, forced.residual(ref.z), rest.jacobian(sol.z))),
    ]
    out[0][1]["newton_s"] = took
    return out


#: (header, width, format) of the table's columns.
COLUMNS = (
    ("N", 4, "{}"),
    ("case", 5, "{}"),
    ("n_z", 5, "{}"),
    ("nnz %", 5, "{:.1f}"),
    ("RCM bw", 6, "{}"),
    ("lu", 8, "{:.3f}"),
    ("np", 8, "{:.3f}"),
    ("csc", 7, "{:.3f}"),
    ("splu f/s", 15, "{}"),
    ("mmd f/s", 15, "{}"),
    ("band", 7, "{}"),
    ("wood splu/band (k)", 22, "{}"),
    ("best/dense", 15, "{}"),
    ("+csc", 5, "{:.2f}"),
    ("max res", 8, "{:.1e}"),
)


def cells(n: int, case: str, r: dict) -> list[str]:
    def fs(name: str) -> str:
        return f"{r[name + '_f']:.3f}/{r[name + '_s']:.3f}"

    band = f"{r['band']:.3f}" if "band" in r else "—"
    wood = f"{r['wood']:.3f}/{r['woodb']:.3f} ({r['k']})" if "wood" in r else "—"
    values = [
        n,
        case,
        r["n_z"],
        100 * r["fill"],
        r["bw"],
        r["lu"],
        r["np"],
        r["csc"],
        fs("splu"),
        fs("mmd"),
        band,
        wood,
        f"{r['ratio']:.2f} {r['best']}",
        r["ratio_csc"],
        r["res"],
    ]
    return [fmt.format(v) for (_, _, fmt), v in zip(COLUMNS, values, strict=True)]


def crossover(rows: list[tuple[int, dict]], key: str) -> int | None:
    """The smallest N from which on (every larger N measured too) structured wins."""
    win = None
    for n, r in sorted(rows, key=lambda t: t[0]):
        win = (n if win is None else win) if r[key] < 1.0 else None
    return win


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=SIZES)
    ap.add_argument("--quick", action="store_true", help="N = 6 12 24 48")
    ap.add_argument("--markdown", action="store_true", help="print the table as Markdown")
    ap.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    args = ap.parse_args()
    sizes = QUICK if args.quick else args.sizes
    # Both OpenBLAS libraries (NumPy's; SciPy's, which Numba's LAPACK calls use) on
    # --threads threads: biplan's default of one is applied by biplan._compile.setup.configure
    # only once JAX is used, so a compiled-core process otherwise keeps OpenBLAS's default.
    threadpool_limits(limits=args.threads, user_api="blas")
    threads = [i["num_threads"] for i in threadpool_info()]
    print(f"# load average {os.getloadavg()}, BLAS threads {threads}; times in ms")
    start = time.perf_counter()
    biplan.relaxed_reference(biplan.Model(biplan.designs.semi_bistable()))  # compile, untimed
    print(f"# warm-up (Numba load/compile) {time.perf_counter() - start:.1f} s")
    widths = [w for _, w, _ in COLUMNS]
    head = [h for h, _, _ in COLUMNS]
    if args.markdown:
        print("| " + " | ".join(head) + " |\n" + "|---" * len(head) + "|")
    else:
        print("  ".join(f"{h:>{w}}" for h, w in zip(head, widths, strict=True)))
    by_case: dict[str, list[tuple[int, dict]]] = {"rest": [], "force": []}
    for n in sizes:
        for case, r in case_rows(n):
            by_case[case].append((n, r))
            row = cells(n, case, r)
            if args.markdown:
                print("| " + " | ".join(row) + " |")
            else:
                print("  ".join(f"{c:>{w}}" for c, w in zip(row, widths, strict=True)))
            if not args.markdown and not np.isnan([r["res_band"], r["res_wood"]]).all():
                print(f"#   residual band {r['res_band']:.1e}, Woodbury {r['res_wood']:.1e}")
        print(f"#   N = {n}: reference + forced solve {by_case['rest'][-1][1]['newton_s']:.2f} s")
    for case, rows in by_case.items():
        at48 = [r for n, r in rows if n == 48]
        x, xc = crossover(rows, "ratio"), crossover(rows, "ratio_csc")
        msg = (
            f"{case}: structured beats dense from N = {x or 'never'} on"
            f" ({xc or 'never'} with the CSC conversion)"
        )
        if at48:
            r = at48[0]
            msg += f"; N = 48: {r['best']}/dense = {r['ratio']:.2f} ({r['ratio_csc']:.2f} + csc)"
        print(msg)
    print(f"# load average {os.getloadavg()}, total {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
