"""Response-solver timings: the paper design's quasi-static path and one 2 s dynamic ramp.

Run:  .venv/bin/python benchmarks/bench_response.py

In one process, for the semi-bistable paper design (6 modules, 64 unknowns):

* path — ``trace_path`` with pseudo-arclength under displacement control 0 → 9 mm (≥ 200
  steps through the spinodal regime and all fold transitions), warm (after jit), with and
  without event location; the cold (first-call) time is reported separately;
* path baseline — what a researcher would write with SciPy: natural displacement stepping at
  the same displacements, each step ``scipy.optimize.root`` (``hybr``, finite-difference
  Jacobian) on the model residual (the jitted residual, i.e. a favourable baseline);
* ramp — ``integrate`` with generalized-α, h = 10 ms, the paper's 0.8 N/s × 2 s, warm;
* ramp baseline — ``scipy.integrate.solve_ivp(method="Radau")`` on the penalty-regularised
  ODE (guides and contacts as stiff springs, κ = 1e3 N/mm, mass matrix from the model),
  finite-difference Jacobian, over a 0.05 s window; its time is extrapolated to 2 s.

Ratios are printed as baseline / biplan.
"""

from __future__ import annotations

import time

import numpy as np

import biplan
from biplan.solvers.dynamics import mass_matrix_at


def _time(fn, repeat: int = 3) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    model = biplan.Model(biplan.designs.semi_bistable())
    ref = biplan.relaxed_reference(model)
    method = biplan.ArcLength(initial_step=0.05, max_step=0.1)
    quiet = biplan.ArcLength(initial_step=0.05, max_step=0.1, locate_events=False)
    control = biplan.Control.displacement(9.0)

    t0 = time.perf_counter()
    path = biplan.trace_path(model, method, ref, control)
    cold_path = time.perf_counter() - t0
    warm_events = _time(lambda: biplan.trace_path(model, method, ref, control))
    warm_path = _time(lambda: biplan.trace_path(model, quiet, ref, control))
    n_steps = path.stats.n_steps
    print(f"path: {n_steps} steps, {path.stats.n_cutbacks} cut-backs, {len(path.events)} events")
    print(f"  cold (incl. compilation)     {cold_path:8.2f} s")
    print(f"  warm, events located         {warm_events:8.3f} s")
    print(
        f"  warm, no event location      {warm_path:8.3f} s  ({1e3 * warm_path / n_steps:.2f} ms/step)"
    )

    import scipy.optimize

    targets = path.displacement[1:][np.argsort(path.displacement[1:])]
    targets = targets[:: max(1, len(targets) // 60)]  # time a subset, scale per step
    z = ref.z.copy()
    ok = 0
    t0 = time.perf_counter()
    for u in targets:
        load = biplan.Load.of_displacement(float(u))
        sol = scipy.optimize.root(lambda zz, ld=load: model.residual(zz, ld), z, method="hybr")
        ok += bool(np.max(np.abs(model.residual(sol.x, load))) < 1e-8)
        z = sol.x
    per_step = (time.perf_counter() - t0) / len(targets)
    base_path = per_step * n_steps
    print(
        f"  baseline scipy root (FD)     {base_path:8.2f} s  ({1e3 * per_step:.1f} ms/step, "
        f"{ok}/{len(targets)} steps reach 1e-8)"
    )
    print(
        f"  ratio baseline / biplan      {base_path / warm_path:8.1f}x (no events), "
        f"{base_path / warm_events:.1f}x (events)"
    )

    scheme = biplan.GeneralizedAlpha(time_step=0.01)
    t0 = time.perf_counter()
    ramp = biplan.integrate(model, scheme, ref, t_end=2.0)
    cold_ramp = time.perf_counter() - t0
    warm_ramp = _time(lambda: biplan.integrate(model, scheme, ref, t_end=2.0))
    print(f"ramp: {ramp.stats.n_steps} steps, {ramp.message}")
    print(f"  cold (incl. compilation)     {cold_ramp:8.2f} s")
    print(f"  warm                         {warm_ramp:8.3f} s")

    import scipy.integrate

    nq = model.n_coordinates
    kappa = 1e3
    mass = mass_matrix_at(model, ref.q)
    m_inv = np.linalg.pinv(mass + 1e-12 * np.eye(nq))

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, v = y[:nq], y[nq:]
        f = 0.8 * t
        g = model.constraints(q)
        gap = np.minimum(model.contact_gaps(q), 0.0)
        force = (
            -model.gradient(q)
            + f * model.load_gradient(q)
            - kappa * model.constraint_jacobian(q).T @ g
            - kappa * model.contact_jacobian(q).T @ gap
            - 0.1 * mass @ v
        )
        return np.concatenate([v, m_inv @ force])

    window = 0.05
    t0 = time.perf_counter()
    sol = scipy.integrate.solve_ivp(
        rhs, (0.0, window), np.concatenate([ref.q, np.zeros(nq)]), method="Radau", rtol=1e-6
    )
    base_window = time.perf_counter() - t0
    base_ramp = base_window * 2.0 / window
    print(
        f"  baseline solve_ivp Radau     {base_ramp:8.1f} s  (measured {base_window:.2f} s for "
        f"{window} s of the ramp, {sol.nfev} evaluations, status {sol.status})"
    )
    print(f"  ratio baseline / biplan      {base_ramp / warm_ramp:8.1f}x")


if __name__ == "__main__":
    main()
