"""Equilibrium solves against closed forms and conservation statements (MODEL.md §11).

* the reference state and every returned equilibrium satisfy the KKT system to tolerance;
* force and displacement control are dual (reaction = applied force, same configuration);
* the circular folds are springs in series: each carries the whole end force;
* a one-module tube with a stiff helical fold reduces to a 2-DOF linear problem solved here in
  closed form;
* uniform fold states at the zero-force points of the law are exact equilibria;
* dΠ/dU = F along a displacement-controlled path (Clapeyron/Castigliano).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

import biplan
from biplan import ConfigError, ConvergenceError, LinearLaw, Load, Newton, Status
from conftest import CIRCULAR, GEOMETRY, make_tube

DEV = biplan.Development(**GEOMETRY)
H, H1, H2, A_LEN = DEV.circumference, DEV.element1_span, DEV.helical_span, DEV.helical_length
K_WEDGE = H * math.sin(DEV.beta) / H1 + DEV.pitch * math.cos(DEV.beta) * (1 / H1 + 1 / H2)
TOL = 1e-8


def assert_equilibrium(model, sol):
    """Converged, residual below tolerance (reported and recomputed), guides satisfied,
    contact complementarity (regularised) respected."""
    assert sol.converged, sol.message
    assert sol.status is Status.CONVERGED
    assert sol.residual_norm < TOL
    r = model.residual(sol.z, sol.load)
    assert np.max(np.abs(r)) < TOL
    assert np.max(np.abs(model.constraints(sol.q))) < TOL
    # a contact carrying λ_∂ may close past flat by c λ_∂ (ModelOptions.contact_compliance)
    c = model.options.contact_compliance
    assert np.min(model.contact_gaps(sol.q) + c * sol.contact_multipliers) > -1e-9
    assert np.min(sol.contact_multipliers) > -1e-9
    # the compiled and the JAX energies sum the folds in different orders (and may contract
    # multiply-adds differently on another CPU): a few hundred ulp of Π apart
    assert sol.energy == pytest.approx(model.energy(sol.q), rel=1e-13, abs=1e-15)
    # the compiled z_p and the JAX kernel sum the chain (Z ≈ 20 mm) in different orders: a few
    # ulp of Z apart
    assert sol.displacement == pytest.approx(model.load_displacement(sol.q), abs=1e-13)


def _closure_bound(model, force):
    """Largest end movement of a tube pressed shut by ``force``: each of its circular folds
    (in series) closes past flat by at most c·|F| (ModelOptions.contact_compliance)."""
    return model.layout.n_connectors * model.options.contact_compliance * abs(force) + 1e-9


def _connector_points(model):
    """Indices into the contact vector of each connector's points."""
    from biplan.geometry.chain import tables

    t = tables(model.layout)
    offset = 2 * model.layout.n_modules
    return [offset + np.flatnonzero(t.contact_conn == c) for c in range(model.layout.n_connectors)]


def _fold_force(law, w0, w1, length):
    """∫_0^L F(w(x)) dx over a linear field, by adaptive quadrature."""
    bps = [length * (b - w0) / (w1 - w0) for b in law.coefficients[3:]] if w1 != w0 else []
    pts = [x for x in bps if 0.0 < x < length] or None
    val, _ = quad(
        lambda x: float(law.force(w0 + (w1 - w0) * x / length)),
        0.0,
        length,
        points=pts,
        epsabs=1e-13,
        epsrel=1e-12,
    )
    return val


def _stiff_helical_tube(n_modules, k_circ=1.0, k_hel=1e3):
    return make_tube(n_modules, helical=LinearLaw(k_hel), circular=LinearLaw(k_circ))


def _one_module_linear_prediction(k_circ, k_hel):
    """Linearised 1-module tube (DOF γ, u with φ1 = u/H1, φ2 = −u/H2): the base TPC fields
    run from γ to γ − u, the helical field from 0 to −K u, and the end-edge centroid moves by
    z_p = γ − H u/(2 H1). Returns the stiffness matrix in (γ, u) and the load vector ∂z_p."""
    kmat = np.array(
        [
            [k_circ * H, -k_circ * H / 2],
            [-k_circ * H / 2, k_hel * A_LEN * K_WEDGE**2 / 3 + k_circ * H / 3],
        ]
    )
    dzp = np.array([1.0, -H / (2 * H1)])
    return kmat, dzp


