"""Benchmark: all design derivatives of one state, implicit differentiation against finite
differences of re-solves.

On the semi-bistable design (``designs.semi_bistable()``, six modules, SI Table calib) at the
end force ``--force`` (default 1.0 N, on the phase-1 branch from the relaxed reference), times

* :func:`biplan.analysis.sensitivity.equilibrium.sensitivity`: every observable (u_z, u_r, θ, Π, z_p,
  λ_min) with respect to every parameter (R, l, β, the helical stiffness, the circular law's
  k1, k2, k3, l1, l2 and F): one kernel call and one factorisation of the KKT Jacobian;
* :func:`biplan.analysis.sensitivity.finite_differences.finite_differences`: the same table by central
  differences, two Newton re-solves (from the converged state, ‖r‖∞ < 1e-13) per parameter;

both warm (each run once first, untimed, to compile), and prints the ratio and the largest
relative difference of p ∂y/∂p between the two (entries above 1e-3 of their row's largest).

Run: ``.venv/bin/python benchmarks/bench_sensitivity.py [--force F] [--repeat N]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import biplan
from biplan.analysis.sensitivity.equilibrium import sensitivity
from biplan.analysis.sensitivity.finite_differences import finite_differences


def best_of(repeat: int, fn) -> tuple[float, object]:  # type: ignore[no-untyped-def]
    """(best wall time [s] of ``repeat`` calls, the last result)."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", type=float, default=1.0, help="end force F [N]")
    parser.add_argument("--repeat", type=int, default=3, help="timed calls (best of)")
    args = parser.parse_args()

    model = biplan.Model(biplan.designs.semi_bistable())
    tight = biplan.Newton(atol=1e-13)
    t0 = time.perf_counter()
    state = biplan.solve_equilibrium(model, tight, None, biplan.Load.of_force(args.force))
    if not state.converged:
        raise SystemExit(f"no equilibrium at F = {args.force} N: {state.message}")
    exact = sensitivity(model, state)  # compile
    cold = time.perf_counter() - t0
    fd = finite_differences(model, state)  # compile the re-solves' kernels
    t_exact, exact = best_of(args.repeat, lambda: sensitivity(model, state))
    t_fd, fd = best_of(args.repeat, lambda: finite_differences(model, state))

    p = np.asarray([par.value for par in exact.parameters])  # type: ignore[union-attr]
    a, b = exact.derivatives * p, fd.derivatives * p  # type: ignore[union-attr]
    significant = np.abs(b) > 1e-3 * np.abs(b).max(axis=1, keepdims=True)
    rel = np.abs(a - b)[significant] / np.abs(b)[significant]
    n_obs, n_par = a.shape
    print(f"semi-bistable design, F = {args.force} N, {n_obs} observables × {n_par} parameters")
    print(f"  first call (solve + compile): {cold:.1f} s")
    print(f"  implicit (adjoint):          {1e3 * t_exact:8.1f} ms")
    print(f"  finite differences:          {1e3 * t_fd:8.1f} ms ({2 * n_par} re-solves)")
    print(f"  ratio:                       {t_fd / t_exact:8.1f}×")
    print(f"  largest relative difference: {rel.max():.2e} (of {rel.size} significant entries)")


if __name__ == "__main__":
    main()
