"""Fidelity study of the semi-bistable design: every selectable reading against the paper.

Run:  .venv/bin/python benchmarks/fidelity_semi_bistable.py [--quick | --only INDEX | --sensitivity]

For each reading (ModelOptions variant) of the SI calibration-table design it computes:

* the displacement-controlled equilibrium path to 9 mm (pseudo-arclength): the first loss of
  stability (force and load-point displacement), the displacement span of the unstable
  equilibria (spinodal regime), and the number of stability changes along the path;
* the paper's force ramp (0.8 N/s for 2 s, generalized-α, 5 % first-mode damping): u_z/l₀,
  u_r/l₀ and θ at 1.6 N, and whether the tube left phase 1 within the ramp (any circular fold
  more than half open);
* "serrated" vs "distributed": on the stable (realised) displacement-controlled response the
  circular folds transform one at a time when the force drops several times (one drop per
  fold); the count of stability changes on the path is its proxy here.

Every row is a reading of the paper (MODEL.md CHOICEs); the last rows are *sensitivities*, not
readings: they show how far a free number would have to move, and are never defaults.
Prints a Markdown table (pasted into docs/fidelity.md).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import biplan
from biplan.options import (
    ChainOffset,
    LoadPoint,
    MirrorConvention,
    ModelOptions,
    ModuleKind,
    TransitionReading,
)

READINGS: list[tuple[str, dict]] = [
    ("defaults (MODEL.md literal)", {}),
    ("L1: l_circ as branch lengths", {"__branch_lengths": True}),
    ("W1: load at the seam node", {"load_point": LoadPoint.SEAM}),
    ("W1: load at the split point", {"load_point": LoadPoint.SPLIT}),
    ("R: chain offset as printed in the SI", {"chain_offset": ChainOffset.PAPER}),
    ("K3: mirror as a point reflection", {"mirror": MirrorConvention.POINT}),
    ("K4: first module mirrored", {"first_module": ModuleKind.MIRRORED}),
    ("S1: weak contacts active", {"weak_contacts_active": True}),
]


#: α_R [1/s] for every reading: 5 % damping of the default design's first mode at 0.8 N
#: (ω₁ = 5.2e3 rad/s), the same for all readings so that the ramps compare.
RAYLEIGH = 525.0


def _tube(options: ModelOptions, circular_scale: float = 1.0, c_ratio: float | None = None):
    tube = biplan.designs.semi_bistable(options)
    if circular_scale != 1.0:
        law = tube.circular_laws[0]
        k1, k2, k3 = law.stiffness
        scaled = biplan.TrilinearLaw(
            (k1 * circular_scale, k2 * circular_scale, k3 * circular_scale), law.transitions
        )
        for i in range(tube.n_circular):
            tube = tube.with_law(("circular", i), scaled)
    if c_ratio is not None:
        k1 = tube.circular_laws[0].stiffness[0]
        for i in range(tube.n_modules):
            tube = tube.with_law(("helical", i), biplan.LinearLaw(c_ratio * k1))
    return tube


def study(name: str, tube: biplan.Tube) -> dict:
    model = biplan.Model(tube)
    t0 = time.perf_counter()
    ref = biplan.relaxed_reference(model)
    path = biplan.trace_path(
        model,
        biplan.ArcLength(initial_step=0.05, max_step=0.1, locate_events=False),
        ref,
        biplan.Control.displacement(9.0),
    )
    lam = path.min_eigenvalue
    unstable = np.flatnonzero(lam < 0)
    first = int(unstable[0]) if unstable.size else len(lam)
    k = int(np.argmax(path.force[:first])) if first else 0
    changes = int(np.sum(np.diff((lam < 0).astype(int)) != 0))
    ramp = biplan.integrate(
        model, biplan.GeneralizedAlpha(time_step=0.02, rayleigh=RAYLEIGH), ref, t_end=2.0
    )
    l0 = model.tube.initial_length
    n = model.layout.n_modules
    left = bool(np.any(ramp.phase_fraction[-1, n:, 2] > 0.5))
    return {
        "reading": name,
        "peak_force": float(path.force[k]),
        "peak_u": float(path.displacement[k]),
        "spinodal": (
            (float(path.displacement[unstable].min()), float(path.displacement[unstable].max()))
            if unstable.size
            else (np.nan, np.nan)
        ),
        "changes": changes,
        "uz": float(ramp.u_z[-1] / l0),
        "ur": float(ramp.u_r[-1] / l0),
        "theta": float(ramp.theta[-1]),
        "left_phase1": left,
        "ramp_status": ramp.status.name,
        "path_status": path.status.name,
        "seconds": time.perf_counter() - t0,
    }


def main() -> None:
    quick = "--quick" in sys.argv
    rows = []
    readings = READINGS[:2] if quick else READINGS
    if "--sensitivity" in sys.argv:
        readings, quick = [], False
    if "--only" in sys.argv:  # one reading per process (every layout compiles its kernels)
        readings = [READINGS[int(sys.argv[sys.argv.index("--only") + 1])]]
        quick = True
    for name, changes in readings:
        if changes.get("__branch_lengths"):
            # the same kernels (layout) as the defaults: only the law numbers change
            t = biplan.designs.SEMI_BISTABLE_TABLE
            law = biplan.TrilinearLaw.from_table(
                t.circular_stiffness, t.circular_transitions, TransitionReading.BRANCH_LENGTHS
            )
            tube = _tube(ModelOptions())
            for i in range(tube.n_circular):
                tube = tube.with_law(("circular", i), law)
        else:
            tube = _tube(ModelOptions().with_(**changes))
        try:
            rows.append(study(name, tube))
        except biplan.BiplanError as err:
            print(f"{name}: failed: {err}", flush=True)
            continue
        print(rows[-1], flush=True)
    if not quick:
        rows.append(
            study("sensitivity: circular k × 0.5 (not a reading)", _tube(ModelOptions(), 0.5))
        )
        print(rows[-1], flush=True)
        rows.append(
            study("sensitivity: C = 0.5 (not a reading)", _tube(ModelOptions(), c_ratio=0.5))
        )
        print(rows[-1], flush=True)
    print()
    print(
        "| reading | first instability F [N] (z_p [mm]) | spinodal z_p [mm] | stability changes | "
        "u_z/l0 @1.6 N | u_r/l0 @1.6 N | θ @1.6 N [rad] | transition within ramp |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        s0, s1 = r["spinodal"]
        print(
            f"| {r['reading']} | {r['peak_force']:.3f} ({r['peak_u']:.2f}) | {s0:.2f}–{s1:.2f} | "
            f"{r['changes']} | {r['uz']:.4f} | {r['ur']:.4f} | {r['theta']:.4f} | "
            f"{'yes' if r['left_phase1'] else 'no'} ({r['ramp_status'].lower()}) |"
        )


if __name__ == "__main__":
    main()
