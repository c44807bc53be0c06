"""``biplan reproduce --quick``: every promised file, a computed verdict for every claim.

The end-to-end run uses the layouts the rest of the suite compiles (the six-module
semi-bistable and the four-module fully bistable tubes; design-map chunks of 4). The claim
functions are also checked on hand-made results: a paper-like input must give ``reproduced``
and a contrary one ``not`` — so no verdict is a constant — and their source must derive every
verdict through ``grade``/``grade_distance`` (AST check).
"""

from __future__ import annotations

import ast
import inspect
import re
import textwrap
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from biplan.cli.main import main
from biplan.reproduction.claims import CLAIMS
from biplan.reproduction.facts import (
    CalibrationFacts,
    MovieFacts,
    Results,
    SemiBistableFacts,
    StateFacts,
    ValidationFacts,
)
from biplan.reproduction.figures import FIGURE_FILES
from biplan.reproduction.grading import Grade, grade, grade_distance
from biplan.reproduction.report import assess

DATA_FILES = (
    "REPRODUCTION.md",
    "semi_sweep.csv",
    "semi_sweep.nc",
    "validation.csv",
    "design_map/map.nc",
    "stability_map/map.nc",
    "states/states.csv",
    "states/transitions.graphml",
    "states/hierarchy.nc",
    "cft_calibration.csv",
    "ramp.nc",
    "explorer.html",
    "explorer_design_map.html",
    "explorer_ramp.html",
)
PNG = b"\x89PNG\r\n\x1a\n"


# --- the end-to-end quick run ----------------------------------------------------------------
@pytest.fixture(scope="module")
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("reproduce")
    with pytest.raises(SystemExit) as exc:
        main(["reproduce", "--quick", "--quiet", "--out", str(out)])
    assert exc.value.code in (0, None)
    return out


@pytest.mark.slow
def test_quick_run_writes_every_promised_file(quick_run: Path) -> None:
    errors = quick_run / "errors.log"
    assert not errors.exists(), errors.read_text()
    for name in DATA_FILES:
        assert (quick_run / name).stat().st_size > 0, name
    for files in FIGURE_FILES.values():
        for name in files:
            if name.startswith("movie_S1"):
                movies = list(quick_run.glob("movie_S1.*"))
                assert movies and movies[0].stat().st_size > 0
            else:
                assert (quick_run / name).read_bytes()[:8] == PNG, name


@pytest.mark.slow
def test_quick_report_has_a_verdict_for_every_claim(quick_run: Path) -> None:
    text = (quick_run / "REPRODUCTION.md").read_text()
    for claim in CLAIMS:
        row = [line for line in text.splitlines() if line.startswith(f"| `{claim.id}` |")]
        assert len(row) == 1, claim.id
        verdict = re.search(r"\*\*(reproduced|partly|not)\*\*", row[0])
        assert verdict, row[0]
        assert "stage failed" not in row[0], row[0]
    for files in FIGURE_FILES.values():  # figures are linked
        for name in files:
            if not name.startswith("movie"):
                assert f"]({name})" in text
    assert "## Stages" in text and "failed:" not in text


# --- verdicts are computed -------------------------------------------------------------------
def _semi(good: bool) -> SemiBistableFacts:
    n = 30
    u = np.linspace(0.3, 9.0, n)
    spinodal = np.zeros((n, 6))
    if good:  # phase 1 to 1.5 N, one snap, phase 2 rising; bending in phase 1 and the snap
        spinodal[9] = [0.3, 0.6, 0.6, 0.6, 0.6, 0.6]  # every fold softening before the snap
        force = np.r_[np.linspace(0.1, 1.5, 10), np.linspace(0.5, 2.0, n - 10)]
        stable = np.ones(n, dtype=bool)
        switched = np.zeros(n, dtype=bool)
        switched[10] = True
        u_r = np.r_[-0.02 * force[:10], -3.0, -0.5 * np.ones(n - 11)]
        theta = np.r_[-0.02 * force[:10], -0.5, -0.05 * np.ones(n - 11)]
        b = 0.58
    else:  # no regular phase 1, no snap, no bending
        force = np.linspace(0.1, 3.0, n)
        stable = np.zeros(n, dtype=bool)
        switched = np.zeros(n, dtype=bool)
        u_r = theta = np.zeros(n)
        b = 0.8
    return SemiBistableFacts(
        b, 1.444, 21.6, u, force, u.copy(), u_r, theta, stable, switched, spinodal
    )


def _design_map(good: bool) -> xr.Dataset:
    b, c = [0.45, 0.58, 0.7], [0.5, 1.5, 3.0]
    i, j = np.meshgrid(np.arange(3), np.arange(3), indexing="ij")
    mag = np.array([[9.0, 6.0, 5.0], [7.0, 4.0, 1.0], [8.0, 5.0, 3.0]])
    if good:
        u_z, u_r = 1.0 - 0.2 * i - 0.1 * j, -0.01 * mag
    else:
        u_z, u_r = 0.2 * i + 0.1 * j, -0.01 * mag[::-1, ::-1].T[::-1]
        b, c = [0.65, 0.7, 0.75], [2.0, 3.0, 4.0]
    return xr.Dataset({"u_z": (("b", "C"), u_z), "u_r": (("b", "C"), u_r)}, coords={"b": b, "C": c})


