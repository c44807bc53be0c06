"""Path following on the semi-bistable paper design (issue: response solvers).

Physics asserted (numbers recorded in docs/fidelity.md):

* a two-phase response: the displacement-controlled path has a stretch of negative tangent
  stiffness, and λ_min(H_r) crosses zero where force control would snap (the force maximum);
* phase 1 shows eccentric bending (u_r grows with F, circular fields non-uniform), phase 2 is
  dominated by extension;
* force-controlled arclength and displacement-controlled paths trace the same curve;
* constraint residuals stay below tolerance; a solve that cannot continue stops with a status.
"""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan.model.assembly import Load
from biplan.solvers.continuation import FULL_CONTACT_PENETRATION
from biplan.solvers.newton import Status, make_solution
from jax_oracle.observe import observe_batch


@pytest.fixture(scope="module")
def displacement_path(model6):
    return biplan.trace_path(
        model6,
        biplan.ArcLength(initial_step=0.05, max_step=0.1),
        None,
        biplan.Control.displacement(9.0),
    )


@pytest.fixture(scope="module")
def force_path(model6):
    return biplan.trace_path(
        model6,
        biplan.ArcLength(initial_step=0.05, max_step=0.1, max_steps=40),
        None,
        biplan.Control.force(2.5),
    )


def test_observed_eigenvalue_matches_reference_classification(model6, reference6):
    """The jitted masked-SVD λ_min equals the NumPy reduced Hessian (basis independence)."""
    sols = [reference6]
    for u in (0.6, 1.2, 1.55):
        sols.append(biplan.solve_equilibrium(model6, None, sols[-1], Load.of_displacement(u)))
    z = np.stack([s.z for s in sols])
    loads = Load(*(np.array([float(getattr(s.load, f)) for s in sols]) for f in Load._fields))
    obs = observe_batch(model6.layout, model6.params, z, loads)
    for s, lam, dof in zip(sols, obs.min_eigenvalue, obs.dof, strict=True):
        st = biplan.classify(model6, s)
        assert int(dof) == st.dof
        if st.dof:
            assert lam == pytest.approx(st.min_eigenvalue, rel=1e-8, abs=1e-9)
    assert np.allclose(obs.phase_fraction.sum(axis=-1), 1.0)


def test_displacement_path_completes_with_small_residuals(displacement_path):
    p = displacement_path
    assert p.completed, p.message
    assert p.load_parameter[-1] == pytest.approx(9.0)
    assert np.all(np.isfinite(p.force))
    assert p.constraint_residual.max() < 1e-8
    assert p.stats.n_steps > 50


def test_two_phase_response_with_negative_stiffness(displacement_path):
    p = displacement_path
    u, f = p.displacement, p.force
    slope = np.diff(f) / np.diff(u)
    assert np.any(slope < -0.5), "no stretch of negative tangent stiffness"
    # λ_min crosses zero at the phase-1 force maximum, where force control would snap
    first = p.events[0]
    phase1 = slice(0, first.step + 1)
    assert first.force == pytest.approx(f[phase1].max(), rel=2e-3)
    assert 1.0 < first.force < 3.0
    assert p.min_eigenvalue[: first.step].min() > 0
    assert p.min_eigenvalue[first.step + 1] < 0


def test_phase_one_eccentric_bending_and_phase_two_extension(model6, displacement_path):
    p = displacement_path
    first = p.events[0].step
    u_r = np.abs(p.u_r[: first + 1])
    assert np.all(np.diff(u_r[1:]) > 0), "|u_r| must grow monotonically in phase 1"
    ratio_phase1 = abs(p.u_r[first]) / p.u_z[first]
    assert ratio_phase1 > 0.1
    fields = model6.circular_fields(p.q[first])
    spread = max(float(np.max(np.abs(w0 - w1))) for w0, w1, _ in fields)
    assert spread > 0.01, "circular folds transform non-uniformly along the circumference"
    # phase 2: the circular folds open; extension dominates the deformation
    open_frac = p.phase_fraction[-1, model6.layout.n_modules :, 2]
    assert open_frac.mean() > 0.5
    assert p.u_z[-1] / model6.tube.initial_length > 0.3
    assert abs(p.u_r[-1]) / p.u_z[-1] < ratio_phase1


def test_force_arclength_passes_the_limit_point_on_the_same_curve(displacement_path, force_path):
    fp, dp = force_path, displacement_path
    assert fp.limit_points, "the force-controlled path must locate a limit point"
    lp = fp.limit_points[0]
    k = lp.step
    assert fp.direction[k + 1] < 0 < fp.direction[1], "the force decreases past the limit point"
    assert lp.force == pytest.approx(dp.events[0].force, rel=5e-3)
    # up to the limit point every force-controlled state lies on the displacement-controlled
    # curve: solving at its U from the nearest displacement-path state gives its force
    upto = dp.events[0].step
    for i in range(1, k):  # the located limit point itself is a bifurcation of the branch
        j = int(np.argmin(np.abs(dp.displacement[: upto + 1] - fp.displacement[i])))
        start = make_solution(
            dp.model, dp.z[j], Load.of_displacement(dp.displacement[j]), Status.CONVERGED, 0.0, 0
        )
        s = biplan.solve_equilibrium(
            dp.model, None, start, Load.of_displacement(fp.displacement[i])
        )
        assert s.converged
        assert s.force == pytest.approx(fp.force[i], abs=1e-6)
    assert fp.constraint_residual.max() < 1e-8


