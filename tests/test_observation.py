"""The compiled observation (:mod:`biplan.solvers.observation`, Numba) equals the JAX one
(``jax_oracle.observe.observe_batch``) on states of the semi-bistable and the fully
bistable design: at rest, under displacement control before, inside and past the snaps
(unstable states and contact-locked ones included) and under force control; and its batched,
parallel kernel equals the one-state kernel fed the solver's Jacobian."""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan.model.params import Load
from biplan.solvers import observation
from jax_oracle.observe import Observation, kkt_min_eigenvalue, observe_batch

#: Displacements [mm] of the semi-bistable path (warm-started in turn from the reference).
PATH = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0)
#: Of those, the states observed.
OBSERVED = (0.5, 1.0, 3.0, 3.5, 5.0)


def _loads(rows: list[tuple[float, float, float]]) -> Load:
    """A Load of (k,) arrays from rows (F [N], U [mm], d)."""
    table = np.array(rows, dtype=float)
    return Load(table[:, 0], table[:, 1], table[:, 2])


@pytest.fixture(scope="module")
def semi_states(model6, reference6) -> tuple[np.ndarray, np.ndarray]:
    """(zs, loads (k, 3)) of the semi-bistable design."""
    zs, rows = [np.asarray(reference6.z)], [(0.0, 0.0, 0.0)]
    sol = reference6
    for u in PATH:
        sol = biplan.solve_equilibrium(model6, biplan.Newton(), sol, Load.of_displacement(u))
        if u in OBSERVED:
            assert sol.converged
            zs.append(np.asarray(sol.z))
            rows.append((0.0, u, 1.0))
    force = biplan.solve_equilibrium(model6, biplan.Newton(), reference6, Load.of_force(1.5))
    assert force.converged
    zs.append(np.asarray(force.z))
    rows.append((1.5, 0.0, 0.0))
    # the state at U = 3 mm under the force it carries: an equilibrium under force control
    z = zs[OBSERVED.index(3.0) + 1].copy()
    rows.append((-z[-1], 0.0, 0.0))
    z[-1] = 0.0
    zs.append(z)
    return np.array(zs), np.array(rows)


@pytest.fixture(scope="module")
def fully_states(model4_element) -> np.ndarray:
    """States at rest of the fully bistable design: the reference and the states a tube
    relaxes to once unloaded from points of a displacement path (stable and unstable ones,
    with folds open)."""
    model = model4_element
    ref = biplan.relaxed_reference(model)
    zs = [np.asarray(ref.z)]
    sol = ref
    for u in np.arange(0.5, 6.01, 0.5):
        sol = biplan.solve_equilibrium(model, biplan.Newton(), sol, Load.of_displacement(u))
        if u in (0.5, 2.5, 5.5, 6.0):
            rest = biplan.solve_equilibrium(model, biplan.Newton(), sol, Load.of_force(0.0))
            zs.append(np.asarray(rest.z))
    return np.array(zs)