# --------------------------------------------------------------------------------------------
# Reference state
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["model1", "model6", "model4"])
def test_relaxed_reference(name, request):
    m = request.getfixturevalue(name)
    ref = biplan.relaxed_reference(m)
    assert_equilibrium(m, ref)
    assert ref.energy < 1e-9
    assert ref.force == 0.0
    # the contact regularisation (ε = 1e-6) opens each closed fold by O(ε) only
    assert abs(ref.displacement) < 1e-5
    assert np.max(np.abs(ref.q)) < 1e-5
    assert ref.iterations >= 1


# --------------------------------------------------------------------------------------------
# Force and displacement control
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("force", [0.4, 1.2, 2.0])
def test_displacement_control_reaction_equals_applied_force(model6, reference6, force):
    fsol = biplan.solve_equilibrium(model6, Newton(), reference6, Load.of_force(force))
    assert_equilibrium(model6, fsol)
    assert fsol.force == force
    u = fsol.displacement
    assert np.sign(u) == np.sign(force)
    dsol = biplan.solve_equilibrium(model6, Newton(), reference6, Load.of_displacement(u))
    assert_equilibrium(model6, dsol)
    assert dsol.displacement == pytest.approx(u, abs=1e-10)
    assert dsol.force == pytest.approx(force, rel=1e-7, abs=1e-9)
    np.testing.assert_allclose(dsol.q, fsol.q, atol=1e-7)
    assert dsol.energy == pytest.approx(fsol.energy, rel=1e-8, abs=1e-12)


@pytest.mark.parametrize("force", [-0.1, -0.3])
def test_compression_of_the_closed_tube_is_carried_by_contact(model6, force):
    """Under compression every fold of the closed tube is pressed shut: the end does not move
    (up to the ε-regularisation and the contact compliance) and the contact reactions of
    each circular fold balance the end force."""
    sol = biplan.solve_equilibrium(model6, Newton(), model6.zeros(), Load.of_force(force))
    assert_equilibrium(model6, sol)
    assert abs(sol.displacement) < _closure_bound(model6, force)
    assert np.max(model6.contact_gaps(sol.q)) < 1e-9
    dzp = model6.load_gradient(sol.q)
    n = model6.layout.n_modules
    fields = model6.circular_fields(sol.q)
    for j, pts in enumerate(_connector_points(model6)):
        # the fold pressed past flat by c λ_∂ carries a sliver of the force elastically
        law = model6.tube.circular_laws[j]
        elastic = sum(_fold_force(law, a, b, ell) for a, b, ell in zip(*fields[j], strict=True))
        assert abs(elastic) < 1e-5 * abs(force)
        assert elastic - sol.contact_multipliers[pts].sum() == pytest.approx(
            force * dzp[3 * n + j], rel=1e-7
        )


@pytest.mark.parametrize("force", [-0.05, -0.3])
def test_compression_from_the_relaxed_reference(model6, reference6, force):
    """Warm-started from ``relaxed_reference`` (q and its multipliers), a compressive end
    force reaches the contact-carried equilibrium of the cold start. The reference's contact
    multipliers are smoothing artefacts (λ_∂·w_∂ = ε²/2 at gaps ~1e-9 mm); from them Newton
    drifts into penetration, so the solve is restarted from zero contact multipliers
    (``Newton.contact_restart``) and says so."""
    cold = biplan.solve_equilibrium(model6, Newton(), reference6.q, Load.of_force(force))
    assert_equilibrium(model6, cold)
    assert cold.restarts == 0
    sol = biplan.solve_equilibrium(model6, Newton(), reference6, Load.of_force(force))
    assert_equilibrium(model6, sol)
    assert abs(sol.displacement) < _closure_bound(model6, force)
    np.testing.assert_allclose(sol.q, cold.q, atol=1e-8)
    assert sol.restarts in (0, 1)
    if sol.restarts:
        assert "restarted from zero contact multipliers" in sol.message
        assert sol.iterations > cold.iterations


