"""Design sensitivities by implicit differentiation of the KKT system, against central finite
differences of full re-solves (relative 1e-5), on three designs: the one-module tube of the
calibration laws (under tension, and with its circular fold open and the helical fold pressed
shut: active contacts), two modules under displacement control, and two modules with a
trilinear helical law and one circular fold of its own law (per-fold parameters, b as the
angle parameter). The first-instability force and displacement against finite differences of
located limit points; the command line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import biplan
from biplan.analysis.sensitivity.equilibrium import Mode, Observable, eigen_weights, sensitivity
from biplan.analysis.sensitivity.finite_differences import (
    finite_differences,
    limit_point_finite_differences,
)
from biplan.analysis.sensitivity.limit_point import limit_point_sensitivity, locate_limit_point
from biplan.analysis.sensitivity.parameters import AngleParameter, design_parameters
from biplan.cli.main import EXIT_BIPLAN_ERROR, main
from biplan.io.config import dump_config
from conftest import make_tube

RTOL = 1e-5
TIGHT = biplan.Newton(atol=1e-13)


def assert_matches(exact: np.ndarray, fd: np.ndarray, values: np.ndarray) -> float:
    """Relative agreement of p ∂y/∂p, entry by entry; entries below 1e-3 of their row's largest,
    or below 1e-5 (mm, rad, N, N·mm, H_r), are compared to that floor (finite differences of a
    zero derivative are solver noise). Returns the largest relative error."""
    scaled_fd, scaled = np.abs(fd * values), np.abs((exact - fd) * values)
    floor = np.maximum(1e-3 * scaled_fd.max(axis=1, keepdims=True), 1e-5)
    err = scaled / np.maximum(np.maximum(scaled_fd, floor), 1e-300)
    assert np.all(err < RTOL), np.argwhere(err >= RTOL)
    return float(err.max())


def _tension(model: biplan.Model) -> biplan.Solution:
    return biplan.solve_equilibrium(model, TIGHT, None, biplan.Load.of_force(0.3))


def _contacts(model: biplan.Model) -> biplan.Solution:
    """Circular fold opened (U = 1.4 mm), then compressed (F = −0.1 N): the helical fold's
    ends pressed shut (active contacts), the open fold free."""
    up = biplan.solve_equilibrium(model, TIGHT, None, biplan.Load.of_displacement(1.4))
    z = up.z.copy()
    z[-1] = 0.0
    return biplan.solve_equilibrium(model, TIGHT, z, biplan.Load.of_force(-0.1))


def _displacement(model: biplan.Model) -> biplan.Solution:
    return biplan.solve_equilibrium(model, TIGHT, None, biplan.Load.of_displacement(0.4))


@pytest.fixture(scope="module")
def mixed_laws() -> biplan.Model:
    """Two modules, trilinear helical law, circular fold 1 with a law of its own."""
    tube = make_tube(
        2, helical=biplan.TrilinearLaw(stiffness=(2.0, -1.6, 1.0), transitions=(0.05, 0.3))
    )
    other = biplan.TrilinearLaw(stiffness=(1.1, -0.3, 0.7), transitions=(0.25, 1.2))
    return biplan.Model(tube.with_law(("circular", 1), other))


CASES = {
    "tension": ("model1", _tension, {}),
    "active contacts": ("model1", _contacts, {}),
    "displacement control": ("model2", _displacement, {}),
    "per-fold laws, b": (
        "mixed_laws",
        lambda m: biplan.solve_equilibrium(m, TIGHT, None, biplan.Load.of_force(0.05)),
        {"angle": "b", "per_fold": True},
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_state_derivatives_match_finite_differences(case: str, request: pytest.FixtureRequest):
    name, make_state, options = CASES[case]
    model = request.getfixturevalue(name)
    state = make_state(model)
    assert state.converged
    if case == "active contacts":
        assert np.count_nonzero(state.contact_multipliers > 1e-3) >= 1
        assert eigen_weights(model, state) is not None  # not contact-locked: λ_min exists
    exact = sensitivity(model, state, **options)
    fd = finite_differences(model, state, **options)
    assert [p.name for p in exact.parameters] == [p.name for p in fd.parameters]
    np.testing.assert_allclose(exact.values, fd.values, rtol=1e-12, atol=1e-12)
    values = np.asarray([p.value for p in exact.parameters])
    assert_matches(exact.derivatives, fd.derivatives, values)
    if case == "displacement control":
        assert Observable.FORCE in exact.observables
        # the reaction's derivative with respect to U is the tangent stiffness
        assert exact.derivative("force", "load.displacement") > 0
    if case == "per-fold laws, b":
        names = {p.name for p in exact.parameters}
        assert {
            "geometry.b",
            "laws.circular[1].stiffness[0]",
            "laws.helical[0].transitions[1]",
        } <= names


def test_adjoint_and_direct_agree_and_min_eigenvalue_is_the_stability_one(model1):
    state = _tension(model1)
    adjoint = sensitivity(model1, state, mode=Mode.ADJOINT)
    direct = sensitivity(model1, state, mode=Mode.DIRECT)
    np.testing.assert_allclose(adjoint.derivatives, direct.derivatives, rtol=1e-9, atol=1e-13)
    lam = adjoint.values[adjoint.observables.index(Observable.MIN_EIGENVALUE)]
    assert lam == pytest.approx(biplan.classify(model1, state).min_eigenvalue, rel=1e-12)
    one = sensitivity(model1, state, ("u_z",), ("laws.helical.stiffness",))
    assert one.derivatives.shape == (1, 1)
    assert one.derivatives[0, 0] == pytest.approx(
        adjoint.derivative("u_z", "laws.helical.stiffness")
    )
    frame = adjoint.to_dataframe()
    assert list(frame.columns[:5]) == ["observable", "parameter", "value", "unit", "elasticity"]
    assert (
        frame.set_index(["observable", "parameter"]).loc[("u_z", "geometry.helical_angle"), "unit"]
        == "mm/deg"
    )


def test_parameter_map_gives_the_rebuilt_tube(model2):
    """Moving R, β (in degrees) and a stiffness through the map equals building the tube."""
    pset = design_parameters(model2, biplan.Load.of_force(0.2))
    v = pset.values.copy()
    v[pset.index("geometry.radius")] = 2.1
    v[pset.index("geometry.helical_angle")] = 55.0
    v[pset.index("laws.circular.transitions[0]")] = 0.25
    moved, load = pset.model_at(model2, v)
    circular = biplan.TrilinearLaw(stiffness=(0.9, -0.2, 0.6), transitions=(0.25, 1.3))
    tube = biplan.Tube.uniform(radius=2.1, pitch=3.6, helical_angle=55.0, n_modules=2,
                               helical=biplan.LinearLaw(1.3), circular=circular)  # fmt: skip
    rebuilt = biplan.Model(tube).params
    for a, b in zip(moved.params.geometry, rebuilt.geometry, strict=True):
        assert float(a) == pytest.approx(float(b), rel=1e-14)
    np.testing.assert_allclose(moved.params.circular, rebuilt.circular, rtol=1e-14)
    assert load.force == 0.2
    with_b = design_parameters(model2, load, angle=AngleParameter.B)
    assert with_b.values[2] == pytest.approx(model2.tube.b, rel=1e-12)


def test_requests_are_checked(model1):
    state = _tension(model1)
    with pytest.raises(biplan.ConfigError, match="parameter"):
        sensitivity(model1, state, parameters=("geometry.radios",))
    with pytest.raises(biplan.ConfigError, match="observable"):
        sensitivity(model1, state, observables=("limit_force",))
    failed = biplan.solve_equilibrium(model1, biplan.Newton(max_steps=1), None,
                                      biplan.Load.of_force(1.0))  # fmt: skip
    with pytest.raises(biplan.ConfigError, match="converged"):
        sensitivity(model1, failed)


def test_limit_point_derivatives_match_located_limit_points(model1):
    limit = locate_limit_point(model1)
    assert abs(limit.min_eigenvalue) < 1e-9
    assert 1.0 < limit.force < 4.0
    exact = limit_point_sensitivity(model1, limit)
    fd = limit_point_finite_differences(model1, limit)
    values = np.asarray([p.value for p in exact.parameters])
    assert_matches(exact.derivatives, fd.derivatives, values)
    # the located F* is the force-controlled response's first snap, to its tolerance
    snap = biplan.analysis.response.loadcontrol.first_snap(model1)
    assert snap is not None
    assert limit.force == pytest.approx(snap.force, abs=max(snap.tolerance, 1e-6) * 10)


def _config(folder: Path) -> Path:
    """The one-module tube of ``model1`` as a TOML configuration."""
    config = folder / "one.toml"
    config.write_text(dump_config(make_tube(1)))
    return config


def test_cli_writes_the_table_and_the_chart(tmp_path: Path, model1):
    config = _config(tmp_path)
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        main(["sensitivity", str(config), "--force", "0.3", "--out", str(out), "--quiet"])
    assert info.value.code in (0, None)
    table = pd.read_csv(out / "sensitivity.csv")
    assert list(table.columns[:5]) == ["observable", "parameter", "value", "unit", "elasticity"]
    row = table[(table.observable == "u_z") & (table.parameter == "load.force")]
    expected = sensitivity(model1, _tension(model1)).derivative("u_z", "load.force")
    assert float(row.value.iloc[0]) == pytest.approx(expected, rel=1e-8)
    assert (out / "sensitivity.png").stat().st_size > 0


@pytest.mark.parametrize(
    ("args", "observables"),
    [(["--displacement", "0.2"], "force"), (["--limit-point"], "limit_force")],
)
def test_cli_other_states(tmp_path: Path, model1, args, observables):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        main(["sensitivity", str(_config(tmp_path)), *args, "--out", str(out), "--quiet"])
    assert info.value.code in (0, None)
    table = pd.read_csv(out / "sensitivity.csv")
    assert observables in set(table.observable)
    assert np.all(np.isfinite(table.value))


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--force", "nan"], "--force"),
        (["--force", "1e3"], "--force"),
        (["--displacement", "-500"], "--displacement"),
        (["--force", "1", "--limit-point"], "exactly one of"),
        ([], "exactly one of"),
    ],
)
def test_cli_refuses_bad_requests(tmp_path: Path, capsys, monkeypatch, args, needle):
    monkeypatch.setattr(biplan, "Model", lambda *a, **k: pytest.fail("reached the model"))
    config = _config(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(["sensitivity", str(config), *args, "--out", str(tmp_path / "o")])
    captured = capsys.readouterr()
    assert info.value.code == EXIT_BIPLAN_ERROR
    assert "Traceback" not in captured.err
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert len(lines) == 1 and needle in lines[0], captured.err


def test_limit_point_of_the_semi_bistable_design(model6):
    """The paper's design snaps back: a full Newton step on U lands past the turn of the
    displacement-controlled branch, where no equilibrium exists, and is halved. The search ends
    at λ_min^F = 0, at least first_snap's force (its last stable state before the peak)."""
    from biplan.analysis.response.loadcontrol import first_snap

    limit = locate_limit_point(model6)
    snap = first_snap(model6)
    assert snap is not None
    assert abs(limit.min_eigenvalue) < 1e-10
    assert 0.0 <= limit.force - snap.force < 1e-3 * snap.force
    assert limit.displacement > snap.displacement_before


