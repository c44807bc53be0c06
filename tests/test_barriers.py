"""Energy barriers (constrained climbing-image NEB), departure loads and deflation.

Closed forms come from ``model1``: one module on a base circular fold with a linear helical
fold. Its only bistable fold is the circular one; opening it uniformly (γ) is the soft path,
so the two stable states are γ = 0 and γ = w_s (the law's open well), the saddle is γ = w_b
(the hilltop), the barriers are 2πR (Ψ(w_b), Ψ(w_b) − Ψ(w_s)) and the reduced Hessian's
negative eigenvalue there is 2πR k2. The end force at which the closed state snaps open is the
law's peak force times 2πR.
"""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan.analysis.stability import classify
from biplan.analysis.states.barriers import (
    MepStatus,
    NudgedElasticBand,
    edge_barriers,
    minimum_energy_path,
)
from biplan.analysis.states.deflation import Deflation, deflate
from biplan.analysis.states.departure import DepartureStatus, Ramp, departure_force
from biplan.solvers.newton import Status, make_solution


def _stable(model: biplan.Model, q0: np.ndarray) -> biplan.Solution:
    sol = biplan.solve_equilibrium(model, biplan.Newton(), q0)
    assert sol.converged
    assert classify(model, sol).stable
    return sol


@pytest.fixture(scope="module")
def states1(model1):
    """Closed and open stable states of model1."""
    law = model1.tube.circular_laws[0]
    closed = _stable(model1, np.zeros(4))
    opened = _stable(model1, np.array([0.0, 0.0, 0.0, law.wells()[1]]))
    return closed, opened


@pytest.fixture(scope="module")
def states4(model4):
    """Two stable states of the four-module tube: all closed, and the top connector open."""
    law = model4.tube.circular_laws[-1]
    closed = _stable(model4, np.zeros(model4.n_coordinates))
    q = np.zeros(model4.n_coordinates)
    q[-1] = law.wells()[1]
    return closed, _stable(model4, q)


@pytest.fixture(scope="module")
def mep1(model1, states1):
    a, b = states1
    return {n: minimum_energy_path(model1, a, b, NudgedElasticBand(n_images=n)) for n in (8, 16)}


def test_config_is_validated():
    with pytest.raises(biplan.ConfigError):
        NudgedElasticBand(n_images=2)
    with pytest.raises(biplan.ConfigError):
        NudgedElasticBand(spring=0.0)
    with pytest.raises(biplan.ConfigError):
        NudgedElasticBand(time_step=0.5, max_time_step=0.1)
    with pytest.raises(biplan.ConfigError):
        Deflation(power=0.5)
    with pytest.raises(biplan.ConfigError):
        Deflation(n_perturbations=-1)
    with pytest.raises(biplan.ConfigError):
        Ramp(stop=-1.0)


def test_single_fold_barrier_matches_closed_form(model1, mep1):
    law = model1.tube.circular_laws[0]
    length = 2 * np.pi * model1.tube.development.radius
    forward, backward = (length * b for b in law.barrier())
    for mep in mep1.values():
        assert mep.status is MepStatus.CONVERGED, mep.message
        assert mep.barrier_forward == pytest.approx(forward, rel=1e-6)
        assert mep.barrier_backward == pytest.approx(backward, rel=1e-6)
        q_saddle = mep.saddle_z[: model1.n_coordinates]
        assert q_saddle[-1] == pytest.approx(law.hilltop(), abs=1e-6)
        assert mep.n_negative == 1
        assert mep.saddle_eigenvalues[0] == pytest.approx(length * law.stiffness[1], rel=1e-6)


def test_barrier_converges_with_images(mep1):
    coarse, fine = mep1[8], mep1[16]
    # the refined saddles agree, and the band's own maximum approaches it as images are added
    assert fine.barrier_forward == pytest.approx(coarse.barrier_forward, rel=1e-6)
    gap = [abs(m.saddle_energy - m.energies.max()) / m.barrier_forward for m in (coarse, fine)]
    assert max(gap) < 1e-3


def test_band_lies_on_the_constraint_manifold(model1, mep1):
    mep = mep1[16]
    for q in mep.q:
        assert np.max(np.abs(model1.constraints(q))) < 1e-8
        assert model1.contact_gaps(q).min() > -1e-8
    assert np.all(np.diff(mep.arc_length) > 0)
    assert mep.energies[0] == pytest.approx(0.0, abs=1e-9)


