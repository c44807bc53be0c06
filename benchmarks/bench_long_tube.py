"""The bordered banded KKT solve against dense LU, in one process: pieces, a Newton step, the
long tube's displacement sweep.

Run:  .venv/bin/python benchmarks/bench_long_tube.py [--sizes 6 12 24 48] [--sweep 75]
      [--sweep-step 0.25] [--sweep-dense]

For each N: ``examples/long_tube_48.toml`` with ``n_modules = N`` (the SI Table laws and
geometry), its relaxed reference and the equilibrium at U = 0.2 N mm under displacement
control. Timed, best of several, CPU time of one thread (BLAS on one thread):

* ``direction``: one Newton direction J⁻¹(−r) of that equilibrium's KKT Jacobian inside the
  compiled Newton's kernel (:func:`biplan.solvers.bordered.direction`), by the layout's
  bordered banded solve and by dense LU (``np.linalg.solve``);
* ``LM``: one Levenberg–Marquardt step (ν = 1e-3), by the augmented system in the bordered
  solve (:func:`~biplan.solvers.bordered.lm_solve`) and by the dense normal equations;
* ``Newton``: one sweep step, ``solve_equilibrium`` from the equilibrium at U to U + 0.25 mm
  (``Newton(max_backtracks=8)``, the sweep's), on the model's System with its layout and on
  the same System with the layout removed (dense LU, dense Levenberg–Marquardt), and the
  ratio N / N_min of each.

``--sweep STOP``: ``biplan.analysis.response.run.stable_sweep`` of the 48-module tube to STOP
mm in steps of ``--sweep-step`` (the CLI's ``respond --control displacement``), wall and CPU
time, snaps and failed steps; with ``--sweep-dense`` the same sweep again with dense LU
(``BIPLAN_KKT_SOLVE=dense``, a new model) and the largest force difference between the two.
The machine load (``os.getloadavg``) is printed with every figure.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from biplan._compile.setup import limit_blas_threads

limit_blas_threads()

import biplan  # noqa: E402
from biplan.analysis.response.run import stable_sweep  # noqa: E402
from biplan.analysis.response.settings import QuasiStatic  # noqa: E402
from biplan.io.config import load_config_text  # noqa: E402
from biplan.model import system as system_module  # noqa: E402
from biplan.model.params import Load  # noqa: E402
from biplan.model.system import ordering  # noqa: E402
from biplan.solvers import bordered, iteration, levenberg  # noqa: E402

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "long_tube_48.toml"
NO_LAYOUT = np.zeros(0, dtype=np.int64)


def best(fn, budget: float = 0.3, most: int = 50) -> float:
    """Best CPU time [ms] of ``fn()`` over repeats within ~``budget`` s."""
    fn()
    times: list[float] = []
    start = time.perf_counter()
    while len(times) < most and (len(times) < 3 or time.perf_counter() - start < budget):
        t = time.process_time()
        fn()
        times.append(time.process_time() - t)
    return 1e3 * min(times)


def load_avg() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


def model_of(n: int) -> biplan.Model:
    text = EXAMPLE.read_text().replace("n_modules = 48", f"n_modules = {n}")
    return biplan.Model(load_config_text(text))


def pieces(n: int) -> dict[str, float]:
    """Direction, LM step and one Newton sweep step, structured and dense [ms]."""
    model = model_of(n)
    method = biplan.Newton(max_backtracks=8)
    ref = biplan.relaxed_reference(model, throw=True)
    u = 0.2 * n
    at_u = biplan.solve_equilibrium(model, method, ref, Load.of_displacement(u), throw=True)
    system = model.system(Load.of_displacement(u + 0.25))
    data = system.data
    dense = data._replace(solve_order=NO_LAYOUT, solve_band=NO_LAYOUT)
    jac = model.system(at_u.load).jacobian(at_u.z)
    rhs = -system.residual(at_u.z)
    order, band = data.solve_order, data.solve_band
    out = {
        "n_z": float(model.n_unknowns),
        "border": float(order.size - band[0] if band.size else 0),
    }
    out["direction"] = best(lambda: bordered.direction(jac, rhs, order, band, True))
    out["direction dense"] = best(lambda: bordered.dense_solve(jac, rhs))
    if band.size:
        out["LM"] = best(lambda: bordered.lm_solve(jac, rhs, 1e-3, order, *band))
    else:
        out["LM"] = float("nan")
    out["LM dense"] = best(lambda: levenberg.lm_direction(jac, rhs, 1e-3))
    settings = iteration.newton_settings(
        method.atol, method.max_steps, method.max_backtracks, method.armijo, method.free_steps
    )
    for name, d in (("Newton", data), ("Newton dense", dense)):
        _, _, _, _, steps, status = iteration.solve_system(
            system_module.System(d, system.load), at_u.z, settings
        )
        assert status == 0, f"N = {n}: the sweep step did not converge ({name})"
        out[name] = best(
            lambda d=d: iteration.solve_system(
                system_module.System(d, system.load), at_u.z, settings
            )
        )
        out[name + " steps"] = float(steps)
    return out


def sweep(stop: float, step: float, dense: bool) -> tuple[float, float, object]:
    """(wall s, CPU s, path) of the 48-module stable sweep."""
    if dense:
        os.environ[ordering.SOLVE_ENV] = "dense"
    system_module._LAYOUTS.clear()
    model = model_of(48)
    try:
        settings = QuasiStatic(stop=stop, step=step)
        wall, cpu = time.perf_counter(), time.process_time()
        path = stable_sweep(model, settings)
        return time.perf_counter() - wall, time.process_time() - cpu, path
    finally:
        os.environ.pop(ordering.SOLVE_ENV, None)
        system_module._LAYOUTS.clear()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[6, 12, 24, 48])
    ap.add_argument("--sweep", type=float, default=0.0, help="sweep the 48-module tube to mm")
    ap.add_argument("--sweep-step", type=float, default=0.25)
    ap.add_argument("--sweep-dense", action="store_true", help="and again with dense LU")
    args = ap.parse_args()
    rows = []
    print(
        "N  n_z  border | direction: bordered / dense [ms] | LM: bordered / dense [ms] | "
        "Newton sweep step: bordered / dense [ms] (steps) | load"
    )
    for n in args.sizes:
        r = pieces(n)
        rows.append((n, r))
        print(
            f"{n:3d} {int(r['n_z']):4d} {int(r['border']):3d} | {r['direction']:.3f} / "
            f"{r['direction dense']:.3f} | {r['LM']:.3f} / {r['LM dense']:.3f} | "
            f"{r['Newton']:.3f} / {r['Newton dense']:.3f} ({int(r['Newton steps'])}) | "
            f"{load_avg()}",
            flush=True,
        )
    if len(rows) > 1:
        (n0, r0), (n1, r1) = rows[0], rows[-1]
        print(
            f"Newton step N = {n1} / N = {n0}: {r1['Newton'] / r0['Newton']:.1f}× "
            f"(dense LU: {r1['Newton dense'] / r0['Newton dense']:.1f}×); N = {n1} dense / "
            f"bordered: {r1['Newton dense'] / r1['Newton']:.1f}×"
        )
    if args.sweep:
        runs = [("bordered", False)] + ([("dense", True)] if args.sweep_dense else [])
        paths = []
        for name, dense in runs:
            before = load_avg()
            wall, cpu, path = sweep(args.sweep, args.sweep_step, dense)
            paths.append(path)
            failed = sum(s.value != 0 for s in path.status)
            print(
                f"sweep to {args.sweep:g} mm ({name}): {wall:.1f} s wall, {cpu:.1f} s CPU, "
                f"{path.n_steps} steps, {int(path.switched.sum())} snaps, {failed} failed "
                f"({before} → {load_avg()})",
                flush=True,
            )
        if len(paths) == 2:
            diff = np.nanmax(np.abs(paths[0].force - paths[1].force))
            same = np.array_equal(paths[0].switched, paths[1].switched)
            print(f"largest force difference {diff:.2e} N; the same snap steps: {same}")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
