"""The stable-branch sweep through its snaps: the fail-fast default Newton against the full one.

Run:  .venv/bin/python benchmarks/bench_sweep_snaps.py [--config examples/semi_bistable.toml]
      [--stop 9] [--step 0.05]

One process, warm (each sweep is run once before it is timed): ``displacement_sweep`` from
the relaxed reference to ``--stop`` mm in steps of ``--step`` mm with its default Newton (at
most ``quasistatic.SUB_BACKTRACKS`` step halvings) and with ``Newton()`` (30 halvings). Prints
the wall time of each, the time in failed Newton solves (the steps past a snap), the ratio, and
checks that both find the same snaps with the same forces (docs/performance.md, "Fail-fast
Newton at snaps").
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=Path("examples/semi_bistable.toml"))
    parser.add_argument("--stop", type=float, default=9.0)
    parser.add_argument("--step", type=float, default=0.05)
    args = parser.parse_args()

    import biplan
    from biplan.analysis.response import quasistatic
    from biplan.solvers.newton import Newton

    model = biplan.Model(biplan.load_config(args.config))
    ref = biplan.relaxed_reference(model)
    n = max(1, round(args.stop / args.step))
    targets = np.linspace(args.stop / n, args.stop, n)
    original = quasistatic.solve_equilibrium
    failed = [0.0]

    def timed(*a, **k):  # type: ignore[no-untyped-def]
        start = time.perf_counter()
        sol = original(*a, **k)
        if not sol.converged:
            failed[0] += time.perf_counter() - start
        return sol

    quasistatic.solve_equilibrium = timed
    rows = {}
    for name, solver in (("default (8 halvings)", None), ("Newton() (30 halvings)", Newton())):
        quasistatic.displacement_sweep(model, targets, solver, start=ref)  # warm
        failed[0] = 0.0
        start = time.perf_counter()
        path = quasistatic.displacement_sweep(model, targets, solver, start=ref)
        rows[name] = (time.perf_counter() - start, failed[0], path)
    print(f"{args.config}: {n} steps of {args.stop / n:g} mm to {args.stop:g} mm")
    for name, (wall, fail, path) in rows.items():
        snaps = ", ".join(f"{u:g}" for u in path.displacement[path.switched])
        print(f"{name:>24}: {wall:7.2f} s, of which failed solves {fail:6.2f} s; snaps at {snaps}")
    (fast, _, a), (slow, _, b) = rows.values()
    same = np.array_equal(a.switched, b.switched) and np.allclose(
        a.force, b.force, rtol=1e-6, atol=1e-9, equal_nan=True
    )
    print(f"ratio Newton()/default: {slow / fast:.1f}×; same snaps and forces (1e-6): {same}")


if __name__ == "__main__":
    main()
