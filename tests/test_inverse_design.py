"""Inverse design: a round trip (perturb the one-module tube's laws, ask for its original u_z and
u_r at a force, recover the laws), a limit-force target, the target syntax, and the command
line (writes the found design as a configuration; a target that cannot be met exits 1 with the
best design; a malformed request is refused before any solve).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import biplan
from biplan.analysis.sensitivity.inverse import Target, inverse_design
from biplan.analysis.sensitivity.limit_point import locate_limit_point
from biplan.cli.main import EXIT_BIPLAN_ERROR, main
from biplan.io.config import dump_config, load_config
from conftest import make_tube

VARY = ("laws.helical.stiffness", "laws.circular.stiffness[0]")


def _perturbed() -> biplan.Tube:
    """The one-module tube with k = 1.5 (was 1.3) and k1 = 1.0 (was 0.9)."""
    tube = make_tube(1, helical=biplan.LinearLaw(1.5))
    law = biplan.TrilinearLaw(stiffness=(1.0, -0.2, 0.6), transitions=(0.2, 1.3))
    return tube.with_law(("circular", 0), law)


def _original_targets(model1: biplan.Model) -> tuple[str, str]:
    state = biplan.solve_equilibrium(
        model1, biplan.Newton(atol=1e-13), None, biplan.Load.of_force(0.3)
    )
    e = model1.endpoint(state.q)
    return (f"u_z/l0={e.u_z / model1.tube.initial_length!r}@F=0.3", f"u_r={e.u_r!r}@F=0.3")


def test_target_syntax():
    t = Target.parse("u_z/l0=0.06@F=1.6")
    assert (t.observable.value, t.value, t.per_length) == ("u_z", 0.06, True)
    assert float(t.load.force) == 1.6 and not t.load.is_displacement_controlled
    assert Target.parse("force=1.2@U=2").load.is_displacement_controlled
    assert Target.parse(" limit_force = 1.5 ").label == "limit_force=1.5"
    assert Target.parse(t.label) == t
    s = Target.parse("u_z/l0=0.9@state=1b")
    assert (s.state, float(s.load.force), s.label) == ("1B", 0.0, "u_z/l0=0.9@state=1B")
    assert Target.parse(s.label) == s
    named = ("u_z=1@state=X1", "limit_force=1@state=66", "u_z=0.1@state=")
    for bad in ("u_z=0.1", "limit_force=1@F=2", "u_q=1@F=1", "u_z=abc@F=1", "u_z=1@F=nan", *named):
        with pytest.raises(biplan.ConfigError, match="target"):
            Target.parse(bad)


def test_round_trip_recovers_the_laws(model1):
    start = biplan.Model(_perturbed())
    result = inverse_design(start, _original_targets(model1), VARY, tolerance=1e-9)
    assert result.success, result
    np.testing.assert_allclose(result.values, [1.3, 0.9], rtol=1e-6)
    np.testing.assert_allclose(result.start, [1.5, 1.0])
    assert result.tube.helical_laws[0].stiffness == result.values[0]
    assert result.jacobian.shape == (2, 2)


@pytest.mark.parametrize("n_modules", [1, 2], ids=["single fold pair", "series chain"])
def test_stiffness_scaling_closed_form(n_modules):
    """All laws linear: the energy is homogeneous of degree one in (k_h, k_c), so scaling both
    by s keeps the state at a prescribed U and scales its reaction by s. Asking for twice the
    force at the same deflection u_r has the closed-form answer (2 k_h, 2 k_c), for one module
    and for a chain of two in series."""

    def tube(kh: float, kc: float) -> biplan.Tube:
        return make_tube(n_modules, helical=biplan.LinearLaw(kh), circular=biplan.LinearLaw(kc))

    model = biplan.Model(tube(1.3, 0.9))
    load = biplan.Load.of_displacement(0.4)
    state = biplan.solve_equilibrium(model, biplan.Newton(atol=1e-13), None, load)
    u_r = model.endpoint(state.q).u_r
    targets = (f"force={2 * state.force!r}@U=0.4", f"u_r={u_r!r}@U=0.4")
    vary = ("laws.helical.stiffness", "laws.circular.stiffness")
    result = inverse_design(biplan.Model(tube(1.43, 0.81)), targets, vary, tolerance=1e-10)
    assert result.success
    np.testing.assert_allclose(result.values, [2.6, 1.8], rtol=1e-8)


def test_named_state_round_trip(model4):
    """Fully bistable tube: move the circular spinodal end (1.3 → 1.5 mm) and ask for the
    original u_z/l0 of the all-circular-open state 2A; the fit recovers 1.3 mm."""
    from biplan.analysis.states.search import relax_state

    state = relax_state(model4, "2A")
    wanted = model4.endpoint(state.q).u_z / model4.tube.initial_length
    law = model4.tube.circular_laws[0]
    moved = replace(law, transitions=(law.transitions[0], 1.5))
    tube = model4.tube
    for k in range(len(tube.circular_laws)):
        tube = tube.with_law(("circular", k), moved)
    result = inverse_design(
        biplan.Model(tube), (f"u_z/l0={wanted!r}@state=2A",), ("laws.circular.transitions[1]",),
        tolerance=1e-9,
    )  # fmt: skip
    assert result.success, result
    assert result.values[0] == pytest.approx(1.3, rel=1e-6)
    with pytest.raises(biplan.ConfigError, match="state label"):
        inverse_design(model4, ("u_z=0.1@state=1FF",), ("laws.circular.transitions[1]",))


def test_semi_bistable_round_trip_at_1_6_n(model6):
    """The paper's design: perturb k_h (1.3 → 1.5) and k₁ (0.9 → 1.0), ask for the original
    u_z and u_r at F = 1.6 N, recover the original laws."""
    from biplan.analysis.response.reached import reached_state

    load = biplan.Load.of_force(1.6)
    e = model6.endpoint(reached_state(model6, load).q)
    targets = (f"u_z={e.u_z!r}@F=1.6", f"u_r={e.u_r!r}@F=1.6")
    tube = model6.tube
    law = tube.circular_laws[0]
    moved = replace(law, stiffness=(1.0, *law.stiffness[1:]))
    tube = replace(tube, helical_laws=(biplan.LinearLaw(1.5),) * tube.n_modules)
    tube = replace(tube, circular_laws=(moved,) * len(tube.circular_laws))
    result = inverse_design(biplan.Model(tube), targets, VARY, tolerance=1e-9)
    assert result.success, result
    np.testing.assert_allclose(result.values, [1.3, 0.9], rtol=1e-6)


def _contradiction(model1: biplan.Model) -> tuple[str, str]:
    """u_z at 0.3 N wanted both 20 % below and 20 % above its value: no design meets both."""
    state = biplan.solve_equilibrium(model1, None, None, biplan.Load.of_force(0.3))
    u_z = model1.endpoint(state.q).u_z
    return (f"u_z={0.8 * u_z!r}@F=0.3", f"u_z={1.2 * u_z!r}@F=0.3")


def test_unmet_target_tries_every_start_and_returns_the_best(model1):
    """Contradictory targets: every start is tried and the best one (the smallest scaled
    residual, between the two targets) is returned, not met."""
    targets = _contradiction(model1)
    vary = ("laws.helical.stiffness",)
    result = inverse_design(model1, targets, vary, starts=3, max_evaluations=15)
    assert not result.success and result.starts == 3 and result.values[0] > 0
    low, high = sorted(Target.parse(t).value for t in targets)
    assert low < result.achieved[0] < high

    def cost(r) -> float:
        goal = np.array([Target.parse(t).value for t in targets])
        return float(np.sum(((r.achieved - goal) / goal) ** 2))

    first = inverse_design(model1, targets, vary, starts=1, max_evaluations=15)
    assert first.starts == 1 and cost(result) <= cost(first) + 1e-12


def test_limit_force_target(model1):
    wanted = locate_limit_point(model1).force + 0.1
    result = inverse_design(
        model1, (f"limit_force={wanted!r}",), ("laws.circular.stiffness[0]",), tolerance=1e-9
    )
    assert result.success
    assert result.values[0] > 0.9  # a stiffer closed branch holds more
    again = locate_limit_point(biplan.Model(result.tube))
    assert again.force == pytest.approx(wanted, rel=1e-7)


def test_cli_writes_the_design(tmp_path: Path, model1):
    config = tmp_path / "start.toml"
    config.write_text(dump_config(_perturbed()))
    out = tmp_path / "out"
    args = ["design", str(config), "--out", str(out), "--quiet", "--tolerance", "1e-9"]
    for t in _original_targets(model1):
        args += ["--target", t]
    for name in VARY:
        args += ["--vary", name]
    with pytest.raises(SystemExit) as info:
        main(args)
    assert info.value.code in (0, None)
    found = load_config(out / "design.toml")
    assert found.helical_laws[0].stiffness == pytest.approx(1.3, rel=1e-6)
    assert found.circular_laws[0].stiffness[0] == pytest.approx(0.9, rel=1e-6)
    table = pd.read_csv(out / "design.csv")
    assert table["met"].all()  # plain numbers, not NumPy reprs
    np.testing.assert_allclose(table["achieved"], table["wanted"], rtol=1e-6)
    sens = pd.read_csv(out / "design_sensitivity.csv")
    assert len(sens) == 2 * 2 and np.isfinite(sens["value"].to_numpy(dtype=float)).all()


def test_cli_unmet_target_exits_1_with_the_best_design(tmp_path: Path, capsys, model1):
    config = tmp_path / "one.toml"
    config.write_text(dump_config(model1.tube))
    out = tmp_path / "out"
    args = ["design", str(config), "--vary", "laws.helical.stiffness", "--starts", "1"]
    for t in _contradiction(model1):
        args += ["--target", t]
    with pytest.raises(SystemExit) as info:
        main([*args, "--out", str(out), "--quiet"])
    assert info.value.code == 1
    assert "2 of 2 targets not met" in " ".join(capsys.readouterr().err.split())
    assert load_config(out / "design.toml").helical_laws[0].stiffness > 0
    assert "False" in (out / "design.csv").read_text()


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--target", "u_z=0.1", "--vary", "laws.helical.stiffness"], "--target"),
        (["--target", "u_z=0.1@F=0.3", "--vary", "laws.helical.stifness"], "--vary"),
        (["--target", "u_z=0.1@F=0.3", "--vary", "load.force"], "--vary"),
        (["--target", "u_z=0.1@F=0.3", "--vary", "geometry.pitch", "--starts", "0"], "--starts"),
        (["--target", "u_z=0.1@state=1F", "--vary", "geometry.pitch"], "--target"),
    ],
)
def test_cli_refuses_bad_requests(tmp_path: Path, capsys, monkeypatch, extra, needle):
    import biplan.analysis.sensitivity.inverse

    monkeypatch.setattr(
        biplan.analysis.sensitivity.inverse, "inverse_design", lambda *a, **k: pytest.fail("solved")
    )
    config = tmp_path / "one.toml"
    config.write_text(dump_config(make_tube(1)))
    with pytest.raises(SystemExit) as info:
        main(["design", str(config), *extra, "--out", str(tmp_path / "o")])
    captured = capsys.readouterr()
    assert info.value.code == EXIT_BIPLAN_ERROR
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert len(lines) == 1 and needle in lines[0], captured.err
