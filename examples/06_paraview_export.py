"""Export to ParaView: write reconstructed tubes as VTK files (.vtu, and a .pvd series).

Solves the semi-bistable tube at a few prescribed end displacements, writes each state as a
VTK unstructured grid (the rigid elements as triangles wrapped onto the cylinder, the fold
fields as lines, with elongation, phase, module and fold arrays) and the series as a ParaView
collection. Open ``stretch.pvd`` in ParaView and colour by ``elongation`` or ``phase``.
Quick mode writes three states, full mode twelve. The files are read back with meshio to
check that every point lies on the cylinder of radius R.

    python examples/06_paraview_export.py --out out/examples/06_paraview_export
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import meshio
import numpy as np

import biplan
from biplan.io.vtk import write_pvd, write_vtu

QUICK = os.environ.get("BIPLAN_EXAMPLE_QUICK") == "1"


def main(out: Path) -> dict[str, float | int]:
    out.mkdir(parents=True, exist_ok=True)
    tube = biplan.designs.semi_bistable()
    model = biplan.Model(tube)
    state = biplan.relaxed_reference(model)
    displacements = np.linspace(0.0, 1.2, 3 if QUICK else 12)  # U [mm], phase 1
    qs = []
    for u in displacements:
        state = biplan.solve_equilibrium(
            model, biplan.Newton(), state, biplan.Load.of_displacement(u)
        )
        qs.append(state.q)
    pvd = write_pvd(out / "stretch.pvd", model, np.array(qs), times=displacements)
    last = write_vtu(out / "last.vtu", model, qs[-1])
    mesh = meshio.read(last)
    x, y, z = mesh.points.T
    radius_error = float(np.max(np.abs(np.hypot(x, y) - tube.development.radius)))
    n_vtu = len(list((out / "stretch").glob("*.vtu")))
    print(f"wrote {pvd} ({n_vtu} states) and {last}: {len(mesh.points)} points")
    print(f"cells: {', '.join(f'{b.type} {len(b.data)}' for b in mesh.cells)}")
    return {
        "n_states": len(qs),
        "n_vtu": n_vtu,
        "n_points": len(mesh.points),
        "radius_error": radius_error,
        "z_min": float(z.min()),
        "z_max": float(z.max()),
        "initial_length": tube.initial_length,
        "final_displacement": float(state.displacement),
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/examples/06_paraview_export"))
    result = main(parser.parse_args().out)
    print("RESULT " + json.dumps(result))