def test_four_module_edge_saddle_is_first_order(model4, states4):
    a, b = states4
    (mep,) = edge_barriers(model4, [(a.z, b.z)], NudgedElasticBand(n_images=12))
    assert mep.status is MepStatus.CONVERGED, mep.message
    assert mep.barrier_forward > 0 and mep.barrier_backward > 0
    assert mep.n_negative == 1
    assert mep.saddle_residual < 1e-8
    assert mep.energies[0] == pytest.approx(a.energy, abs=1e-9)
    assert mep.energies[-1] == pytest.approx(b.energy, abs=1e-9)
    # the climbing image sits at the saddle: the band's maximum matches it
    assert abs(mep.energies.max() - mep.saddle_energy) < 1e-5 * mep.barrier_forward
    # the saddle is an equilibrium and unstable by the independent NumPy stability test
    sol = make_solution(
        model4, mep.saddle_z, biplan.Load.of_force(0.0), Status.CONVERGED, mep.saddle_residual, 0
    )
    assert classify(model4, sol).verdict is biplan.Verdict.UNSTABLE


def test_departure_force_bounded_by_uniform_opening(model1, states1):
    closed, opened = states1
    law = model1.tube.circular_laws[0]
    length = 2 * np.pi * model1.tube.development.radius
    dep = departure_force(model1, closed.z, opened.z)
    assert dep.status is DepartureStatus.FOUND, dep.message
    # the end load wedges the fold (and opens the helical fold), so the closed branch ends
    # before the uniform-opening limit 2πR F1 of the law, but not far before it
    assert 0.9 * length * law.peak_force < dep.force < length * law.peak_force
    assert dep.lands_in_target
    assert dep.landed_bits == (0, 1)
    # under compression the open state departs (no claim on where it lands)
    back = departure_force(model1, opened.z, closed.z)
    assert back.status is DepartureStatus.FOUND, back.message
    assert back.force < 0


def test_deflation_finds_the_saddle_between_two_wells(model1, states1):
    law = model1.tube.circular_laws[0]
    known = [s.z for s in states1]
    res = deflate(model1, known, Deflation(n_perturbations=6))
    assert res.n_new == len(res.equilibria) >= 1
    assert res.n_stable == sum(e.stable for e in res.equilibria)
    gammas = [e.q[-1] for e in res.equilibria]
    assert min(abs(g - law.hilltop()) for g in gammas) < 1e-6
    for e in res.equilibria:
        r = model1.residual(e.z, biplan.Load.of_force(0.0))
        assert np.max(np.abs(r)) < 1e-9
        assert all(np.max(np.abs(e.q - k[:4])) > 1e-5 for k in known)
        sol = make_solution(model1, e.z, biplan.Load.of_force(0.0), Status.CONVERGED, e.residual, 0)
        assert classify(model1, sol).stable == e.stable
        assert (e.n_negative == 0) == e.stable


def test_deflated_jacobian_is_the_derivative_and_gives_the_sherman_morrison_step(model1, states1):
    """The deflated system's Jacobian M J + r ∇Mᵀ equals central finite differences of M r, and
    its Newton step is the undeflated step d scaled by 1 / (1 − ∇η · d_q)."""
    from biplan._compile.setup import jax, jnp
    from jax_oracle.deflation import deflated_system

    nq = model1.n_coordinates
    roots = np.stack([s.z[:nq] for s in states1])
    mask = np.ones(len(roots), dtype=bool)
    residual, jacobian, log_m = deflated_system(
        model1.layout, model1.params, jnp.asarray(roots), jnp.asarray(mask), 2.0, 1.0
    )
    rng = np.random.default_rng(3)
    z = states1[0].z + 0.05 * rng.standard_normal(states1[0].z.shape)
    jac = np.asarray(jacobian(jnp.asarray(z)))
    h = 1e-6
    fd = np.stack(
        [
            (
                np.asarray(residual(jnp.asarray(z + h * e)))
                - np.asarray(residual(jnp.asarray(z - h * e)))
            )
            / (2 * h)
            for e in np.eye(len(z))
        ],
        axis=1,
    )
    np.testing.assert_allclose(jac, fd, rtol=1e-6, atol=1e-6 * np.max(np.abs(jac)))
    load = biplan.Load.of_force(0.0)
    d = -np.linalg.solve(model1.jacobian(z, load), model1.residual(z, load))
    grad = np.asarray(jax.grad(log_m)(jnp.asarray(z[:nq])))
    step = -np.linalg.solve(jac, np.asarray(residual(jnp.asarray(z))))
    np.testing.assert_allclose(step, d / (1.0 - grad @ d[:nq]), rtol=1e-8, atol=1e-12)
