"""A first tube: build the paper's semi-bistable design, find its reference, stretch it once.

Builds ``biplan.designs.semi_bistable()`` (R = 2 mm, l = 3.6 mm, β = 60°, N = 6), prints its
geometric ratio b and stiffness ratio C, relaxes the clamped reference, solves the equilibrium
at a prescribed end displacement U and classifies its stability. Writes ``tube.toml`` (the
tube as a configuration file) and ``first_tube.png`` (the planar development) into ``--out``.

    python examples/01_first_tube.py --out out/examples/01_first_tube
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import biplan
from biplan.io.config import dump_config

QUICK = os.environ.get("BIPLAN_EXAMPLE_QUICK") == "1"


def main(out: Path) -> dict[str, float | bool | str]:
    out.mkdir(parents=True, exist_ok=True)
    tube = biplan.designs.semi_bistable()
    model = biplan.Model(tube)
    ref = biplan.relaxed_reference(model)  # clamped base, no load
    load = biplan.Load.of_displacement(1.0)  # U = 1 mm: phase 1, before any fold snaps
    sol = biplan.solve_equilibrium(model, biplan.Newton(), ref, load)
    stability = biplan.classify(model, sol)
    (out / "tube.toml").write_text(dump_config(tube), encoding="utf-8")
    if not QUICK:
        import matplotlib

        matplotlib.use("Agg")
        from biplan import plot

        ax = plot.development(model, sol.q, color_by="elongation", reference=True)
        ax.figure.savefig(out / "first_tube.png", dpi=150)
    print(model)
    print(f"b = {tube.b:.3f}, C = {tube.C:.3f}, l0 = {tube.initial_length} mm")
    print(f"U = 1 mm: F = {sol.force:.4f} N, {sol.status.name}, {stability.verdict.name}")
    return {
        "b": tube.b,
        "C": tube.C,
        "radius": tube.development.radius,
        "pitch": tube.development.pitch,
        "helical_angle": tube.development.helical_angle,
        "displacement": sol.displacement,
        "force": sol.force,
        "energy": sol.energy,
        "converged": sol.converged,
        "stable": stability.verdict is biplan.Verdict.STABLE,
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/examples/01_first_tube"))
    result = main(parser.parse_args().out)
    print("RESULT " + json.dumps(result))
