"""Force–displacement response: pull the semi-bistable tube by its end, through the snaps.

Pseudo-arclength continuation (``biplan.trace_path`` with ``ArcLength``) under displacement
control from the relaxed reference to U = 9 mm (quick mode: 3 mm). The path records the end
force, the endpoint, the energy of every fold and the smallest eigenvalue of the reduced
Hessian; where that eigenvalue changes sign the solver locates the event (the phase-1 force
maximum, where the six identical circular folds stop opening together). Writes
``path.nc``, ``path.csv`` and, in full mode, ``response.png``.

    python examples/02_force_response.py --out out/examples/02_force_response
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


def main(out: Path) -> dict[str, float | int | str]:
    out.mkdir(parents=True, exist_ok=True)
    model = biplan.Model(biplan.designs.semi_bistable())
    stop = 3.0 if QUICK else 9.0
    path = biplan.trace_path(
        model, biplan.ArcLength(max_step=0.1), None, biplan.Control.displacement(stop)
    )
    save(path, out / "path.nc")
    save(path, out / "path.csv")
    if not QUICK:
        import matplotlib

        matplotlib.use("Agg")
        from biplan import plot

        ax = plot.force_displacement(path)
        ax.figure.savefig(out / "response.png", dpi=150)
    first = path.events[0] if path.events else None
    # Initial stiffness dF/dU from the first two recorded states (phase 1 is linear elastic).
    stiffness = float(
        (path.force[1] - path.force[0]) / (path.displacement[1] - path.displacement[0])
    )
    print(f"{path.status.name}: {len(path.force)} states, {len(path.events)} events")
    for event in path.events[:5]:
        print(f"  {event.kind} at U = {event.displacement:.3f} mm, F = {event.force:.3f} N")
    return {
        "status": path.status.name,
        "n_states": len(path.force),
        "final_displacement": float(path.displacement[-1]),
        "peak_force": float(np.max(path.force)),
        "initial_stiffness": stiffness,
        "first_event_force": first.force if first else None,
        "first_event_displacement": first.displacement if first else None,
        "first_event_kind": first.kind if first else "",
        "min_eigenvalue_end": float(path.min_eigenvalue[-1]),
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/examples/02_force_response"))
    result = main(parser.parse_args().out)
    print("RESULT " + json.dumps(result))