def test_held_contacts_have_bounded_multipliers(model4):
    """The fully bistable tube (no base fold) stepped to a 0.4 N end force: the contacts at
    the helical-fold starts of closed modules are held at w_∂ = 0 by the kinematics (their
    gradients lie in the span of the active constraints), so the smoothed rows alone (c = 0)
    admit no finite multiplier and Newton leaves them anywhere above ε²/(2·atol): 0.10,
    0.83, 3.3 and 13 N at 0.1 … 0.4 N. With the contact compliance c a held contact has
    ŵ = c λ_∂ and λ_∂ = ε/√(2c) (to the Newton tolerance on its row, whose scale is ε:
    within a factor 2); every other reaction stays below the end force."""
    eps, c = model4.options.contact_smoothing, model4.options.contact_compliance
    held = eps / np.sqrt(2.0 * c)
    rigid = biplan.Model(model4.tube, model4.options.with_(contact_compliance=0.0))
    largest = {}
    for m in (model4, rigid):
        sol = biplan.relaxed_reference(m)
        for force in (0.1, 0.2, 0.3, 0.4):
            sol = biplan.solve_equilibrium(m, Newton(), sol, Load.of_force(force))
            assert_equilibrium(m, sol)
            lam_c, gaps = sol.contact_multipliers, m.contact_gaps(sol.q)
            largest[m] = lam_c.max()
            if m is model4:
                assert lam_c.max() < force
                locked = np.abs(gaps) < 1e-12
                assert locked.any()
                assert np.all((lam_c[locked] > 0.5 * held) & (lam_c[locked] < 2.0 * held))
    assert largest[rigid] > 1.0 > 0.4 > largest[model4]


def test_contact_restart_only_after_a_failure(model6, reference6):
    """A warm start that converges is not restarted (same steps with and without the
    option), and a failed start without contact multipliers has nothing to restart."""
    load = Load.of_force(0.5)
    warm = biplan.solve_equilibrium(model6, Newton(), reference6, load)
    plain = biplan.solve_equilibrium(model6, Newton(contact_restart=False), reference6, load)
    assert warm.converged and warm.restarts == 0
    assert warm.iterations == plain.iterations
    np.testing.assert_array_equal(warm.z, plain.z)
    failed = biplan.solve_equilibrium(model6, Newton(max_steps=1), reference6.q, load)
    assert not failed.converged and failed.restarts == 0
    with pytest.raises(biplan.ConfigError, match="contact_restart"):
        Newton(contact_restart=1)


def test_solution_reports_its_load(model6, reference6):
    sol = biplan.solve_equilibrium(model6, Newton(), reference6, Load.of_displacement(0.3))
    assert sol.load.is_displacement_controlled
    q, lam, lam_c, mu = model6.split(sol.z)
    np.testing.assert_array_equal(q, sol.q)
    np.testing.assert_array_equal(lam, sol.multipliers)
    np.testing.assert_array_equal(lam_c, sol.contact_multipliers)
    assert sol.force == pytest.approx(-mu, abs=0)


@pytest.mark.parametrize("load", [Load.of_force(1.3), Load.of_displacement(0.9)], ids=["F", "U"])
def test_every_circular_fold_carries_the_end_force(model6, reference6, load):
    """Axial equilibrium of each connector (∂/∂γ_j of the Lagrangian): the line force
    integrated over the fold, minus the contact reactions on its boundary points, equals
    F ∂z_p/∂γ_j ≈ F — circular folds are springs in series (MODEL.md §17 item 1)."""
    sol = biplan.solve_equilibrium(model6, Newton(), reference6, load)
    assert_equilibrium(model6, sol)
    f_end = sol.force
    dzp = model6.load_gradient(sol.q)
    n = model6.layout.n_modules
    for j, (s, e, length) in enumerate(model6.circular_fields(sol.q)):
        law = model6.tube.circular_laws[j]
        total = sum(_fold_force(law, a, b, ell) for a, b, ell in zip(s, e, length, strict=True))
        reactions = sol.contact_multipliers[_connector_points(model6)[j]].sum()
        assert total - reactions == pytest.approx(f_end * dzp[3 * n + j], rel=1e-7, abs=1e-9)
        assert dzp[3 * n + j] == pytest.approx(1.0, abs=0.02)
        # mean line force = F/H: below the closed-branch peak F1 = k1 w1 for F < F1 H
        assert total / H == pytest.approx(f_end / H, rel=0.02)


