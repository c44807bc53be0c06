"""Dynamics: the paper's slow force ramp, integrated in time with the generalized-α method.

``biplan.integrate`` solves M(q) q̈ + c(q, q̇) + ∇Π − F ∇z_p + constraint forces = 0 from the
relaxed reference at rest, under the ramp F(t) = 0.8 N/s · t (2 s; quick mode: 1 s with larger
steps). The ramp is slow next to the tube's first natural period (about a millisecond), so the
end of the run should sit on the quasi-static equilibrium at the final force; the script checks
this with an independent ``solve_equilibrium`` at that force. Writes ``ramp.nc`` and, in full
mode, ``energy.png`` (strain, kinetic, external work and the energy balance).

    python examples/03_dynamics.py --out out/examples/03_dynamics
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

import biplan
from biplan.io.results import save

QUICK = os.environ.get("BIPLAN_EXAMPLE_QUICK") == "1"


def main(out: Path) -> dict[str, float | str]:
    out.mkdir(parents=True, exist_ok=True)
    model = biplan.Model(biplan.designs.semi_bistable())
    ref = biplan.relaxed_reference(model)
    t_end, time_step = (1.0, 0.05) if QUICK else (2.0, 0.01)
    ramp = biplan.integrate(
        model,
        biplan.GeneralizedAlpha(time_step=time_step),
        ref,
        t_end=t_end,
        load=biplan.LoadHistory.ramp(rate=0.8, until=t_end),
    )
    save(ramp, out / "ramp.nc")
    if not QUICK:
        import matplotlib

        matplotlib.use("Agg")
        from biplan.io.results import dataset
        from biplan.plot.diagnostics import energy_by_fold_set

        ax = energy_by_fold_set(dataset(ramp))
        ax.figure.savefig(out / "energy.png", dpi=150)
    final_force = float(ramp.force[-1])
    static = biplan.solve_equilibrium(
        model, biplan.Newton(), ref, biplan.Load.of_force(final_force)
    )
    work = float(np.max(np.abs(ramp.external_work)))
    drift = float(np.max(np.abs(ramp.total_energy - ramp.total_energy[0])))
    print(f"{ramp.status.name}: t = {ramp.time[-1]:.2f} s, F = {final_force:.3f} N")
    print(f"u_z = {ramp.u_z[-1]:.4f} mm (quasi-static: {static.displacement:.4f} mm)")
    print(f"energy balance drift {drift:.2e} N·mm of {work:.3e} N·mm external work")
    return {
        "status": ramp.status.name,
        "final_time": float(ramp.time[-1]),
        "final_force": final_force,
        "final_displacement": float(ramp.displacement[-1]),
        "final_u_z": float(ramp.u_z[-1]),
        "static_displacement": static.displacement,
        "max_kinetic_energy": float(np.max(ramp.kinetic_energy)),
        "external_work": work,
        "energy_drift": drift,
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/examples/03_dynamics"))
    result = main(parser.parse_args().out)
    print("RESULT " + json.dumps(result))
