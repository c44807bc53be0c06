"""Measure how well the calibration recovers known laws (the figures of docs/calibration.md).

Run from the repository root (about a minute)::

    python examples/data/recovery.py --seeds 100

For each seed, 10 synthetic specimens are drawn from the true law with the scatter and noise
of ``make_synthetic.py`` (``biplan.calibration.synthetic``), the law is calibrated (bootstrap of
200 resamples, 95 % percentile intervals), and the relative errors and the interval coverage
are collected. Prints Markdown tables: mean and SD of the relative error, largest |error|, and
the fraction of the seeds whose interval covers the truth.
"""

from __future__ import annotations

import argparse

import numpy as np

import biplan
from biplan.calibration.calibrate import (
    Breakpoints,
    CalibrationOptions,
    calibrate_linear,
    calibrate_trilinear,
)
from biplan.calibration.synthetic import Scatter, synthetic_specimens

TRILINEAR = biplan.TrilinearLaw(stiffness=(0.9, -0.2, 0.6), transitions=(0.2, 1.3))
LINEAR = biplan.LinearLaw(stiffness=1.3)
SCATTER = Scatter(stiffness=0.05, transitions=0.04, noise=0.02, jitter=0.3)


def table(title: str, names: list[str], truth: np.ndarray, rows: list[np.ndarray]) -> str:
    """Markdown table of (value, low, high) rows against ``truth``."""
    data = np.asarray(rows)  # (seeds, parameters, 3)
    err = (data[:, :, 0] - truth) / np.abs(truth)
    cover = (data[:, :, 1] <= truth) & (truth <= data[:, :, 2])
    out = [f"**{title}** ({data.shape[0]} seeds)", ""]
    out.append("| | " + " | ".join(names) + " |")
    out.append("|---|" + "---|" * len(names))
    out.append("| truth | " + " | ".join(f"{t:g}" for t in truth) + " |")
    out.append("| mean error | " + " | ".join(f"{e:+.1%}" for e in err.mean(0)) + " |")
    out.append("| SD of error | " + " | ".join(f"{e:.1%}" for e in err.std(0)) + " |")
    out.append("| max abs error | " + " | ".join(f"{e:.1%}" for e in np.abs(err).max(0)) + " |")
    out.append("| 95 % CI coverage | " + " | ".join(f"{c:.0%}" for c in cover.mean(0)) + " |")
    return "\n".join(out) + f"\n\npooled coverage {cover.mean():.1%}\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--bootstrap", type=int, default=200)
    args = parser.parse_args()
    truth = np.array(TRILINEAR.coefficients)
    for mode in Breakpoints:
        rows = []
        for seed in range(args.seeds):
            specs = synthetic_specimens(TRILINEAR, scatter=SCATTER, n_points=(100, 150), seed=seed)
            opts = CalibrationOptions(breakpoints=mode, n_bootstrap=args.bootstrap, seed=seed)
            result = calibrate_trilinear(specs, options=opts)
            rows.append(np.array([(e.value, e.low, e.high) for e in result.estimates]))
        print(
            table(
                f"trilinear, breakpoints {mode.value}", ["k1", "k2", "k3", "l1", "l2"], truth, rows
            )
        )
    rows = []
    for seed in range(args.seeds):
        specs = synthetic_specimens(
            LINEAR, scatter=SCATTER, n_points=(100, 150), extent=0.5, seed=seed
        )
        result = calibrate_linear(specs, options=CalibrationOptions(n_bootstrap=args.bootstrap))
        rows.append(np.array([(e.value, e.low, e.high) for e in result.estimates[:1]]))
    print(table("linear, through the origin", ["k"], np.array([1.3]), rows))


if __name__ == "__main__":
    main()