# --------------------------------------------------------------------------------------------
# Closed forms with a stiff linear helical fold
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("force", [0.05, 0.2])
def test_one_module_series_spring_closed_form(force):
    """1-module tube, helical k = 1e3, circular k: the circular fold opens ≈ F/(kH)
    uniformly; the exact linearised 2-DOF solution predicts γ, u and z_p."""
    k_circ, k_hel = 1.0, 1e3
    m = biplan.Model(_stiff_helical_tube(1, k_circ, k_hel))
    ref = biplan.relaxed_reference(m)
    sol = biplan.solve_equilibrium(m, Newton(), ref, Load.of_force(force))
    assert_equilibrium(m, sol)
    kmat, dzp = _one_module_linear_prediction(k_circ, k_hel)
    gam, u = np.linalg.solve(kmat, force * dzp)
    assert sol.q[3] == pytest.approx(gam, rel=1e-6)
    assert sol.q[0] == pytest.approx(u, rel=1e-3)
    assert u < 0  # the helical fold opens (standard module: u < 0 opens)
    assert sol.q[1] == pytest.approx(u / H1, rel=2e-3)
    assert sol.q[2] == pytest.approx(-u / H2, rel=2e-3)
    assert sol.displacement == pytest.approx(dzp @ [gam, u], rel=1e-6)
    # the circular fold opens almost uniformly by F/(kH): mean exactly, ends within |u|
    (s, e, length) = m.circular_fields(sol.q)[0]
    mean = np.sum(length * (s + e) / 2) / H
    assert mean == pytest.approx(force / (k_circ * H), rel=1e-6)
    assert np.max(np.abs(np.concatenate([s, e]) - force / (k_circ * H))) <= abs(u)
    assert sol.displacement == pytest.approx(force / (k_circ * H), rel=1e-3)
    # the helical fold opens as a wedge hinged at the split point
    w0, wa = m.helical_boundary(sol.q)[0]
    assert wa == pytest.approx(-K_WEDGE * u, rel=1e-3)
    assert abs(w0) < 1e-9


def test_one_module_uniform_extension_under_displacement_control():
    """Prescribed end displacement U: the circular fold of a one-module tube with a stiff
    helical fold opens uniformly by ≈ U and the reaction is the series-spring force."""
    k_circ, k_hel = 0.9, 1e3
    m = biplan.Model(_stiff_helical_tube(1, k_circ, k_hel))
    ref = biplan.relaxed_reference(m)
    kmat, dzp = _one_module_linear_prediction(k_circ, k_hel)
    compliance = dzp @ np.linalg.solve(kmat, dzp)
    for u_end in (0.01, 0.05):
        sol = biplan.solve_equilibrium(m, Newton(), ref, Load.of_displacement(u_end))
        assert_equilibrium(m, sol)
        assert sol.displacement == pytest.approx(u_end, abs=1e-12)
        assert sol.force == pytest.approx(u_end / compliance, rel=1e-4)
        assert sol.force == pytest.approx(k_circ * H * u_end, rel=2e-3)
        s, e, _ = m.circular_fields(sol.q)[0]
        ends = np.concatenate([s, e])
        np.testing.assert_allclose(ends, u_end, rtol=2e-3)
        assert np.ptp(ends) < 1e-3 * u_end


