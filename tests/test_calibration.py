"""Calibration of fold laws from specimen curves: data checks, statistics, fits, bootstrap.

Synthetic specimens come from known laws with specimen-to-specimen scatter and noise
(:mod:`biplan.calibration.synthetic`: 10 specimens, 5 % log-normal scatter of the stiffnesses, 4 %
of the breakpoints, 0.02 N force noise, 100–150 samples per segment). Stated tolerances
(relative, per fit, about 3 SD of the spread over 100 seeds in docs/calibration.md): k1 6 %,
k2 15 %, k3 12 %, l1 6 %, l2 5 %.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np
import pytest
from scipy.optimize import minimize

import biplan
from biplan.calibration.band import band_statistics
from biplan.calibration.calibrate import (
    Breakpoints,
    CalibrationOptions,
    CaveatKind,
    calibrate_linear,
    calibrate_trilinear,
    force_drop,
)
from biplan.calibration.files import (
    DataError,
    SpecimenFormat,
    read_specimen,
    read_specimens,
)
from biplan.calibration.fits import CftGeometry, cft_force, fit_linear, fit_trilinear
from biplan.calibration.law_blocks import calibration_toml
from biplan.calibration.specimens import Segment, Specimen, segment_problem
from biplan.calibration.synthetic import Scatter, synthetic_specimens
from biplan.calibration.validation import compare_to_band
from biplan.io.config import load_config_text
from biplan.plot import calibration_band, validation_band

TRUTH = biplan.TrilinearLaw(stiffness=(0.9, -0.2, 0.6), transitions=(0.2, 1.3))
TRUTH_VALUES = np.array(TRUTH.coefficients)
NAMES = ("k1", "k2", "k3", "l1", "l2")
TOLERANCE = np.array([0.06, 0.15, 0.12, 0.06, 0.05])
LINEAR = biplan.LinearLaw(1.3)
NO_SCATTER = Scatter(stiffness=0.0, transitions=0.0, noise=0.0, jitter=0.3)


def specimens(seed: int = 0, **kwargs):
    return synthetic_specimens(TRUTH, n_points=(100, 150), seed=seed, **kwargs)


# --- fits at the array level --------------------------------------------------------------
def test_geometry_conversion_is_inverse_and_checked() -> None:
    geo = CftGeometry(radius=1.5, n_folds=3)
    assert geo.fold_length == pytest.approx(2 * math.pi * 1.5)
    assert geo.end_area == pytest.approx(math.pi * 1.5**2)
    u, f = np.linspace(0, 2, 7), np.linspace(-1, 3, 7)
    np.testing.assert_allclose(geo.to_specimen(*geo.to_field(u, f)), (u, f))
    for bad in ({"radius": 0.0}, {"radius": float("nan")}, {"n_folds": 0}, {"n_folds": 1.5}):
        with pytest.raises(biplan.ConfigError):
            CftGeometry(**bad)


def test_fitted_values_are_the_laws_force() -> None:
    """The fit's piecewise-linear basis is the law's force (JAX kernel) mapped to the specimen."""
    geo = CftGeometry(radius=1.7, n_folds=2)
    u = np.linspace(0.0, 3.4, 300)
    expected = geo.fold_length * np.asarray(TRUTH.force(u / geo.n_folds))
    np.testing.assert_allclose(cft_force(TRUTH, geo, u), expected, rtol=1e-12, atol=1e-12)
    fit = fit_trilinear(u, expected, geo, breakpoints=(0.4, 2.6))
    law_force = geo.fold_length * np.asarray(fit.law.force(u / geo.n_folds))
    np.testing.assert_allclose(fit.fitted, law_force, rtol=1e-12, atol=1e-12)
    w = np.linspace(-0.1, 0.6, 9)  # linear laws, negative elongations included
    np.testing.assert_allclose(cft_force(LINEAR, geo, w * 2), geo.fold_length * 1.3 * w)


@pytest.mark.parametrize("free", [False, True])
def test_exact_trilinear_curve_is_recovered(free: bool) -> None:
    geo = CftGeometry(radius=2.5, n_folds=2)
    u = np.linspace(0.0, 3.2, 401)
    force = cft_force(TRUTH, geo, u)
    if free:
        fit = fit_trilinear(u, force, geo)
    else:
        fit = fit_trilinear(u, force, geo, breakpoints=(0.4, 2.6))
    np.testing.assert_allclose(fit.parameters, TRUTH_VALUES, rtol=1e-6)
    assert fit.rms < 1e-9
    assert isinstance(fit.law, biplan.TrilinearLaw) and fit.law.is_bistable


def test_trilinear_fit_keeps_signs_and_order() -> None:
    """Data without negative stiffness still give k1 > 0, k2 < 0, k3 > 0, 0 < w1 < w2."""
    u = np.linspace(0.0, 2.0, 50)
    fit = fit_trilinear(u, 3.0 * u)
    k1, k2, k3, w1, w2 = fit.parameters
    assert k1 > 0 > k2 and k3 > 0 and 0 < w1 < w2


def test_linear_fit_through_origin_and_with_offset() -> None:
    geo = CftGeometry()
    u = np.linspace(0.0, 0.5, 40)
    force = cft_force(LINEAR, geo, u) + 0.3
    through = fit_linear(u, force, geo)
    free = fit_linear(u, force, geo, offset=True)
    assert free.law.stiffness == pytest.approx(1.3, rel=1e-10)
    assert free.offset * geo.fold_length == pytest.approx(0.3, rel=1e-10)
    assert through.offset == 0.0 and through.law.stiffness > 1.3  # the offset tilts the line
    assert free.rms < 1e-12 < through.rms


# --- statistics ---------------------------------------------------------------------------
def test_segment_checks() -> None:
    u = np.array([0.0, 0.1, 0.2, 0.15, 0.3])
    problem = segment_problem(u, np.ones(5))
    assert problem is not None and problem.index == 3 and problem.quantity == "displacement"
    assert "non-monotonic" in problem.valid
    problem = segment_problem(np.arange(3.0), np.ones(3), min_points=5)
    assert problem is not None and problem.quantity == "points"
    problem = segment_problem(np.arange(6.0), np.array([0, 1, np.nan, 2, 3, 4.0]))
    assert problem is not None and problem.index == 2 and problem.quantity == "force"
    seg = Segment(np.array([3.0, 2.0, 1.0]), np.array([30.0, 20.0, 10.0]), "2")
    np.testing.assert_array_equal(seg.displacement, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(seg.force, [10.0, 20.0, 30.0])
    with pytest.raises(biplan.ConfigError, match="overlap"):
        Specimen("s", (Segment([0, 1, 2], [0, 1, 2], "1"), Segment([1.5, 3], [0, 1], "2")))


def test_band_handles_specimens_stopping_at_different_displacements() -> None:
    specs = [
        Specimen(f"s{i}", (Segment(np.linspace(0, end, 30), k * np.linspace(0, end, 30)),))
        for i, (end, k) in enumerate([(1.0, 1.0), (2.0, 2.0), (3.0, 3.0), (4.0, 4.0)])
    ]
    band = band_statistics(specs, points_per_phase=41, min_coverage=0.5)
    u = band.displacement
    ends = np.array([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(band.count, [(ends >= x - 1e-12).sum() for x in u])
    assert band.min_count == 2
    full = u <= 1.0
    slopes = np.array([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(band.median[full], np.median(slopes) * u[full], atol=1e-12)
    np.testing.assert_allclose(band.std[full], np.std(slopes, ddof=1) * u[full], atol=1e-12)
    assert np.all(np.isnan(band.median[u > 3.0 + 1e-12]))  # fewer than half the specimens
    late = (u > 2.0 + 1e-12) & (u <= 3.0)
    np.testing.assert_allclose(band.median[late], 3.5 * u[late])  # the two still measured
    np.testing.assert_allclose(band.limits[0, 1], (2.5, np.median([1.0, 4.0, 9.0, 16.0])))
    sub = band.subset([3, 3, 3, 3])
    np.testing.assert_allclose(sub.median[np.isfinite(sub.median)], 4.0 * u[u <= 4.0 + 1e-12])


def test_fit_curve_interpolates_the_spinodal() -> None:
    band = band_statistics(specimens(seed=3), points_per_phase=40)
    u, f, measured = band.fit_curve(gap_points=25)
    (ua, fa), (ub, fb) = band.limits[0, 1], band.limits[1, 0]
    gap = ~measured
    assert gap.sum() == 25 and np.all(np.diff(u) >= 0)
    np.testing.assert_allclose(f[gap], fa + (fb - fa) * (u[gap] - ua) / (ub - ua))
    assert np.all((u[measured] <= ua + 1e-12) | (u[measured] >= ub - 1e-12))


# --- calibration: recovery, bootstrap, round trip -----------------------------------------
@pytest.mark.parametrize("breakpoints", list(Breakpoints))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_trilinear_calibration_recovers_the_law(seed: int, breakpoints: Breakpoints) -> None:
    options = CalibrationOptions(breakpoints=breakpoints, n_bootstrap=0)
    result = calibrate_trilinear(specimens(seed), options=options)
    error = np.abs(result.fit.parameters - TRUTH_VALUES) / np.abs(TRUTH_VALUES)
    assert np.all(error < TOLERANCE), dict(zip(NAMES, error.round(4), strict=True))
    assert result.law.is_bistable
    assert result.fit.rms < 0.05  # N, a few times the 0.02 N noise


def test_noise_free_calibration_is_tight() -> None:
    result = calibrate_trilinear(
        specimens(0, scatter=NO_SCATTER), options=CalibrationOptions(n_bootstrap=0)
    )
    np.testing.assert_allclose(result.fit.parameters, TRUTH_VALUES, rtol=0.015)
    np.testing.assert_allclose(result.fit.parameters[[0, 2]], TRUTH_VALUES[[0, 2]], rtol=1e-9)


def test_bootstrap_intervals_cover_the_truth_at_about_the_nominal_rate() -> None:
    """Percentile intervals (95 %) over 40 seeds × 5 parameters: pooled coverage in [0.85, 1]."""
    hits = []
    for seed in range(40):
        options = CalibrationOptions(n_bootstrap=100, seed=seed, confidence=0.95)
        result = calibrate_trilinear(specimens(100 + seed), options=options)
        assert result.n_failed == 0 and result.samples.shape == (100, 5)
        hits.append([e.covers(t) for e, t in zip(result.estimates, TRUTH_VALUES, strict=True)])
        assert all(e.low <= e.value <= e.high for e in result.estimates[:3])
    coverage = np.mean(hits)
    assert 0.85 <= coverage <= 1.0, np.mean(hits, axis=0)
    assert np.all(np.mean(hits, axis=0) >= 0.75), np.mean(hits, axis=0)


def test_bootstrap_is_seeded() -> None:
    specs = specimens(5)
    a = calibrate_trilinear(specs, options=CalibrationOptions(n_bootstrap=15, seed=4))
    b = calibrate_trilinear(specs, options=CalibrationOptions(n_bootstrap=15, seed=4))
    np.testing.assert_array_equal(a.samples, b.samples)


def test_linear_calibration_recovers_the_law() -> None:
    specs = synthetic_specimens(LINEAR, extent=0.5, n_points=(100, 150), seed=2)
    result = calibrate_linear(specs, options=CalibrationOptions(n_bootstrap=40))
    k = result.estimate("k")
    assert k.value == pytest.approx(1.3, rel=0.05) and k.low < k.value < k.high
    with_offset = calibrate_linear(specs, options=CalibrationOptions(offset=True, n_bootstrap=40))
    offset = with_offset.estimate("offset")
    assert offset.covers(0.0) and abs(offset.value) < 0.01  # N/mm
    with pytest.raises(biplan.ConfigError, match="two phases"):
        calibrate_trilinear(specs)


# --- caveats: statistics that mean little --------------------------------------------------
EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "data"


@pytest.mark.parametrize(
    ("folder", "kind", "expected"),
    [
        ("cft_linear", "linear", set()),
        ("cft_trilinear", "trilinear", set()),
        ("cft_trilinear", "linear", {CaveatKind.BISTABLE_DATA, CaveatKind.POOR_FIT}),
        ("mft_semi_bistable", "trilinear", set()),
        ("mft_semi_bistable", "linear", {CaveatKind.BISTABLE_DATA, CaveatKind.POOR_FIT}),
    ],
)
def test_a_linear_law_on_bistable_example_data_carries_caveats(
    folder: str, kind: str, expected: set[CaveatKind]
) -> None:
    """The shipped data: a linear law on the trilinear CFT (k = 0.07 N/mm², RMS 1.05 N) or on
    the MFT is flagged; each dataset fitted with its own law is not."""
    specs = read_specimens(EXAMPLES / folder, radius=2.0)
    run = calibrate_linear if kind == "linear" else calibrate_trilinear
    result = run(specs, options=CalibrationOptions(n_bootstrap=0))
    assert {c.kind for c in result.caveats} == expected
    if expected:
        bistable = next(c for c in result.caveats if c.kind is CaveatKind.BISTABLE_DATA)
        assert "bistable" in bistable.message and "trilinear" in bistable.message
        assert "% of its range" in bistable.message
        assert "# warning: the data are bistable" in calibration_toml(result, "helical")
    else:
        assert "warning" not in calibration_toml(result, "circular")


def test_bootstrap_from_few_specimens_carries_a_caveat() -> None:
    specs = read_specimens(EXAMPLES / "cft_linear", radius=2.0)
    one = calibrate_linear(specs[:1], options=CalibrationOptions(n_bootstrap=10))
    assert [c.kind for c in one.caveats] == [CaveatKind.FEW_SPECIMENS]
    assert "single specimen" in one.caveats[0].message
    k = one.estimate("k")
    assert k.low == k.high == pytest.approx(k.value)  # the zero-width interval it warns of
    three = calibrate_linear(specs[:3], options=CalibrationOptions(n_bootstrap=10))
    assert "3 specimens (10 distinct resamples" in three.caveats[0].message
    assert not calibrate_linear(specs[:5], options=CalibrationOptions(n_bootstrap=10)).caveats
    assert not calibrate_linear(specs[:1], options=CalibrationOptions(n_bootstrap=0)).caveats


def test_force_drop_is_the_largest_fall_along_displacement() -> None:
    u = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0])
    assert force_drop(u, np.array([0.0, 2.0, 1.0, 1.5, -0.5, 3.0])) == pytest.approx(2.5)
    assert force_drop(u[::-1], np.array([3.0, -0.5, 1.5, 1.0, 2.0, 0.0])) == pytest.approx(2.5)
    assert force_drop(u, u**2) == 0.0
    assert force_drop(u, np.array([0.0, np.nan, 1.0, 0.9, 2.0, 2.0])) == pytest.approx(0.1)


def _simulated_cft_force(law, geo: CftGeometry, u: float, start: float) -> float:
    """End force of n folds in series at extension u, by minimising the total field energy.

    Each fold is a uniform field of length H (``law.field_energy``); the n elongations are
    free subject to Σ w_i = u, starting near ``start`` per fold; F = dΠ*/du by central
    differences. Independent of the fit's own force formula.
    """
    n, h = geo.n_folds, geo.fold_length
    total_energy = jax.jit(lambda w: jnp.sum(law.field_energy(w, w, h)))

    def energy_at(total: float) -> float:
        def pi(w: np.ndarray) -> float:
            return float(total_energy(jnp.asarray(w)))

        w0 = np.full(n, start) + 1e-3 * np.linspace(-1.0, 1.0, n)
        cons = {"type": "eq", "fun": lambda w: np.sum(w) - total}
        res = minimize(pi, w0, method="SLSQP", constraints=[cons], options={"ftol": 1e-15})
        return float(res.fun)

    du = 1e-4
    return (energy_at(u + du) - energy_at(u - du)) / (2 * du)


def test_field_law_round_trips_to_the_specimen_curve() -> None:
    """Simulating the CFT with the fitted field law reproduces the specimen curve (3 folds)."""
    geo = CftGeometry(radius=1.5, n_folds=3)
    specs = synthetic_specimens(TRUTH, geo, scatter=NO_SCATTER, n_points=(60, 60), seed=1)
    law = calibrate_trilinear(specs, geo, CalibrationOptions(n_bootstrap=0)).law
    phase1, phase2 = specs[0].segments
    for seg, start in ((phase1, 0.05), (phase2, 1.5)):
        for i in (1, seg.displacement.size // 2, seg.displacement.size - 1):
            u, f = seg.displacement[i], seg.force[i]
            simulated = _simulated_cft_force(law, geo, u, start)
            assert simulated == pytest.approx(f, rel=1e-4, abs=1e-6)


# --- validation ---------------------------------------------------------------------------
def test_compare_to_band_reports_rms_and_intervals() -> None:
    band = band_statistics(specimens(4), points_per_phase=50)
    u = band.displacement
    ok = np.isfinite(band.median)
    same = compare_to_band(band, u[ok], band.median[ok])
    assert same.rms == pytest.approx(0.0, abs=1e-12) and same.intervals == ()
    shifted = np.where(u > 1.5, band.median + 3 * np.nan_to_num(band.std), band.median)
    off = compare_to_band(band, u[ok], shifted[ok])
    assert off.intervals and all(a > 1.5 for a, _ in off.intervals)
    assert off.rms > 0 and 0 < off.fraction_outside < 1
    with pytest.raises(biplan.ConfigError, match="overlapping"):
        compare_to_band(band, [10.0, 11.0], [0.0, 1.0])


# --- io: CSV checks and TOML output -------------------------------------------------------
def _write(path: Path, header: str, rows: list[str]) -> Path:
    path.write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    return path


def _rows(n: int = 8, segment: str = "1") -> list[str]:
    return [f"{0.01 * i:.3f},{0.1 * i:.3f},{segment}" for i in range(n)]


def test_reads_force_and_pressure_files(tmp_path: Path) -> None:
    rows = _rows(6) + [f"{2 - 0.1 * i:.3f},{1.0 + i:.3f},2" for i in range(6)]
    sp = read_specimen(_write(tmp_path / "a.csv", "displacement [mm],force [N],segment", rows))
    assert sp.name == "a" and [s.label for s in sp.segments] == ["1", "2"]
    np.testing.assert_allclose(sp.segments[1].displacement, 1.5 + 0.1 * np.arange(6))
    p = _write(
        tmp_path / "b.csv",
        "# comment\nDisplacement (mm);Pressure (kPa)",
        [f"{0.1 * i};{100.0 * i}" for i in range(6)],
    )
    sp = read_specimen(p, radius=2.0)
    np.testing.assert_allclose(sp.segments[0].force, 100e-3 * np.arange(6) * math.pi * 4.0)
    fmt = SpecimenFormat(displacement="ext", force="load", force_unit="mN", displacement_unit="m")
    sp = read_specimen(
        _write(tmp_path / "c.csv", "ext,load", ["0,0", "1e-3,5", "2e-3,9", "3e-3,12", "4e-3,20"]),
        fmt,
    )
    np.testing.assert_allclose(sp.segments[0].displacement, [0, 1, 2, 3, 4])
    np.testing.assert_allclose(sp.segments[0].force, [0, 5e-3, 9e-3, 12e-3, 20e-3])


BAD_CASES = {
    "non-numeric": (4, "0.030,abc,1", "non-numeric"),
    "nan": (5, "0.040,nan,1", "NaN"),
    "empty": (3, "0.020,,1", "empty"),
    "non-monotonic": (6, "0.010,0.5,1", "non-monotonic"),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_bad_rows_are_rejected_with_file_and_row(tmp_path: Path, case: str) -> None:
    line, text, phrase = BAD_CASES[case]
    rows = _rows(8)
    rows[line - 2] = text  # line 1 is the header
    path = _write(tmp_path / "bad.csv", "displacement,force,segment", rows)
    with pytest.raises(DataError) as info:
        read_specimen(path)
    message = str(info.value)
    assert message.startswith(f"{path}, row {line}:"), message
    assert phrase in message and "column" in message


def test_too_few_points_and_unit_mismatch_are_rejected(tmp_path: Path) -> None:
    path = _write(tmp_path / "few.csv", "displacement,force,segment", _rows(6) + _rows(3, "2")[1:])
    with pytest.raises(DataError, match=r"few\.csv, rows 8–9 \(segment '2'\).*at least 5 points"):
        read_specimen(path)
    path = _write(tmp_path / "unit.csv", "displacement [mm],force [kN]", _rows(6))
    with pytest.raises(DataError, match=r"unit\.csv, row 1: .*'kN'.*unit mismatch"):
        read_specimen(path)
    path = _write(tmp_path / "unit2.csv", "displacement [in],pressure [kPa]", _rows(6))
    with pytest.raises(DataError, match="unit mismatch"):
        read_specimen(path, radius=2.0)
    path = _write(tmp_path / "both.csv", "displacement,force,pressure", _rows(6))
    with pytest.raises(DataError, match="exactly one of"):
        read_specimen(path)
    path = _write(
        tmp_path / "split.csv",
        "displacement,force,segment",
        _rows(6) + _rows(6, "2")[1:] + ["0.9,1,1"],
    )
    with pytest.raises(DataError, match="contiguous"):
        read_specimen(path)
    with pytest.raises(DataError, match="radius"):
        read_specimen(_write(tmp_path / "p.csv", "displacement,pressure", _rows(6)))
    with pytest.raises(DataError, match="directory"):
        read_specimens(tmp_path / "missing")


def test_law_block_drops_into_a_config() -> None:
    tri = calibrate_trilinear(specimens(6), options=CalibrationOptions(n_bootstrap=10))
    lin = calibrate_linear(
        synthetic_specimens(LINEAR, extent=0.5, seed=3), options=CalibrationOptions(n_bootstrap=10)
    )
    circular = calibration_toml(tri, "circular", source="data/cft")
    helical = calibration_toml(lin, "helical")
    assert circular.count("[laws.circular]") == 1 and "bistable = true" in circular
    assert "k1 = " in circular and "RMS" in circular
    geometry = "[geometry]\nradius = 2.0\npitch = 3.6\nhelical_angle = 60.0\nn_modules = 6\n\n"
    tube = load_config_text(geometry + circular + "\n" + helical)
    assert tube.circular_laws[0].stiffness == pytest.approx(tri.law.stiffness, rel=1e-5)
    assert tube.circular_laws[0].transitions == pytest.approx(tri.law.transitions, rel=1e-5)
    assert tube.helical_laws[0].stiffness == pytest.approx(lin.law.stiffness, rel=1e-5)


def test_figures_draw_the_band_and_the_fit() -> None:
    result = calibrate_trilinear(specimens(7), options=CalibrationOptions(n_bootstrap=0))
    ax = calibration_band(result)
    labels = [line.get_label() for line in ax.get_lines()]
    assert "median" in labels and "trilinear fit" in labels and "spinodal (interpolated)" in labels
    assert ax.get_xlabel() == "$u$ [mm]" and "[N]" in ax.get_ylabel()
    assert sum(1 for line in ax.get_lines() if line.get_color() == "0.6") == 20  # 10 × 2 segments
    _, ax2 = plt.subplots()
    u = result.band.displacement
    comparison = compare_to_band(result.band, u, cft_force(result.law, result.geometry, u))
    assert validation_band(comparison, ax=ax2) is ax2
    assert any("prediction" in line.get_label() for line in ax2.get_lines())
    plt.close("all")