def _instability_map(good: bool) -> xr.Dataset:
    """F* over (b, C): low where the paper puts the transformation (low b, low C) when good,
    everywhere above the ramp otherwise (one design failed: NaN)."""
    b, c = [0.45, 0.58, 0.7], [0.05, 0.4, 3.0]
    force = np.array([[1.2, 1.5, 1.9], [1.4, 1.7, 2.1], [1.55, 1.9, 2.2]])
    if not good:
        force = force + 1.0
        force[0, 0] = np.nan
    return xr.Dataset({"force": (("b", "C"), force)}, coords={"b": b, "C": c})


def _stability_map(good: bool) -> xr.Dataset:
    regime = np.array([[1, 2, 3], [1, 3, 2], [1, 1, 2]] if good else [[1, 1, 1]] * 2 + [[3, 1, 1]])
    band = np.zeros((3, 3), dtype=np.int8)
    band[1, 1] = int(good)
    dims = ("C", "displacement")
    return xr.Dataset(
        {"regime": (dims, regime), "transition": (dims, band)},
        coords={"C": [0.5, 1.5, 3.0], "displacement": [0.01, 0.05, 0.1]},
    )


def _states(good: bool) -> StateFacts:
    pathways: dict[str, tuple[str, ...] | None]
    if good:
        labels = ("00", "2A", "1B", "66", *(f"{k:02X}" for k in range(0x70, 0x70 + 30)))
        u_z, u_r = np.full(34, 0.5), np.full(34, 0.0)
        u_z[[2, 3]], u_r[[2, 3]] = 0.9, (0.4, 0.2)
        theta = np.full(34, 1 / 3)
        theta[[2, 3]] = 2 / 3
        circ = np.zeros(34, dtype=int)
        pathways = {"p1": ("2A", "66"), "p2": ("2A", "1B"), "p3": ("66", "00")}
        theta_counts = np.array([0, 0, 1, 3, 20, 8, 2])
        u_z_counts = np.array([1, 5, 2, 0, 3, 6, 1])
        u_r_counts = np.array([12, 3, 2, 6, 4, 2, 1, 0])
        branches, branch_theta = np.arange(4), np.array([0.0, 1 / 3, 2 / 3, 1.0])
        rms = np.array([0.1, 0.2, 0.3, 0.4])
    else:
        labels = ("01", "02", "03", "04", "05")
        u_z, u_r, theta = np.full(5, 0.5), np.full(5, 0.7), np.zeros(5)
        circ = np.zeros(5, dtype=int)
        pathways = {"p1": None, "p2": None, "p3": None}
        theta_counts = np.array([0, 0, 0, 5, 0, 0, 0])
        u_z_counts = np.zeros(7, dtype=int)
        u_r_counts = np.array([0, 0, 0, 0, 0, 0, 0, 5])
        branches, branch_theta, rms = np.arange(2), np.array([0.0, 0.5]), np.array([0.2, 0.1])
    n = len(labels)
    return StateFacts(
        n_seeds=128,
        labels=labels,
        u_z=u_z,
        u_r=u_r,
        Theta=theta,
        n_open_helical=np.ones(n, dtype=int),
        n_open_circular=circ,
        theta_bins=np.arange(-3, 4) / 3,
        theta_counts=theta_counts,
        u_z_bins=np.linspace(0.0, 1.2, 7),
        u_z_counts=u_z_counts,
        u_r_bins=np.linspace(0.0, 0.7, 8),
        u_r_counts=u_r_counts,
        branches=branches,
        branch_theta=branch_theta,
        branch_rms_u_z=rms,
        branch_rms_u_r=rms,
        pathways=pathways,
    )


def _results(good: bool) -> Results:
    truth = {"k1": 0.9, "k2": -0.2, "k3": 0.6}
    est = {k: ((v if good else 2 * v), np.nan, np.nan) for k, v in truth.items()}
    return Results(
        semi=_semi(good),
        design_map=_design_map(good),
        instability_map=_instability_map(good),
        stability_map=_stability_map(good),
        validation=ValidationFacts(0.02, 0.1 if good else 0.9, 50, not good, "test"),
        states=_states(good),
        calibration=(
            CalibrationFacts("trilinear", est, truth, 0.02 if good else 1.0, 0.02, not good),
        ),
        movie=MovieFacts("movie_S1.gif", 20 if good else 2, good, 1.6),
    )