def test_load_stepping_stops_at_a_force_limit_point(model6):
    p = biplan.trace_path(
        model6, biplan.LoadStepping(initial_step=0.2, max_step=0.2), None, biplan.Control.force(3.0)
    )
    assert p.status is biplan.PathStatus.STALLED
    assert "limit point" in p.message
    assert np.all(np.isfinite(p.force))
    assert 2.0 < p.force[-1] < 2.2


def test_compression_past_full_contact_stops_with_a_status(model6):
    p = biplan.trace_path(
        model6,
        biplan.LoadStepping(initial_step=0.05, max_step=0.1, max_steps=60),
        None,
        biplan.Control.displacement(-1.0),
    )
    """The closed tube cannot shorten: with the contact compliance c the contacts would have
    to carry absurd forces (c·λ_∂ = penetration), so the path stops at full contact."""
    assert not p.completed
    assert p.status is biplan.PathStatus.FULL_CONTACT, p.message
    assert "full contact" in p.message
    assert np.all(np.isfinite(p.force)) and np.all(np.isfinite(p.q))
    assert p.displacement.min() > -1e-4
    c = model6.options.contact_compliance
    for z in p.z:
        q, _, lam_c, _ = model6.split(z)
        assert -model6.contact_gaps(q).min() <= FULL_CONTACT_PENETRATION
        assert lam_c.max() <= 1.5 * FULL_CONTACT_PENETRATION / c


def test_pressure_control_is_an_end_force(model6):
    p_stop = 0.1  # MPa
    p = biplan.trace_path(
        model6,
        biplan.LoadStepping(initial_step=0.02, max_step=0.05),
        None,
        biplan.Control.pressure(p_stop),
    )
    area = np.pi * model6.tube.development.radius**2
    assert p.completed
    assert p.force[-1] == pytest.approx(p_stop * area)
    f = biplan.solve_equilibrium(
        model6,
        None,
        make_solution(model6, p.z[-1], Load.of_force(p.force[-1]), Status.CONVERGED, 0.0, 0),
        Load.of_force(p_stop * area),
    )
    assert f.displacement == pytest.approx(p.displacement[-1], abs=1e-9)


def test_bad_inputs_are_rejected_before_solving(model6):
    with pytest.raises(biplan.ConfigError, match=r"control.stop"):
        biplan.Control.force(float("nan"))
    with pytest.raises(biplan.ConfigError, match="initial_step"):
        biplan.ArcLength(initial_step=-1.0)
    with pytest.raises(biplan.ConfigError, match="load"):
        biplan.trace_path(model6, biplan.ArcLength(), None, None)
    with pytest.raises(biplan.ConfigError, match="kind"):
        biplan.Control("torque", 1.0)


def test_path_dataset_netcdf_and_csv_round_trip(tmp_path, model6, force_path):
    from biplan.io.results import dataset, load_result, model_of, save

    ds = dataset(force_path)
    assert ds.sizes["step"] == force_path.n_steps
    assert ds["phase_fraction"].dims == ("step", "fold", "phase")
    assert ds["force"].attrs["units"] == "N"
    save(force_path, tmp_path / "p.nc")
    save(force_path, tmp_path / "p.csv")
    back = load_result(tmp_path / "p.nc")
    assert np.allclose(back["force"].values, force_path.force)
    assert model_of(back).layout == model6.layout
    header = (tmp_path / "p.csv").read_text().splitlines()[1].split(",")
    for col in ("force", "u_z", "u_r", "theta", "energy", "min_eigenvalue", "stable"):
        assert col in header


def test_states_observed_in_the_path_kernel_equal_a_fresh_observation(model6):
    """The path kernel observes each accepted state from its corrector's KKT Jacobian
    (``observe_from_jacobian``); a fresh ``observe_batch`` (a second assembly) gives the same
    observables (through the phase-1 peak, where λ_min changes sign)."""
    path = biplan.trace_path(
        model6,
        biplan.ArcLength(initial_step=0.05, max_step=0.1, locate_events=False),
        None,
        biplan.Control.displacement(2.0),
    )
    assert path.completed, path.message
    n = len(path.load_parameter)
    loads = Load(np.zeros(n), np.asarray(path.load_parameter), np.ones(n))
    fresh = observe_batch(model6.layout, model6.params, path.z, loads)
    for name in ("force", "displacement", "u_z", "u_r", "theta", "energy", "phase_fraction"):
        np.testing.assert_allclose(
            getattr(path, name), getattr(fresh, name), rtol=1e-10, atol=1e-10, err_msg=name
        )
    np.testing.assert_allclose(path.min_eigenvalue, fresh.min_eigenvalue, rtol=1e-8, atol=1e-9)
    assert np.any(path.min_eigenvalue < 0) and np.any(path.min_eigenvalue > 0)
