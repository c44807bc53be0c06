"""Implicit dynamics with the mass matrix (issue: response solvers).

* the mass matrix is symmetric positive semi-definite and equals Σ w JᵀJ, and the inertia
  force equals M q̈ + c(q, q̇) with c from the Lagrangian (checked against finite differences
  of the kinetic energy);
* an undamped ρ∞ = 1 run conserves T + Π − W, and halving the step converges at second order;
* with Rayleigh damping and a fixed load T + Π − W decreases monotonically;
* the paper's ramp to 1.6 N keeps the constraints satisfied;
* after a loss of stability under the force ramp the tube snaps to phase 2 and settles;
* the design map's dynamic finish gets through a cascade of contact impacts;
* a run over several chunks compiles the chunk once.
"""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan._compile.setup import jax, jnp, xla_options
from biplan.analysis.modes import natural_modes, rayleigh_at, rayleigh_for_damping_ratio
from biplan.analysis.response.ramp_dynamics import continue_ramp
from biplan.model.assembly import Load
from biplan.model.inertia import inertia_force
from biplan.solvers import BackwardEuler, ControlKind
from biplan.solvers.dynamics import mass_matrix_at


@pytest.fixture(scope="module")
def loaded(model6, reference6):
    """Equilibrium at F = 1 N and its natural modes."""
    s = biplan.solve_equilibrium(model6, None, reference6, Load.of_force(1.0))
    return s, natural_modes(model6, s)


def test_mass_matrix_and_inertia_force(model6, loaded, rng):
    s, _ = loaded
    q = s.q
    m = mass_matrix_at(model6, q)
    assert np.allclose(m, m.T, atol=1e-20)
    assert np.linalg.eigvalsh(m).min() > -1e-18
    v = rng.normal(size=q.size)
    a = rng.normal(size=q.size)
    mu = model6.tube.surface_density
    force = jax.jit(inertia_force, static_argnums=0, compiler_options=xla_options())
    f = np.asarray(
        force(model6.layout, model6.params, jnp.asarray(q), jnp.asarray(v), jnp.asarray(a), mu)
    )

    # Lagrange: d/dt(M v) − ½ ∂(vᵀMv)/∂q with d/dt M = ∂M/∂q·v, by central differences
    def mass(qq: np.ndarray) -> np.ndarray:
        return mass_matrix_at(model6, qq)

    h = 1e-6
    dm = (mass(q + h * v) - mass(q - h * v)) / (2 * h)
    grad_t = np.array(
        [(v @ mass(q + h * e) @ v - v @ mass(q - h * e) @ v) / (4 * h) for e in np.eye(q.size)]
    )
    expected = m @ a + dm @ v - grad_t
    assert np.allclose(f, expected, rtol=1e-5, atol=1e-9 * np.abs(expected).max())


def test_natural_period_is_sub_millisecond(loaded):
    _, modes = loaded
    assert 1e-4 < modes.period[0] < 1e-2  # MODEL §13: lowest periods ~0.1–1 ms ≪ 2 s ramp
    assert np.all(np.diff(modes.angular_frequency) >= 0)


def _free_vibration(model6, s, modes, h, rho=1.0, rayleigh=0.0, periods=3.0):
    v0 = modes.shapes[:, 0] / np.linalg.norm(modes.shapes[:, 0]) * 0.02 * modes.angular_frequency[0]
    t_end = periods * modes.period[0]
    return biplan.integrate(
        model6,
        biplan.GeneralizedAlpha(time_step=h, spectral_radius=rho, rayleigh=rayleigh),
        s,
        v0=v0,
        t_end=t_end,
        load=biplan.LoadHistory.constant(1.0),
    )


def test_undamped_energy_conservation_and_second_order_convergence(model6, loaded):
    s, modes = loaded
    period = modes.period[0]
    runs = [_free_vibration(model6, s, modes, period / n) for n in (20, 40, 80)]
    for tr in runs:
        assert tr.completed
        drift = np.ptp(tr.total_energy)
        assert drift < 1e-3 * tr.kinetic_energy.max()  # stated tolerance: 0.1 % of the KE
        assert tr.stats.max_constraint_residual < 1e-8
    e1 = np.abs(runs[0].q[-1] - runs[2].q[-1]).max()
    e2 = np.abs(runs[1].q[-1] - runs[2].q[-1]).max()
    order = np.log2((e1 - e2) / e2) if e1 > e2 > 0 else 0.0
    assert order > 1.6


def test_damped_energy_decreases_monotonically(model6, loaded):
    s, modes = loaded
    alpha = rayleigh_for_damping_ratio(modes, 0.1)
    tr = _free_vibration(model6, s, modes, modes.period[0] / 40, rho=1.0, rayleigh=alpha)
    mech = tr.kinetic_energy + tr.energy - tr.external_work
    assert np.all(np.diff(mech) < 1e-12)
    assert mech[-1] < mech[0] - 0.3 * tr.kinetic_energy.max()
    inc = np.diff(tr.dissipated_energy)
    assert inc.sum() > 0 and inc.min() > -1e-2 * inc.max()  # α_R Δqᵀ M q̇_{n+1} ≈ 2α_R T h