def test_six_folds_in_series(model6):
    """Six circular folds in series (stiff helical folds, linear circular law k): z_p ≈ 6F/(kH),
    and each fold's mean opening is F ∂z_p/∂γ_j/(kH) exactly (linear law)."""
    k_circ, force = 1.0, 0.2
    m = biplan.Model(_stiff_helical_tube(6, k_circ))
    assert m.layout == model6.layout  # same compiled kernels
    ref = biplan.relaxed_reference(m)
    sol = biplan.solve_equilibrium(m, Newton(), ref, Load.of_force(force))
    assert_equilibrium(m, sol)
    assert sol.displacement == pytest.approx(6 * force / (k_circ * H), rel=1e-3)
    dzp = m.load_gradient(sol.q)
    pts = _connector_points(m)
    for j, (s, e, length) in enumerate(m.circular_fields(sol.q)):
        mean = np.sum(length * (s + e) / 2) / H
        react = sol.contact_multipliers[pts[j]].sum()
        assert k_circ * H * mean - react == pytest.approx(force * dzp[18 + j], rel=1e-8)
        assert mean == pytest.approx(force / (k_circ * H), rel=1e-3)
    # the tube is softer when the helical folds are softer (more compliance in series)
    soft = biplan.Model(_stiff_helical_tube(6, k_circ, k_hel=1.3))
    sol_soft = biplan.solve_equilibrium(soft, Newton(), ref, Load.of_force(force))
    assert_equilibrium(soft, sol_soft)
    assert sol_soft.displacement > sol.displacement


def test_phase_one_stiffness_is_bounded_by_series_circular_folds(model6, reference6):
    """Adding helical compliance can only soften the tube: F/U ≤ k1 H / N_c (rigid helical
    folds, uniform circular openings), and the bound is approached for stiff helical folds."""
    u_end = 0.1
    bound = CIRCULAR.stiffness[0] * H / model6.layout.n_connectors
    sol = biplan.solve_equilibrium(model6, Newton(), reference6, Load.of_displacement(u_end))
    assert_equilibrium(model6, sol)
    assert 0.5 * bound < sol.force / u_end < bound
    stiff = biplan.Model(
        biplan.Tube.uniform(
            **GEOMETRY, n_modules=6, helical=LinearLaw(1e4), circular=CIRCULAR, base_fold=True
        )
    )
    assert stiff.layout == model6.layout  # same compiled kernels
    s2 = biplan.solve_equilibrium(stiff, Newton(), stiff.zeros(), Load.of_displacement(u_end))
    assert_equilibrium(stiff, s2)
    assert sol.force / u_end < s2.force / u_end < bound
    assert s2.force / u_end == pytest.approx(bound, rel=2e-3)


# --------------------------------------------------------------------------------------------
# Exact equilibria at the zero-force points of the law
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("state", ["open", "hilltop", "mixed"])
@pytest.mark.parametrize("name", ["model1", "model6", "model4"])
def test_uniform_fold_states_are_exact_equilibria(name, state, request):
    """Closed helical folds (q_module = 0) with every circular fold uniformly at a zero-force
    point of its law (0, w_b or w_s) are equilibria at F = 0 with Π = Σ H Ψ(w)."""
    m = request.getfixturevalue(name)
    law = m.tube.circular_laws[0]
    nm, nc = m.layout.n_modules, m.layout.n_connectors
    w = {
        "open": [law.wells()[1]] * nc,
        "hilltop": [law.hilltop()] * nc,
        "mixed": [law.wells()[1] if j % 2 == 0 else 0.0 for j in range(nc)],
    }[state]
    q0 = np.concatenate([np.zeros(3 * nm), w])
    sol = biplan.solve_equilibrium(m, Newton(), q0, Load.of_force(0.0))
    assert_equilibrium(m, sol)
    np.testing.assert_allclose(sol.q, q0, atol=1e-6)
    assert sol.energy == pytest.approx(H * float(np.sum(law.energy_density(np.array(w)))), rel=1e-9)


# --------------------------------------------------------------------------------------------
# Energy along a displacement-controlled path
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("u_end", [0.5, 1.3])
def test_reaction_is_the_derivative_of_the_energy(model6, reference6, u_end):
    """dΠ/dU = F on an equilibrium path under displacement control (the reaction does the
    work); checked by central differences of independently solved states."""
    sol = biplan.solve_equilibrium(model6, Newton(), reference6, Load.of_displacement(u_end))
    assert_equilibrium(model6, sol)
    h = 1e-4
    e = []
    for du in (-h, h):
        s = biplan.solve_equilibrium(model6, Newton(), sol, Load.of_displacement(u_end + du))
        assert_equilibrium(model6, s)
        e.append(s.energy)
    assert (e[1] - e[0]) / (2 * h) == pytest.approx(sol.force, rel=1e-6)