def _assert_equal(ours: Observation, ref: Observation) -> None:
    """Field by field: values to 1e-10 relative (with a floor at round-off of the tiny
    energies of the reference state), λ_min to 1e-8 of max(1, |λ|), counts exact."""
    for name in ("force", "displacement", "u_z", "u_r", "theta"):
        np.testing.assert_allclose(getattr(ours, name), getattr(ref, name), rtol=1e-10, atol=1e-12)
    for name in ("energy", "fold_energy"):
        np.testing.assert_allclose(getattr(ours, name), getattr(ref, name), rtol=1e-10, atol=1e-13)
    np.testing.assert_allclose(ours.phase_fraction, ref.phase_fraction, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(ours.dof, ref.dof)
    np.testing.assert_array_equal(ours.n_active_contacts, ref.n_active_contacts)
    lam, lam_ref = ours.min_eigenvalue, np.asarray(ref.min_eigenvalue)
    np.testing.assert_array_equal(np.isinf(lam), np.isinf(lam_ref))
    finite = np.isfinite(lam_ref)
    scale = np.maximum(1.0, np.abs(lam_ref[finite]))
    assert np.all(np.abs(lam[finite] - lam_ref[finite]) <= 1e-8 * scale)
    np.testing.assert_allclose(ours.constraint_residual, ref.constraint_residual, atol=1e-12)
    np.testing.assert_allclose(ours.penetration, ref.penetration, atol=1e-12)


def test_semi_bistable_states_equal_jax(model6, semi_states):
    zs, rows = semi_states
    ours = observation.observe(model6.system(), zs, rows)
    _assert_equal(ours, observe_batch(model6.layout, model6.params, zs, _loads(list(rows))))
    # the path holds unstable states (inside the snap) and contact-locked ones (past it)
    assert np.any(ours.min_eigenvalue < -1e-3)
    assert np.any((ours.n_active_contacts > 0) & (ours.dof > 0))
    assert np.all(ours.dof[rows[:, 2] == 1.0] < model6.n_coordinates)


def test_fully_bistable_states_at_rest_equal_jax(model4_element, fully_states):
    model = model4_element
    ours = observation.observe(model.system(), fully_states)
    zeros = np.zeros(len(fully_states))
    _assert_equal(ours, observe_batch(model.layout, model.params, fully_states, Load(*[zeros] * 3)))
    assert np.any(ours.phase_fraction[:, :, 2] > 0.5)  # open folds
    assert np.any(ours.min_eigenvalue < 0.0) and np.any(ours.min_eigenvalue > 0.0)


def test_parallel_serial_and_one_state_agree(model6, semi_states):
    """Blocks on several threads, the serial kernel and the one-state kernel fed the Jacobian of
    :meth:`System.jacobian` give the same numbers, bit for bit."""
    zs, rows = semi_states
    zs, rows = np.concatenate([zs] * 3), np.concatenate([rows] * 3)  # a few per thread
    parallel = observation.observe(model6.system(), zs, rows, parallel=True)
    serial = observation.observe(model6, zs, rows, parallel=False)
    for field in Observation._fields:
        np.testing.assert_array_equal(getattr(parallel, field), getattr(serial, field))
    for i, (z, load) in enumerate(zip(zs[:12], rows[:12], strict=True)):
        system = model6.system(Load(*load))
        one = observation.observe_state(system.data, z, system.load, system.jacobian(z), False)
        for field, value in zip(Observation._fields, one, strict=True):
            np.testing.assert_array_equal(value, getattr(serial, field)[i], err_msg=field)


def test_loads_and_weak_contacts(model6, semi_states):
    zs, rows = semi_states
    system = model6.system()
    at_rest = observation.observe(system, zs[:1])
    explicit = observation.observe(system.data, zs[0], Load(0.0, 0.0, 0.0))
    for field in Observation._fields:
        np.testing.assert_array_equal(getattr(at_rest, field), getattr(explicit, field))
    # S1: a closed contact counts whatever its multiplier, so never fewer are active
    strong = observation.observe(system, zs, rows)
    weak = observation.observe(system, zs, rows, weak_contacts=True)
    assert np.all(weak.n_active_contacts >= strong.n_active_contacts)
    assert np.all(weak.dof <= strong.dof)
    for z, load, lam in zip(zs, rows, weak.min_eigenvalue, strict=True):  # the JAX test
        system = model6.system(Load(*load))
        jac = system.jacobian(z)
        gaps = system.state(z, jac).gaps
        ref = float(kkt_min_eigenvalue(model6.layout, z, jac, gaps, Load(*load).for_jax(), True))
        assert lam == ref or abs(lam - ref) <= 1e-8 * max(1.0, abs(ref))
    with pytest.raises(ValueError):
        observation.observe(system, np.zeros((0, model6.n_unknowns)))