def test_the_default_set_leaves_out_min_eigenvalue_at_a_contact_locked_state() -> None:
    """One fully bistable module without base fold is contact-locked under tension (no free
    direction: λ_min has no derivative). The default observables leave λ_min out and say so;
    asked for by name, it is refused. The other rows are those of the full request; the end
    displacement is zero up to rounding, so it has no elasticity (NaN, not ±772)."""
    model = biplan.Model(biplan.designs.fully_bistable(n_modules=1))
    ref = biplan.relaxed_reference(model, throw=True)
    state = biplan.solve_equilibrium(model, None, ref, biplan.Load.of_force(0.5))
    assert state.converged and eigen_weights(model, state) is None
    found = sensitivity(model, state)
    assert Observable.MIN_EIGENVALUE not in found.observables
    assert found.left_out == ("min_eigenvalue is left out at a contact-locked state (no H_r)",)
    # the locked tube does not move: its end displacement is rounding, and has no elasticity
    u_z = found.observables.index(Observable.U_Z)
    assert abs(found.values[u_z]) < 1e-9 and np.isnan(found.elasticities[u_z]).all()
    assert np.isfinite(found.derivatives[u_z]).all()  # dy/dp is still given
    named = sensitivity(model, state, observables=found.observables)
    assert named.left_out == ()
    np.testing.assert_array_equal(named.derivatives, found.derivatives)
    with pytest.raises(biplan.ConfigError, match="left out at a contact-locked state"):
        sensitivity(model, state, observables=("u_z", "min_eigenvalue"))