def test_symmetric_path_peak_is_below_the_fold_capacity(model6, reference6):
    """Every circular fold carries the whole force, so the path force cannot exceed the capacity
    of a uniformly loaded fold, k1 w1 H ≈ 2.26 N (MODEL.md §17), and it rises monotonically
    with the phase-1 stiffness before the peak."""
    capacity = CIRCULAR.peak_force * H
    assert capacity == pytest.approx(2.26, abs=0.01)
    cur = reference6
    forces = []
    for u_end in np.arange(0.25, 2.01, 0.25):
        cur = biplan.solve_equilibrium(model6, Newton(), cur, Load.of_displacement(u_end))
        assert_equilibrium(model6, cur)
        forces.append(cur.force)
    forces = np.array(forces)
    assert forces.max() < capacity
    assert forces.max() > 0.85 * capacity
    k = int(np.argmax(forces))
    assert np.all(np.diff(forces[: k + 1]) > 0)
    assert forces[-1] < forces.max()  # softening past the peak


# --------------------------------------------------------------------------------------------
# Failure modes and validation
# --------------------------------------------------------------------------------------------
def test_non_convergence_is_reported(model6):
    sol = biplan.solve_equilibrium(model6, Newton(max_steps=1), None, Load.of_displacement(2.0))
    assert sol.status is not Status.CONVERGED
    assert not sol.converged
    assert np.isfinite(sol.residual_norm)
    assert sol.residual_norm > TOL
    assert sol.residual_norm == pytest.approx(
        np.max(np.abs(model6.residual(sol.z, sol.load))), rel=1e-12
    )
    with pytest.raises(ConvergenceError):
        biplan.solve_equilibrium(
            model6, Newton(max_steps=1), None, Load.of_displacement(2.0), throw=True
        )
    with pytest.raises(ConfigError):
        biplan.classify(model6, sol)


def test_bad_inputs_raise_config_error(model1):
    with pytest.raises(ConfigError):
        biplan.solve_equilibrium(model1, Newton(), None, "F=1")
    with pytest.raises(ConfigError):
        biplan.solve_equilibrium(model1, Newton(), None, (1.0, 0.0, 0.0))
    for bad in (math.nan, math.inf, "x"):
        with pytest.raises(ConfigError):
            Load.of_force(bad)
        with pytest.raises(ConfigError):
            Load.of_displacement(bad)
    with pytest.raises(ConfigError):
        biplan.solve_equilibrium(model1, Newton(), np.zeros(3), Load.of_force(0.1))
    with pytest.raises(ConfigError):
        biplan.solve_equilibrium(model1, Newton(), np.full(4, np.nan), Load.of_force(0.1))
    for kwargs in ({"atol": 0.0}, {"atol": -1.0}, {"max_steps": 0}, {"armijo": 0.7}):
        with pytest.raises(ConfigError):
            Newton(**kwargs)


# --------------------------------------------------------------------------------------------
# Newton watchdog (free steps)
# --------------------------------------------------------------------------------------------
def test_watchdog_returns_the_best_of_its_free_steps(model1):
    """With free steps the iterates are those of plain Newton; a solve whose free steps run
    out unconverged goes back to the iterate of smallest merit ½‖r‖² (here it also hits the
    step limit, so that is what it returns)."""
    from biplan._compile.setup import jnp
    from biplan.model.assembly import autodiff_functions

    kk = autodiff_functions(model1.layout)
    rng = np.random.default_rng(3)
    load = Load.of_displacement(1.0)
    jload = Load(*(jnp.asarray(float(v)) for v in load))
    picked = set()
    for _ in range(5):
        zs = [model1.pack(rng.normal(scale=0.5, size=model1.n_coordinates))]
        for _ in range(3):
            r = np.asarray(kk.residual(model1.params, zs[-1], jload))
            jac = np.asarray(kk.jacobian(model1.params, zs[-1], jload))
            zs.append(zs[-1] + np.linalg.solve(jac, -r))
        merit = [0.5 * np.sum(np.asarray(kk.residual(model1.params, z, jload)) ** 2) for z in zs]
        sol = biplan.solve_equilibrium(model1, Newton(max_steps=3, free_steps=3), zs[0], load)
        assert sol.status is Status.MAX_STEPS
        best = int(np.argmin(merit))
        picked.add(best)
        assert np.allclose(sol.z, zs[best], rtol=1e-9, atol=1e-9)
    assert len(picked) > 1  # not always the last (or the first) iterate


