"""Search of the fully bistable fold laws for the paper's state set (issue "stable states", part 6).

The paper gives no laws for its four-module fully bistable MFT. This script samples helical and
circular trilinear laws in a physically reasonable box (same geometry as SI Table calib; both
laws bistable; the helical open well inside the kinematic lock of the helical folds, MODEL §16)
and enumerates the stable states of each sample with :func:`biplan.analysis.states.search.enumerate_states`.

Score of a sample (lower is better): |n_stable − 34| + 10 × (number of 00, 2A, 1B, 66 not
stable). The box and the sample count are the only inputs; nothing is tuned to a figure.

Usage::

    .venv/bin/python benchmarks/fully_bistable_search.py --samples 80 --out out/search.csv
    .venv/bin/python benchmarks/fully_bistable_search.py --around 0.25 --samples 60 \
        --out out/search_local.csv

The second form is the local stage: log-normal perturbations (σ = 0.25) of every coefficient
of the provisional laws.

Prints the best samples and writes every sample (laws, count, key states, score) to CSV.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

import biplan
from biplan.analysis.states.search import enumerate_states
from biplan.designs import SEMI_BISTABLE_TABLE

KEY_STATES = ("00", "2A", "1B", "66")
TARGET = 34

#: Sampling box: (k1, k2, k3) [N/mm²], (w1, w2) [mm] per fold set.
BOX = {
    "helical": {
        "k1": (0.5, 3.0),
        "k2": (-3.0, -0.3),
        "k3": (0.3, 2.0),
        "w1": (0.02, 0.3),
        "dw": (0.1, 0.4),
    },
    "circular": {
        "k1": (0.3, 1.5),
        "k2": (-1.0, -0.1),
        "k3": (0.3, 1.5),
        "w1": (0.1, 1.0),
        "dw": (0.3, 1.2),
    },
}
#: Largest helical open well (mean elongation) [mm]: inside the kinematic lock (MODEL §16).
HELICAL_WELL_MAX = 0.8


def sample_law(rng: np.random.Generator, box: dict) -> biplan.TrilinearLaw | None:
    v = {k: rng.uniform(*r) for k, r in box.items()}
    law = biplan.TrilinearLaw(
        stiffness=(v["k1"], v["k2"], v["k3"]), transitions=(v["w1"], v["w1"] + v["dw"])
    )
    return law if law.is_bistable else None


def perturb_law(
    rng: np.random.Generator, law: biplan.TrilinearLaw, spread: float
) -> biplan.TrilinearLaw | None:
    """A log-normal perturbation (σ = ``spread``) of every coefficient of a law."""
    k = np.asarray(law.stiffness) * np.exp(rng.normal(0.0, spread, 3))
    w1, w2 = np.asarray(law.transitions) * np.exp(rng.normal(0.0, spread, 2))
    if w2 <= w1:
        return None
    new = biplan.TrilinearLaw(stiffness=tuple(float(x) for x in k), transitions=(w1, w2))
    return new if new.is_bistable else None


def tube_of(helical: biplan.TrilinearLaw, circular: biplan.TrilinearLaw) -> biplan.Tube:
    t = SEMI_BISTABLE_TABLE
    return biplan.Tube.uniform(
        radius=t.radius,
        pitch=t.pitch,
        helical_angle=t.helical_angle,
        n_modules=4,
        helical=helical,
        circular=circular,
        base_fold=False,
    )


def evaluate(helical: biplan.TrilinearLaw, circular: biplan.TrilinearLaw) -> dict:
    cat = enumerate_states(biplan.Model(tube_of(helical, circular)))
    labels = {s.label for s in cat.states}
    missing = [k for k in KEY_STATES if k not in labels]
    return {
        "helical": helical.stiffness + helical.transitions,
        "circular": circular.stiffness + circular.transitions,
        "n_stable": len(cat),
        "distinct_labels": len(labels),
        "missing": " ".join(missing),
        "score": abs(len(cat) - TARGET) + 10 * len(missing),
        "labels": " ".join(sorted(labels)),
        "seconds": cat.elapsed,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--seed", type=int, default=20261130)
    parser.add_argument("--out", type=Path, default=Path("out/fully_bistable_search.csv"))
    parser.add_argument(
        "--around",
        type=float,
        default=0.0,
        help="local stage: perturb the provisional laws log-normally with this σ (0: box search)",
    )
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    rows = []
    args.out.parent.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    provisional = biplan.designs.fully_bistable()
    rows.append(evaluate(provisional.helical_laws[0], provisional.circular_laws[0]))
    print("provisional:", rows[0]["n_stable"], "states, missing", rows[0]["missing"] or "none")
    while len(rows) < args.samples + 1:
        if args.around > 0:
            helical = perturb_law(rng, provisional.helical_laws[0], args.around)
            circular = perturb_law(rng, provisional.circular_laws[0], args.around)
        else:
            helical = sample_law(rng, BOX["helical"])
            circular = sample_law(rng, BOX["circular"])
        if helical is None or circular is None or helical.wells()[-1] > HELICAL_WELL_MAX:
            continue
        rows.append(evaluate(helical, circular))
        r = rows[-1]
        print(
            f"{len(rows) - 1:4d} n={r['n_stable']:3d} missing={r['missing'] or '-':12s} "
            f"score={r['score']:3d} ({time.perf_counter() - start:.0f} s)",
            flush=True,
        )
    with open(args.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    best = sorted(rows[1:], key=lambda r: r["score"])[:5]
    print("\nbest samples (helical k1,k2,k3,w1,w2 | circular k1,k2,k3,w1,w2):")
    for r in best:
        h = ", ".join(f"{x:.3g}" for x in r["helical"])
        c = ", ".join(f"{x:.3g}" for x in r["circular"])
        print(
            f"  n={r['n_stable']:3d} missing={r['missing'] or '-'} score={r['score']} | {h} | {c}"
        )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