def test_paper_ramp_keeps_constraints_and_reaches_1_6_newton(model6):
    tr = biplan.integrate(model6, biplan.GeneralizedAlpha(time_step=0.02), t_end=2.0)
    assert tr.completed, tr.message
    assert tr.force[-1] == pytest.approx(1.6)
    assert tr.time[-1] == pytest.approx(2.0)
    assert tr.constraint_residual.max() < 1e-8
    assert np.all(tr.stable)
    ds = tr.to_dataset()
    assert ds.sizes["time"] == tr.time.size and ds["time"].attrs["units"] == "s"


def test_snap_after_loss_of_stability_settles_in_phase_two(model6, loaded):
    _, modes = loaded
    history = biplan.LoadHistory(ControlKind.FORCE, (0.0, 2.8, 3.2), (0.0, 2.24, 2.24))
    scheme = BackwardEuler(time_step=0.01, rayleigh=rayleigh_for_damping_ratio(modes, 0.05))
    tr = biplan.integrate(model6, scheme, t_end=3.2, load=history)
    assert tr.completed, tr.message
    before = tr.time < 2.6
    assert np.all(tr.stable[before])
    assert tr.kinetic_energy.max() > 1e-2  # a dynamic snap, not a quasi-static creep
    n = model6.layout.n_modules
    assert tr.phase_fraction[-1, n:, 2].mean() > 0.5  # circular folds open: phase 2
    assert tr.stable[-1] and tr.kinetic_energy[-1] < 1e-6  # settled
    assert tr.u_z[-1] > 5 * tr.u_z[before][-1]
    assert np.all(np.isfinite(tr.q))


def test_snap_cascade_with_contact_impacts_is_finished(model6, loaded):
    """The design map's dynamic finish (docs/maps.md) on the six-module design ramped at
    1.2 N/s to 2.4 N: the last load step of 0.075 N that converges is 2.1 N; the snap drives
    folds into their contacts at metres per second. The run reaches 2.4 N at rest in a
    stable equilibrium with circular folds open, and the chunk compiled once."""
    s, _ = loaded
    for f in np.arange(1.075, 2.1 + 1e-9, 0.075):
        s = biplan.solve_equilibrium(model6, None, s, Load.of_force(float(f)))
        assert s.converged, f
    traj = continue_ramp(model6, s.z, 1.75, rate=1.2, duration=2.0, damping_ratio=0.05,
                         time_step=0.01)  # fmt: skip
    assert traj.completed, traj.message
    assert traj.force[-1] == pytest.approx(2.4) and traj.time[-1] == pytest.approx(0.25)
    assert traj.kinetic_energy.max() > 1e-1  # a violent snap
    assert traj.kinetic_energy[-1] < 1e-6  # settled
    static = biplan.solve_equilibrium(model6, None, traj.z[-1], Load.of_force(2.4))
    assert static.converged
    np.testing.assert_allclose(static.q, traj.q[-1], atol=1e-5)
    assert biplan.classify(model6, static).verdict is biplan.Verdict.STABLE
    n = model6.layout.n_modules
    assert (traj.phase_fraction[-1, n:, 2] > 0.5).any()  # circular folds opened
    assert traj.u_z[-1] > 5 * traj.u_z[0]


def test_bad_dynamics_inputs(model6):
    with pytest.raises(biplan.ConfigError, match="spectral_radius"):
        biplan.GeneralizedAlpha(spectral_radius=1.5)
    with pytest.raises(biplan.ConfigError, match=r"load.times"):
        biplan.LoadHistory(ControlKind.FORCE, (0.0, 0.0), (0.0, 1.0))
    with pytest.raises(biplan.ConfigError, match="start"):
        biplan.integrate(model6, None, np.full(model6.n_coordinates, 0.3), t_end=0.1)


def test_damping_probe_past_the_first_snap_is_halved():
    """The fully bistable tube snaps at 0.49 N: the probe at half a 1.6 N ramp (0.8 N) has no
    stable state on the reference's branch, so the probe is halved until one has (0.4 N), and
    the damping equals the one probed there directly; a tube without any usable probe says
    which loads were tried."""
    model = biplan.Model(biplan.designs.fully_bistable())
    ref = biplan.relaxed_reference(model, throw=True)
    halved = rayleigh_at(model, ref, biplan.Load.of_force(0.8), 0.05)
    direct = rayleigh_at(model, ref, biplan.Load.of_force(0.4), 0.05)
    assert halved == direct > 0.0
    with pytest.raises(biplan.ConfigError, match="probe load of the damping ratio") as err:
        rayleigh_at(model, ref, biplan.Load.of_force(0.0), 0.05)  # contacts lock every mode
    assert "F = 0 N: none (every contact locked)" in str(err.value)
    assert "damping ratio 0: undamped" in str(err.value)
