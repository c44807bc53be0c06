"""Slope hierarchy of the fully bistable tube under the two chain readings R3 (docs/states.md).

Enumerates the stable states once (they do not depend on R3) and evaluates the endpoint slope θ
of every state under ``chain_attachment = "element"`` (MODEL literal, H^TPC = I) and
``"edge_fit"`` (edge-fit stacking). Prints max|θ|, the |Θ| ranges per number of open helical
folds, and Θ of 66 and 1B.

Usage::

    .venv/bin/python benchmarks/fully_bistable_readings.py
"""

from __future__ import annotations

import numpy as np

import biplan
from biplan.analysis.states.search import enumerate_states


def main() -> None:
    catalogue = enumerate_states(biplan.Model(biplan.designs.fully_bistable()))
    print(f"{len(catalogue)} stable states")
    hel = np.array([catalogue.open_counts(s)[0] for s in catalogue.states])
    for reading in ("element", "edge_fit"):
        options = biplan.ModelOptions(chain_attachment=reading)
        model = biplan.Model(biplan.designs.fully_bistable(options))
        theta = np.array([model.endpoint(s.q).theta for s in catalogue.states])
        big = np.abs(theta).max()
        slope = theta / big if big > 0 else theta
        print(f"{reading}: max|theta| = {big:.4f} rad")
        for k in np.unique(hel):
            a = np.abs(slope[hel == k])
            print(f"  {k} open helical folds: |Theta| in [{a.min():.3f}, {a.max():.3f}]")
        for label in ("66", "1B"):
            if label in catalogue.names:
                i = catalogue.names.index(label)
                print(f"  Theta({label}) = {slope[i]:.3f}")


if __name__ == "__main__":
    main()
