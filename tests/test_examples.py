"""Every script in ``examples/`` runs (coarse) and its key numbers make physical sense.

Each example is run in this process (``runpy``) with ``BIPLAN_EXAMPLE_QUICK=1`` and ``--out`` a
temporary directory; its last output line is ``RESULT {json}``. ``CHECKS`` maps the script's
name (without ``.py``) to a function that checks one to three numbers of that JSON against
physics: signs, ranges, closed forms or an independent computation the script also ran. The
printed values are never hard-coded.

To add an example, add ``examples/NN_name.py`` (same conventions) and an entry ``"NN_name"``
here; a script without an entry fails :func:`test_example`.

Runtime: the examples share the session's compiled kernels (the semi-bistable layout of
``model6``); the path-following and dynamics examples dominate. The tests are marked ``slow``
(informational: the suite runs them).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import runpy
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("[0-9][0-9]_*.py"))

#: Geometry and laws of the semi-bistable design (SI Table calib), from the paper, not the code.
RADIUS, PITCH, BETA_DEG, N_MODULES = 2.0, 3.6, 60.0, 6
K1_CIRC, W1_CIRC, K_HELIC = 0.9, 0.2, 1.3
#: Circumference H = 2πR [mm]: the length of every circular fold field.
CIRCUMFERENCE = 2 * math.pi * RADIUS
#: End force [N] at which a uniformly opened circular fold reaches its peak line force k1 w1.
FOLD_PEAK_FORCE = CIRCUMFERENCE * K1_CIRC * W1_CIRC

Result = dict[str, Any]


def _first_tube(r: Result) -> None:
    # b = (l / cos β) / (2πR) from the printed geometry; C = k_helic / k1_circ.
    beta = math.radians(r["helical_angle"])
    b = (r["pitch"] / math.cos(beta)) / (2 * math.pi * r["radius"])
    assert r["b"] == pytest.approx(b, rel=1e-12)
    assert r["C"] == pytest.approx(K_HELIC / K1_CIRC, rel=1e-12)
    # Phase 1 at U = 1 mm: a converged, stable, tensile state below the folds' peak force.
    assert r["converged"] and r["stable"]
    assert 0.0 < r["force"] < FOLD_PEAK_FORCE


def _force_response(r: Result) -> None:
    assert r["status"] == "COMPLETED"
    assert r["initial_stiffness"] > 0.0
    # The first event is where the six circular folds stop opening together: close to the end
    # force at which a fold's line force peaks (k1 w1 over the circumference).
    assert 0.85 * FOLD_PEAK_FORCE < r["first_event_force"] < 1.05 * FOLD_PEAK_FORCE
    assert r["first_event_force"] == pytest.approx(r["peak_force"], rel=0.05)


def _dynamics(r: Result) -> None:
    assert r["status"] == "COMPLETED"
    # The ramp is 0.8 N/s; it is slow against the first natural period (~1 ms), so the end
    # state is the quasi-static equilibrium at the final force (independent Newton solve).
    assert r["final_force"] == pytest.approx(0.8 * r["final_time"], rel=1e-9)
    assert r["final_displacement"] == pytest.approx(r["static_displacement"], rel=0.02)
    # Energy balance T + Π − W + D is kept up to the scheme's numerical dissipation.
    assert r["energy_drift"] < 0.05 * r["external_work"]


def _pressure(r: Result) -> None:
    assert r["status"] == "COMPLETED"
    # Internal pressure acts as the end force p πR² ...
    assert r["end_area"] == pytest.approx(math.pi * RADIUS**2, rel=1e-12)
    assert r["final_force"] == pytest.approx(r["final_pressure"] * r["end_area"], rel=1e-6)
    # ... so the pressure-controlled state equals the force-controlled one at that force.
    assert r["final_displacement"] > 0.0
    assert r["final_displacement"] == pytest.approx(r["force_control_displacement"], abs=1e-5)


def _calibration(r: Result) -> None:
    # The synthetic specimens were made from k = (0.9, −0.2, 0.6) N/mm², w = (0.2, 1.3) mm and
    # a helical k = 1.3 N/mm² with 5 % specimen scatter (examples/data/README.md).
    assert r["k1"] == pytest.approx(K1_CIRC, rel=0.1)
    assert r["k1_low"] <= r["k1"] <= r["k1_high"]
    assert r["k2"] < 0.0 and r["circular_bistable"]
    assert r["helical_k"] == pytest.approx(K_HELIC, rel=0.1)


def _paraview(r: Result) -> None:
    assert r["n_vtu"] == r["n_states"] >= 2
    # The wrap onto the cylinder is isometric: every exported point lies at radius R.
    assert r["radius_error"] < 1e-9
    # The free end rose by the prescribed U (its highest point at least that, tilt aside).
    rise = r["z_max"] - N_MODULES * PITCH
    assert r["final_displacement"] - 1e-6 <= rise <= r["final_displacement"] + 1.0


def _custom_architecture(r: Result) -> None:
    assert r["round_trip"]
    # Symmetry broken by the weak fold: it opens first, and it caps the force near its own
    # peak line force over the circumference (below the uniform folds' peak).
    assert r["first_open_fold"] == r["weak_fold"]
    weak_peak = r["fold_length"] * r["weak_peak_line_force"]
    assert 0.8 * weak_peak < r["peak_force"] < 1.05 * weak_peak < FOLD_PEAK_FORCE


CHECKS: dict[str, Callable[[Result], None]] = {
    "01_first_tube": _first_tube,
    "02_force_response": _force_response,
    "03_dynamics": _dynamics,
    "04_pressure": _pressure,
    "05_calibration": _calibration,
    "06_paraview_export": _paraview,
    "07_custom_architecture": _custom_architecture,
}


def run_example(script: Path, out: Path) -> Result:
    """Run one example in quick mode, in this process; return the JSON of its ``RESULT`` line.

    In-process, so that the examples share the compiled kernels of the test session (every
    example uses a layout the suite compiles anyway); a fresh process per script would trace
    and load every kernel again (minutes per script on a 2-core machine).
    """
    buffer = io.StringIO()
    saved_argv, saved_env = sys.argv, os.environ.get("BIPLAN_EXAMPLE_QUICK")
    sys.argv = [str(script), "--out", str(out)]
    os.environ["BIPLAN_EXAMPLE_QUICK"] = "1"
    try:
        with contextlib.redirect_stdout(buffer):
            runpy.run_path(str(script), run_name="__main__")
    except SystemExit as exc:
        assert exc.code in (0, None), f"{script.name} exited with {exc.code}:\n{buffer.getvalue()}"
    finally:
        sys.argv = saved_argv
        if saved_env is None:
            os.environ.pop("BIPLAN_EXAMPLE_QUICK", None)
        else:
            os.environ["BIPLAN_EXAMPLE_QUICK"] = saved_env
        import matplotlib.pyplot as plt

        plt.close("all")
    stdout = buffer.getvalue()
    lines = [ln for ln in stdout.splitlines() if ln.startswith("RESULT ")]
    assert lines, f"{script.name} printed no RESULT line:\n{stdout}"
    assert stdout.rstrip().splitlines()[-1] == lines[-1], "RESULT must be the last line"
    return json.loads(lines[-1].removeprefix("RESULT "))


def test_examples_exist() -> None:
    assert EXAMPLES, "no examples/NN_*.py scripts found"


def test_no_stale_checks() -> None:
    """Every check belongs to an existing script (a renamed script must rename its check)."""
    assert set(CHECKS) <= {s.stem for s in EXAMPLES}


@pytest.mark.slow
@pytest.mark.parametrize("script", EXAMPLES, ids=[s.stem for s in EXAMPLES])
def test_example(script: Path, tmp_path: Path) -> None:
    check = CHECKS.get(script.stem)
    if check is None:
        pytest.fail(f"examples/{script.name} has no entry in CHECKS of tests/test_examples.py")
    result = run_example(script, tmp_path / script.stem)
    assert any((tmp_path / script.stem).iterdir()), "the example wrote nothing into --out"
    check(result)
