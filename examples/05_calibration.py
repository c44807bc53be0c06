"""Calibration from data: fit the fold laws to Circular Folded Tube specimen curves.

Reads the synthetic specimen folders of ``examples/data`` (ten trilinear CFTs with force
columns, ten linear CFTs with pressure columns; their true laws are known), fits a trilinear
circular law and a linear helical law with bootstrap confidence intervals, writes both as
``[laws.*]`` blocks of a tube configuration, and builds the semi-bistable tube from them.
Quick mode uses 20 bootstrap resamples instead of 200. Writes ``circular.toml``,
``helical.toml``, ``calibrated_tube.toml`` and, in full mode, ``circular.png``.

    python examples/05_calibration.py --out out/examples/05_calibration
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

from biplan.calibration.calibrate import (
    CalibrationOptions,
    calibrate_linear,
    calibrate_trilinear,
)
from biplan.calibration.files import read_specimens
from biplan.calibration.fits import CftGeometry
from biplan.calibration.law_blocks import calibration_toml
from biplan.io.config import load_config_text

QUICK = os.environ.get("BIPLAN_EXAMPLE_QUICK") == "1"
DATA = Path(__file__).resolve().parent / "data"

GEOMETRY = """\
name = "semi-bistable MFT, calibrated"
[geometry]
radius = 2.0
pitch = 3.6
helical_angle = 60.0
n_modules = 6
base_fold = true
"""


def main(out: Path) -> dict[str, float | bool]:
    out.mkdir(parents=True, exist_ok=True)
    geometry = CftGeometry(radius=2.0, n_folds=1)  # R [mm]; one circular fold per specimen
    options = CalibrationOptions(n_bootstrap=20 if QUICK else 200, seed=0)
    circular = calibrate_trilinear(read_specimens(DATA / "cft_trilinear"), geometry, options)
    # The linear specimens record pressure [kPa]; the radius converts it to end force p πR².
    helical = calibrate_linear(read_specimens(DATA / "cft_linear", radius=2.0), geometry, options)
    circular_toml = calibration_toml(circular, "circular")
    helical_toml = calibration_toml(helical, "helical")
    (out / "circular.toml").write_text(circular_toml, encoding="utf-8")
    (out / "helical.toml").write_text(helical_toml, encoding="utf-8")
    config = GEOMETRY + "\n" + helical_toml + "\n" + circular_toml
    (out / "calibrated_tube.toml").write_text(config, encoding="utf-8")
    tube = load_config_text(config, "calibrated_tube.toml")
    if not QUICK:
        import matplotlib

        matplotlib.use("Agg")
        from biplan.plot.calibration import calibration_band

        ax = calibration_band(circular)
        ax.figure.savefig(out / "circular.png", dpi=150)
    for cal in (circular, helical):
        for e in cal.estimates:
            print(f"{e.name:>6} = {e.value:8.4f} {e.unit:6} [{e.low:.4f}, {e.high:.4f}]")
    print(f"calibrated tube: b = {tube.b:.3f}, C = {tube.C:.3f}")
    k1 = circular.estimate("k1")
    return {
        "k1": k1.value,
        "k1_low": k1.low,
        "k1_high": k1.high,
        "k2": circular.estimate("k2").value,
        "k3": circular.estimate("k3").value,
        "w1": circular.estimate("l1").value,
        "w2": circular.estimate("l2").value,
        "circular_bistable": circular.law.is_bistable,
        "helical_k": helical.estimate("k").value,
        "C": tube.C,
    }


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/examples/05_calibration"))
    result = main(parser.parse_args().out)
    print("RESULT " + json.dumps(result))
