"""The state search's relaxation on the compiled system (:mod:`biplan.model.system.reduced`,
:mod:`biplan.solvers.relax_loop`).

Oracles: the JAX reduced coordinates, fold openings and penalised energy
(:mod:`biplan.model.elements.reduced`, autodiff), central finite differences, the JAX
endpoint under R3 ``EDGE_FIT``, and the KKT residual and stability test of the package at
every relaxed state.
"""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan._compile.setup import jax, jnp
from biplan.analysis.states import seeding
from biplan.analysis.states.catalogue import Enumeration
from biplan.analysis.states.labels import bistable_folds
from biplan.analysis.states.search import state_bits
from biplan.model import potential
from biplan.model.elements import reduced as oracle
from biplan.model.system import chainterm, endpoint, reduced
from biplan.options import ChainAttachment, ContactForm, TpcSign
from biplan.solvers import iteration, lanes, relax_loop
from biplan.solvers.fractions import phase_fractions
from conftest import make_tube

LAYOUTS = {
    "fully bistable, 3 modules, edge fit": lambda: biplan.designs.fully_bistable(n_modules=3),
    "fully bistable, 2 modules, element": lambda: biplan.designs.fully_bistable(
        n_modules=2, options=biplan.ModelOptions()
    ),
    "minimum contact, printed TPC sign, edge fit": lambda: make_tube(2).with_options(
        contact=ContactForm.MINIMUM,
        tpc_sign=TpcSign.AS_PRINTED,
        chain_attachment=ChainAttachment.EDGE_FIT,
    ),
}


@pytest.fixture(scope="module", params=list(LAYOUTS))
def model(request) -> biplan.Model:
    return biplan.Model(LAYOUTS[request.param]())


def _x(model: biplan.Model, rng: np.random.Generator, scale: float = 0.08) -> np.ndarray:
    return rng.uniform(-scale, scale, model.layout.n_modules + model.layout.n_connectors)


def test_reduced_kinematics_equal_the_jax_reading(model, rng) -> None:
    d = model.system().data
    for _ in range(3):
        x = _x(model, rng)
        q, d1, d2 = reduced.full_coordinates(d, x)
        q_ref = np.asarray(oracle.full_coordinates(model.layout, model.params, jnp.asarray(x)))
        np.testing.assert_allclose(q, q_ref, rtol=0, atol=1e-14)
        w, jac = reduced.fold_openings(d, x)
        w_ref = potential.fold_openings(model.layout, model.params, jnp.asarray(q_ref))
        np.testing.assert_allclose(w, np.asarray(w_ref), rtol=0, atol=1e-13)
        h = 1e-6
        fd = np.stack(
            [
                (reduced.fold_openings(d, x + h * e)[0] - reduced.fold_openings(d, x - h * e)[0])
                / (2 * h)
                for e in np.eye(len(x))
            ],
            axis=1,
        )
        np.testing.assert_allclose(jac, fd, rtol=0, atol=1e-7)
        # φ' and φ'' against central differences of the closed form
        step = 1e-5
        for m in range(model.layout.n_modules):
            e = np.zeros(len(x))
            e[m] = step
            q_p, d1_p, _ = reduced.full_coordinates(d, x + e)
            q_m, d1_m, _ = reduced.full_coordinates(d, x - e)
            fd1 = (q_p[3 * m + 1 : 3 * m + 3] - q_m[3 * m + 1 : 3 * m + 3]) / (2 * step)
            np.testing.assert_allclose(d1[m], fd1, rtol=1e-7, atol=1e-9)
            fd2 = (d1_p[m] - d1_m[m]) / (2 * step)
            np.testing.assert_allclose(d2[m], fd2, rtol=1e-6, atol=1e-8)


