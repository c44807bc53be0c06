"""Pressure loading: inflate the tube, as the paper's pneumatic actuation does.

An internal pressure p on the closed tube acts on its end cap as the axial force F = p πR².
``Control.pressure`` follows the equilibrium path in p [MPa = N/mm²] (1 kPa = 1e-3 MPa) with
pseudo-arclength continuation, to 0.12 MPa in quick mode (phase 1, before the first snap) and
to 0.2 MPa in full mode (through the limit point near 0.17 MPa). The script checks the last
state against an independent force-controlled equilibrium at F = p πR². Writes
``pressure.nc`` and, in full mode, ``pressure.png``.

    python examples/04_pressure.py --out out/examples/04_pressure
"""

from __future__ import annotations

import argparse
import json
import math
import os
from pathlib import Path

import biplan
from biplan.io.results import save

QUICK = os.environ.get("BIPLAN_EXAMPLE_QUICK") == "1"


def main(out: Path) -> dict[str, float | int | str]:
    out.mkdir(parents=True, exist_ok=True)
    tube = biplan.designs.semi_bistable()
    model = biplan.Model(tube)
    ref = biplan.relaxed_reference(model)
    stop = 0.12 if QUICK else 0.2  # MPa
    path = biplan.trace_path(
        model, biplan.ArcLength(max_step=0.1, max_steps=400), ref, biplan.Control.pressure(stop)
    )
    save(path, out / "pressure.nc")
    if not QUICK:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(3.4, 2.6), layout="constrained")
        ax.plot(path.u_z, 1e3 * path.load_parameter, color="0.2")
        ax.set(xlabel="end displacement $u_z$ [mm]", ylabel="pressure $p$ [kPa]")
        fig.savefig(out / "pressure.png", dpi=150)
    p = float(path.load_parameter[-1])
    end_area = math.pi * tube.development.radius**2
    check = biplan.solve_equilibrium(
        model, biplan.Newton(), ref, biplan.Load.of_force(p * end_area)
    )
    print(f"{path.status.name}: {len(path.force)} states, p = {1e3 * p:.1f} kPa")
    print(f"F = {path.force[-1]:.4f} N (p πR² = {p * end_area:.4f} N)")
    print(f"u_z = {path.u_z[-1]:.4f} mm, force control at p πR²: {check.displacement:.4f} mm")
    first = path.events[0] if path.events else None
    return {
        "status": path.status.name,
        "n_states": len(path.force),
        "final_pressure": p,
        "end_area": end_area,
        "final_force": float(path.force[-1]),
        "final_displacement": float(path.displacement[-1]),
        "force_control_displacement": check.displacement,
        "first_event_pressure": first.load_parameter if first else None,
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/examples/04_pressure"))
    result = main(parser.parse_args().out)
    print("RESULT " + json.dumps(result))