@pytest.mark.parametrize("claim", CLAIMS, ids=[c.id for c in CLAIMS])
def test_verdict_follows_the_results(claim) -> None:
    good = assess(_results(True), [claim])[0].finding
    bad = assess(_results(False), [claim])[0].finding
    assert good.verdict is Grade.REPRODUCED, (good.value, good.reason)
    assert bad.verdict is Grade.NOT, (bad.value, bad.reason)


@pytest.mark.parametrize("claim", CLAIMS, ids=[c.id for c in CLAIMS])
def test_no_verdict_is_typed(claim) -> None:
    """Every verdict comes out of ``grade``/``grade_distance``; no literal verdict."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(claim.check)))
    literals = {v.value for v in Grade}
    calls = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
            assert node.value.id != "Grade", f"{claim.id}: Grade.{node.attr}"
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            assert node.value not in literals, f"{claim.id}: literal {node.value!r}"
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            calls.add(node.func.id)
    assert calls & {"grade", "grade_distance"}, claim.id


def test_distributed_onset_with_serrated_completion_is_partly() -> None:
    """The model's picture (docs/fidelity.md): every fold softening before the first snap,
    then one snap per fold — half of the claim. Without the onset data, or with only one fold
    softening, neither half holds."""
    from dataclasses import replace

    claim = next(c for c in CLAIMS if c.id == "fig3.distributed")
    semi = _semi(True)
    switched = semi.switched.copy()
    switched[[14, 18, 22]] = True  # four snaps
    results = _results(True)
    results.semi = replace(semi, switched=switched)
    found = assess(results, [claim])[0].finding
    assert found.verdict is Grade.PARTLY and "6 of 6" in found.value, found
    one = semi.spinodal.copy()
    one[9, 1:] = 0.0
    results.semi = replace(semi, switched=switched, spinodal=one)
    assert assess(results, [claim])[0].finding.verdict is Grade.NOT
    results.semi = replace(semi, switched=switched, spinodal=None)
    assert assess(results, [claim])[0].finding.verdict is Grade.NOT
    # a short tube: the folds soften together and transform without a snap
    force = np.r_[np.linspace(0.1, 1.5, 10), np.linspace(1.4, 0.2, 10), np.linspace(0.3, 2, 10)]
    calm = np.zeros(semi.force.size, dtype=bool)
    results.semi = replace(semi, force=force, switched=calm)
    assert assess(results, [claim])[0].finding.verdict is Grade.REPRODUCED


def test_within_ramp_reports_where_the_instability_map_transforms_within_the_ramp() -> None:
    """The map's part of the reason: how many designs have F* ≤ 1.6 N, the lowest F* and the
    largest C among them, computed from the map (a failed design, NaN, is not counted)."""
    claim = next(c for c in CLAIMS if c.id == "fig3.A2.within_ramp")
    good = assess(_results(True), [claim])[0].finding.reason
    assert "F* ≤ 1.6 N at 4 of 9 designs" in good
    assert "lowest F* = 1.2 N at b = 0.45, C = 0.05 (all at C ≤ 0.4)" in good
    bad = assess(_results(False), [claim])[0].finding.reason
    assert "F* ≤ 1.6 N at 0 of 9 designs" in bad and "lowest F* = 2.4 N at b = 0.58" in bad
    no_map = replace(_results(True), instability_map=None)
    assert "map" not in assess(no_map, [claim])[0].finding.reason


def test_failed_stage_is_reported_not_computed() -> None:
    results = _results(True)
    results.states = None
    results.errors["states"] = "ConvergenceError: boom"
    out = {a.claim.id: a.finding for a in assess(results)}
    assert out["fig4.count"].verdict is Grade.NOT
    assert "boom" in out["fig4.count"].reason
    assert out["fig3.A1.extension"].verdict is Grade.REPRODUCED


def test_grading_helpers() -> None:
    assert grade([True, True]) is Grade.REPRODUCED
    assert grade([True, False]) is Grade.PARTLY
    assert grade([False]) is Grade.NOT and grade([]) is Grade.NOT
    assert grade_distance(0.0, 0.0, 1.0) is Grade.REPRODUCED
    assert grade_distance(0.5, 0.0, 1.0) is Grade.PARTLY
    assert grade_distance(2.0, 0.0, 1.0) is Grade.NOT
    assert grade_distance(float("nan"), 0.0, 1.0) is Grade.NOT


def test_tpc_sign_is_checked_before_any_stage(tmp_path: Path, capsys) -> None:
    from biplan.cli.main import EXIT_BIPLAN_ERROR
    from biplan.cli.reproduce import TPC_SIGNS
    from biplan.options import TpcSign

    assert tuple(s.value for s in TpcSign) == TPC_SIGNS
    with pytest.raises(SystemExit) as info:
        main(["reproduce", "--quick", "--tpc-sign", "printed", "--out", str(tmp_path / "r")])
    assert info.value.code == EXIT_BIPLAN_ERROR
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 1 and "--tpc-sign" in lines[0] and "as_printed" in lines[0]
    assert not (tmp_path / "r").exists()