def test_watchdog_reaches_the_same_equilibrium_with_fewer_residuals(model6, reference6):
    """Off the relaxed reference every contact touches (gap 0) and the merit of the smoothed
    Fischer–Burmeister rows is so curved that the line search rejects converging full steps;
    the watchdog takes them (the design map's first load steps, docs/maps.md)."""
    from biplan._compile.setup import jnp
    from jax_oracle.newton import settings_of, solve_loop

    load = Load(jnp.asarray(0.1), jnp.asarray(0.0), jnp.asarray(0.0))
    z0 = jnp.asarray(reference6.z)
    out = {}
    for free in (0, 8):
        settings = settings_of(Newton(max_backtracks=12, free_steps=free))
        out[free] = solve_loop.compiled(model6.layout)(model6.params, z0, load, settings)[0]
        assert int(out[free].status) == Status.CONVERGED.value
    n = model6.n_coordinates
    assert np.allclose(out[8].z[:n], out[0].z[:n], atol=1e-9)
    assert int(out[8].evals) < int(out[0].evals)


def test_traced_watchdog_of_length_zero_takes_the_plain_iterates(model1):
    """The scalar loop traces the watchdog length (one kernel for every ``Newton``); with
    length 0 it takes exactly the iterates of the loop compiled without a watchdog."""
    import functools

    from biplan._compile.setup import jax, jnp, xla_options
    from jax_oracle.newton import newton_loop, settings_of, solve_loop

    plain = jax.jit(functools.partial(newton_loop, model1.layout, free_steps=0),
                    compiler_options=xla_options(runs_often=True))  # fmt: skip
    rng = np.random.default_rng(5)
    load = Load(jnp.asarray(0.0), jnp.asarray(0.8), jnp.asarray(1.0))
    settings = settings_of(Newton(max_steps=40, free_steps=0))
    for _ in range(4):
        z0 = jnp.asarray(model1.pack(rng.normal(scale=0.3, size=model1.n_coordinates)))
        a = solve_loop.compiled(model1.layout)(model1.params, z0, load, settings)[0]
        b = plain(model1.params, z0, load, settings)
        for field in ("z", "status", "steps", "evals"):
            np.testing.assert_array_equal(np.asarray(getattr(a, field)),
                                          np.asarray(getattr(b, field)))  # fmt: skip


def test_watchdog_length_is_checked():
    with pytest.raises(ConfigError, match="free_steps"):
        Newton(free_steps=-1)
    with pytest.raises(ConfigError, match="free_steps"):
        Newton(free_steps=2.0)
    assert Newton(max_steps=5, free_steps=5).free_steps == 5


def test_state_returned_by_the_solve_equals_a_fresh_evaluation(model6, reference6):
    """The solve kernel returns the state's data from the Jacobian of its last Newton pass
    (``lagrangian.state_from_jacobian``); it equals ``state_data`` evaluated afresh at the
    solution, under force and displacement control."""
    for load in (Load.of_force(1.2), Load.of_displacement(2.0)):
        sol = biplan.solve_equilibrium(model6, Newton(), reference6, load)
        assert sol.converged
        fresh = model6.state(sol.z, load)
        for name in fresh._fields:
            a, b = getattr(sol.data, name), getattr(fresh, name)
            for x, y in zip(np.atleast_1d(a), np.atleast_1d(b), strict=True):
                np.testing.assert_allclose(x, y, rtol=0, atol=1e-10 * max(1.0, np.max(np.abs(y))))