def test_penalized_energy_and_its_derivatives(model, rng) -> None:
    """The value against the JAX reading, the gradient and Hessian against central
    differences of the compiled value and gradient."""
    d = model.system().data
    stiffness = 1e4
    pressed = 0
    # compiled once (eager, each of its operations compiles on its own)
    jax_energy = jax.jit(
        lambda x: oracle.penalized_energy(model.layout, model.params, x, stiffness)
    )
    for _ in range(2):
        x = _x(model, rng)
        value, gaps = reduced.penalized_value(d, x, stiffness)
        grad, hess = reduced.penalized_derivatives(d, x, gaps, stiffness)
        ref = float(jax_energy(jnp.asarray(x)))
        assert value == pytest.approx(ref, rel=1e-12, abs=1e-13)
        h = 1e-6
        fd_g, fd_h = np.zeros_like(grad), np.zeros_like(hess)
        for i, e in enumerate(np.eye(len(x)) * h):
            vp, gp = reduced.penalized_value(d, x + e, stiffness)
            vm, gm = reduced.penalized_value(d, x - e, stiffness)
            fd_g[i] = (vp - vm) / (2 * h)
            dp = reduced.penalized_derivatives(d, x + e, gp, stiffness)[0]
            dm = reduced.penalized_derivatives(d, x - e, gm, stiffness)[0]
            fd_h[:, i] = (dp - dm) / (2 * h)
        scale = np.max(np.abs(hess))
        np.testing.assert_allclose(grad, fd_g, rtol=0, atol=1e-6 * scale)
        np.testing.assert_allclose(hess, fd_h, rtol=0, atol=1e-6 * scale)
        pressed += int(np.sum(gaps < 0.0))
    assert pressed > 0  # the penalty was exercised


def test_edge_fit_endpoint_and_height_equal_the_jax_chain(model, rng) -> None:
    d = model.system().data
    for _ in range(3):
        q = reduced.full_coordinates(d, _x(model, rng))[0]
        ref = model.endpoint(jnp.asarray(q))
        np.testing.assert_allclose(endpoint.endpoint(d, q), tuple(ref), rtol=0, atol=1e-13)
        zp = chainterm.load_height(d, q) - d.load_reference[0]
        assert zp == pytest.approx(model.load_displacement(q), abs=1e-13)
        frac = potential.phase_fractions(model.layout, model.params, jnp.asarray(q))
        np.testing.assert_allclose(phase_fractions(d, q), np.asarray(frac), atol=1e-13)


def test_positive_definite_test_and_descent_shift() -> None:
    floor = relax_loop.SHIFT_FLOOR
    assert relax_loop._positive_definite(np.diag([2.0, 1.0, 3.0]), floor)
    indefinite = np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    assert not relax_loop._positive_definite(indefinite, floor)
    assert not relax_loop._positive_definite(np.diag([floor / 2, 1.0, 1.0]), floor)


@pytest.fixture(scope="module")
def relaxed():
    model = biplan.Model(biplan.designs.fully_bistable(n_modules=2))
    folds = bistable_folds(model.tube)
    bits = seeding.seed_bits(np.arange(2 ** len(folds)), len(folds))
    target, mask = seeding.seed_targets(model, folds, bits)
    settings = Enumeration()
    newton = settings.newton
    method = iteration.newton_settings(
        newton.atol, newton.max_steps, newton.max_backtracks, newton.armijo, newton.free_steps
    )
    args = (float(settings.penalty_stiffness), int(settings.max_iterations), method)
    d = model.system().data
    k, n_z = len(target), model.n_unknowns
    batch = (np.empty((k, n_z)), np.empty(k, np.int64), np.empty(k), np.empty(k, np.int64))
    with lanes.limited(2):  # blocks of seeds on two threads
        lanes.run_rows(relax_loop.relax_rows, k, d, target, mask, *args, *batch)
    return model, d, target, mask, args, batch


def test_parallel_seeds_equal_one_seed_at_a_time(relaxed) -> None:
    _, d, target, mask, args, (zs, status, residual, iterations) = relaxed
    k, n_z = zs.shape
    for i in range(k):  # each seed alone, on this thread, into arrays of its own
        one = (np.full((k, n_z), np.nan), np.full(k, -1), np.full(k, np.nan), np.full(k, -1))
        relax_loop.relax_rows(d, target, mask, *args, *one, i, i + 1)
        np.testing.assert_array_equal(zs[i], one[0][i])
        assert (status[i], residual[i], iterations[i]) == (one[1][i], one[2][i], one[3][i])


def test_relaxed_seeds_are_equilibria_in_their_seeds_wells(relaxed) -> None:
    model, d, _, _, _, (zs, status, residual, _) = relaxed
    assert np.all(status == 0)
    assert np.all(residual < 1e-9)
    for z in zs:
        r = model.system().residual(z)
        assert np.max(np.abs(r)) < 1e-9
    # the descent never stops on a saddle: every seed reaches a stable state, whose fold
    # bits are those of its phase fractions
    folds = bistable_folds(model.tube)
    reached = seeding.evaluate(model, folds, np.arange(len(zs)), Enumeration())
    assert np.all(reached["min_eigenvalue"] > 0.0)
    for z, bits in zip(zs, reached["reached"], strict=True):
        assert state_bits(model, z[: d.sizes[0]]) == tuple(bits)
