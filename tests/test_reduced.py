"""Reduced coordinates (MODEL §16): the guides solved in closed form, and the penalised energy
and contact-only KKT system of the state search assembled per element in them.

Oracles: the guides of the full kinematics (:func:`biplan.model.potential.guide_values`), the
dense autodiff of the same functions written through the full coordinates, central finite
differences, and the full KKT residual of the package at the mapped state.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import biplan
from biplan._compile.setup import jax, jnp
from biplan.model.elements import reduced
from biplan.model.lagrangian import (
    full_state,
    reduced_kkt_jacobian_at_rest,
    reduced_residual_at_rest,
    residual_at_rest,
    sizes,
)
from biplan.model.potential import contact_gaps, energy, guide_values
from biplan.options import ContactForm, MirrorConvention, ModuleKind, TpcSign
from conftest import make_tube

LAYOUTS = {
    "fully bistable, 3 modules": lambda: biplan.designs.fully_bistable(n_modules=3),
    "base fold, point mirror, mirrored first": lambda: make_tube(2).with_options(
        mirror=MirrorConvention.POINT, first_module=ModuleKind.MIRRORED
    ),
    "minimum contact, printed TPC sign": lambda: make_tube(2).with_options(
        contact=ContactForm.MINIMUM, tpc_sign=TpcSign.AS_PRINTED
    ),
}


@pytest.fixture(scope="module", params=list(LAYOUTS))
def model(request) -> biplan.Model:
    return biplan.Model(LAYOUTS[request.param]())


def _random_x(model: biplan.Model, rng: np.random.Generator, scale: float = 0.3) -> jnp.ndarray:
    return jnp.asarray(rng.uniform(-scale, scale, reduced.n_reduced(model.layout)))


def test_closed_form_angles_satisfy_the_guides(model, rng) -> None:
    lay, p = model.layout, model.params
    for _ in range(5):
        x = _random_x(model, rng)
        q = reduced.full_coordinates(lay, p, x)
        assert np.abs(np.asarray(guide_values(lay, p, q))).max() < 1e-13
        np.testing.assert_array_equal(np.asarray(reduced.reduced_coordinates(lay, q)), x)
    # the branch through the reference configuration
    q0 = reduced.full_coordinates(lay, p, jnp.zeros(reduced.n_reduced(lay)))
    np.testing.assert_allclose(np.asarray(q0), 0.0, atol=1e-15)


def test_a_locked_module_has_no_angles(model) -> None:
    """Far beyond the kinematic lock (MODEL §16) the guide has no solution: NaN, not a
    silently wrong angle."""
    ref, n_c, _ = biplan.geometry.chain.reference_frames(model.layout, model.params.geometry)
    angles = reduced.module_angles(jnp.asarray(50.0), ref[0], n_c[0])
    assert np.any(np.isnan(np.asarray(angles)))


def test_penalized_terms_equal_the_dense_autodiff(model, rng) -> None:
    lay, p = model.layout, model.params
    k = jnp.asarray(1e4)

    def dense(x: jnp.ndarray) -> jnp.ndarray:
        q = reduced.full_coordinates(lay, p, x)
        gaps = contact_gaps(lay, p, q)
        return energy(lay, p, q) + 0.5 * k * jnp.sum(jnp.minimum(gaps, 0.0) ** 2)

    local = jax.jit(lambda x: reduced.penalized_terms(lay, p, x, k))
    value = jax.jit(lambda x: reduced.penalized_energy(lay, p, x, k))
    oracle = jax.jit(lambda x: (dense(x), jax.grad(dense)(x), jax.hessian(dense)(x)))
    for _ in range(4):
        x = _random_x(model, rng)  # contacts both open and penetrated
        t = local(x)
        e, g, h = oracle(x)
        scale = float(np.abs(np.asarray(h)).max())
        assert abs(float(t.value - e)) < 1e-10 * max(1.0, abs(float(e)))
        assert abs(float(value(x) - e)) < 1e-10 * max(1.0, abs(float(e)))
        np.testing.assert_allclose(np.asarray(t.gradient), np.asarray(g), atol=1e-10 * scale)
        np.testing.assert_allclose(np.asarray(t.hessian), np.asarray(h), atol=1e-10 * scale)


def test_reduced_terms_equal_the_dense_autodiff(model, rng) -> None:
    lay, p = model.layout, model.params
    _, _, nc = sizes(lay)
    lam_c = jnp.asarray(rng.uniform(0.0, 0.5, nc))

    def lagrangian(x: jnp.ndarray) -> jnp.ndarray:
        q = reduced.full_coordinates(lay, p, x)
        return energy(lay, p, q) - lam_c @ contact_gaps(lay, p, q)

    def gaps(x: jnp.ndarray) -> jnp.ndarray:
        return contact_gaps(lay, p, reduced.full_coordinates(lay, p, x))

    local = jax.jit(lambda x: reduced.reduced_terms(lay, p, x, lam_c))

    def derivatives(x: jnp.ndarray) -> tuple[jnp.ndarray, ...]:
        return jax.grad(lagrangian)(x), gaps(x), jax.hessian(lagrangian)(x), jax.jacfwd(gaps)(x)

    oracle = jax.jit(derivatives)
    for _ in range(3):
        x = _random_x(model, rng)
        t = local(x)
        for got, want in zip(t, oracle(x), strict=True):
            scale = max(1.0, float(np.abs(np.asarray(want)).max()))
            np.testing.assert_allclose(np.asarray(got), np.asarray(want), atol=1e-11 * scale)


def test_reduced_kkt_jacobian_matches_finite_differences(model, rng) -> None:
    lay, p = model.layout, model.params
    _, _, nc = sizes(lay)
    lam_c = jnp.asarray(rng.uniform(0, 0.3, nc))
    v = jnp.concatenate([_random_x(model, rng, 0.1), lam_c, jnp.asarray([0.2])])
    res = jax.jit(functools.partial(reduced_residual_at_rest, lay, p))
    jac = np.asarray(jax.jit(functools.partial(reduced_kkt_jacobian_at_rest, lay, p))(v))
    h = 1e-6
    fd = np.stack(
        [
            (np.asarray(res(v.at[i].add(h))) - np.asarray(res(v.at[i].add(-h)))) / (2 * h)
            for i in range(v.shape[0])
        ],
        axis=1,
    )
    np.testing.assert_allclose(jac, fd, atol=1e-6 * max(1.0, np.abs(fd).max()))


def test_a_reduced_solution_is_a_full_equilibrium(model4) -> None:
    """Newton on the reduced KKT system from a relaxed seed: mapped back (q(x), the guide
    multipliers by least squares), the full KKT residual of the package vanishes too."""
    from biplan.analysis.states.catalogue import Enumeration
    from biplan.analysis.states.labels import bistable_folds
    from biplan.analysis.states.seeding import relax_seeds, seed_bits, seed_targets

    lay, p = model4.layout, model4.params
    folds = bistable_folds(model4.tube)
    target, mask = seed_targets(model4, folds, seed_bits(np.array([0b0011011]), len(folds)))
    s = Enumeration()
    zs, status, residual = relax_seeds(model4, target, mask, s)
    assert int(status[0]) == 0
    z = zs[0]
    nq, ng, _ = sizes(lay)

    @jax.jit  # one compiled function (eager, its operations compile one by one: ~30 s)
    def mapped(z: jnp.ndarray) -> tuple[jnp.ndarray, ...]:
        v = jnp.concatenate([reduced.reduced_coordinates(lay, z[:nq]), z[nq + ng :]])
        return (
            residual_at_rest(lay, p, z),
            v,
            reduced_residual_at_rest(lay, p, v),
            full_state(lay, p, v),
        )

    full, v, reduced_residual, back = (np.asarray(a) for a in mapped(jnp.asarray(z)))
    assert np.abs(full).max() < s.newton.atol
    assert abs(float(residual[0]) - np.abs(full).max()) < 1e-15
    # the state is the full state of its own reduced coordinates
    assert np.abs(reduced_residual).max() < 1e-8
    np.testing.assert_allclose(back, z, atol=1e-12)
    assert v.shape[0] == reduced.n_reduced(lay) + z.shape[0] - nq - ng


def test_observation_at_rest_equals_the_general_one_at_zero_load(model4) -> None:
    """The at-rest kernel (no Hessian of the load point) observes what the general kernel
    observes under a zero end load, on relaxed states and on states off equilibrium."""
    from biplan.analysis.states.catalogue import Enumeration
    from biplan.analysis.states.labels import bistable_folds
    from biplan.analysis.states.seeding import relax_seeds, seed_bits, seed_targets
    from biplan.model.params import Load
    from jax_oracle.observe import observe_batch

    lay, p = model4.layout, model4.params
    folds = bistable_folds(model4.tube)
    target, mask = seed_targets(model4, folds, seed_bits(np.array([0, 27, 100]), len(folds)))
    zs, status, _ = relax_seeds(model4, target, mask, Enumeration())
    assert np.all(status == 0)
    rng = np.random.default_rng(3)
    z = np.concatenate([zs, zs + rng.uniform(-1e-3, 1e-3, zs.shape)])
    zero = np.zeros(len(z))
    general = observe_batch(lay, p, z, Load(zero, zero, zero))  # the kernels of the package
    rest = observe_batch(lay, p, z, None)
    for name, a, b in zip(general._fields, general, rest, strict=True):
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12, err_msg=name)
