"""Snaps or stable softening: how the semi-bistable design's circular folds transform under a
displacement-controlled stable-branch sweep, for other fold counts and spinodal slopes.

Run:  .venv/bin/python benchmarks/series_criterion.py [--k2 -0.2 -0.1 ...] [--modules 2 3 ...]

A sensitivity study, not a reading: every case is the Table's design with one quantity changed
(``circular.k2`` for every circular fold, or the number of modules N). Each case is swept from
the relaxed reference to U = 1.5 N_c mm in steps of 0.1 mm (``displacement_sweep``), and the
script prints the snaps (steps that left an unstable equilibrium for a stable one), the
phase-1 peak and the span of stable softening (``summarize``), and the uniform-field series
number (N_c − 1)|k₂|/k₁: one fold on k₂ < 0 in series with N_c − 1 folds on k₁ is stable under
displacement control only when it is below 1 (less the rest of the tube's compliance).
Results and their reading: docs/fidelity.md, "Distributed onset, serrated completion".
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import biplan
from biplan.analysis.maps.grid import apply_values
from biplan.analysis.response.quasistatic import displacement_sweep
from biplan.analysis.response.summary import summarize


def run(name: str, tube: biplan.Tube) -> None:
    t0 = time.perf_counter()
    model = biplan.Model(tube)
    nc = model.layout.n_connectors
    law = tube.circular_laws[0]
    k1, k2 = law.stiffness[0], law.stiffness[1]
    stop = 1.5 * nc
    targets = np.round(np.arange(0.1, stop + 1e-9, 0.1), 10)
    path = displacement_sweep(model, targets, start=biplan.relaxed_reference(model))
    s = summarize(path, initial_length=tube.initial_length)
    snaps = [round(float(path.displacement[i]), 2) for i in np.flatnonzero(path.switched)]
    failed = sum(not x.converged for x in path.solutions)
    print(
        f"{name}: N_c = {nc}, (N_c - 1)|k2|/k1 = {(nc - 1) * abs(k2) / k1:.2f}; "
        f"{len(snaps)} snaps at U = {snaps}; phase-1 peak {s.peak_force:.3f} N; stable softening "
        f"{s.softening_start:.2f} … {s.softening_end:.2f} mm; {failed} failed "
        f"({time.perf_counter() - t0:.0f} s)",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--k2", type=float, nargs="*", default=[-0.2, -0.14, -0.1, -0.05])
    parser.add_argument("--modules", type=int, nargs="*", default=[2, 3, 4])
    args = parser.parse_args()
    base = biplan.designs.semi_bistable()
    for k2 in args.k2:
        run(f"k2 = {k2}", apply_values(base, {"circular.k2": k2}))
    for n in args.modules:
        run(f"N = {n}", apply_values(base, {"n_modules": n}))


if __name__ == "__main__":
    main()
