"""The compiled dynamics (:mod:`biplan.model.system.inertia`, :mod:`biplan.solvers.step_loop`)
equal the JAX dynamics (:mod:`biplan.model.inertia`, :mod:`biplan.solvers._dynkernel`).

* the quadrature points, their Jacobians and velocity-quadratic terms, the weights, the mass
  matrix, the inertia force, the kinetic energy and the exact derivative of the inertia rows of
  a step equal JAX's (autodiff) to 1e-10 on layouts with and without a base fold and without
  connectors; the increments' third derivatives equal finite differences;
* the damped Newton of a step takes the iterates of :func:`biplan.solvers.iteration.newton`;
* the paper's ramp and a snap with contact impacts (backward Euler) take the same steps,
  retries and Newton iterations as the JAX driver and end in the same state, with the same
  energy balance.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import biplan
from biplan._compile.setup import jax, jnp, kernel_options
from biplan.geometry.layout import TubeLayout
from biplan.model import inertia as jax_inertia
from biplan.model.assembly import Load
from biplan.model.system import chainterm, elements, inertia
from biplan.solvers import BackwardEuler, ControlKind, iteration
from biplan.solvers import _dynkernel as dk
from biplan.solvers.dynamics import mass_matrix_at
from conftest import make_tube

TOL = 1e-10

#: Small layouts (the JAX reference compiles per layout, its graph unrolled over the chain):
#: the clamp's translation, a TPC and an SPC; module 0 at the identity; no connector at all.
#: The six-module design is compared through whole trajectories below.
LAYOUTS = {
    "two modules on a base fold": lambda: make_tube(2),
    "three modules, no base fold": lambda: make_tube(3, base_fold=False),
    "one module, no connector": lambda: make_tube(1, base_fold=False),
}


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    b = np.asarray(b)
    return float(np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300))


@functools.partial(jax.jit, static_argnums=0, compiler_options=kernel_options())
def _jax_inertia(layout: TubeLayout, p, q, v, a, q0, mu, c_v, c_m):  # type: ignore[no-untyped-def]
    """The JAX quantities: points, ∂p/∂q, (∂²p)[v, v], weights, M, M a + c, and the inertia
    rows of a step (v, a affine in q) with their autodiff Jacobian."""

    def pts(qq):  # type: ignore[no-untyped-def]
        return jax_inertia.quadrature_points(layout, p, qq)

    def step(qq):  # type: ignore[no-untyped-def]
        return jax_inertia.inertia_force(
            layout, p, qq, v + c_v * (qq - q0), a + c_m * (qq - q0), mu
        )

    hvv = jax.jvp(lambda qq: jax.jvp(pts, (qq,), (v,))[1], (q,), (v,))[1]
    return (
        pts(q),
        jax.jacfwd(pts)(q),
        hvv,
        jax_inertia.quadrature_weights(layout, p, mu),
        jax_inertia.mass_matrix(layout, p, q, mu),
        jax_inertia.inertia_force(layout, p, q, v, a, mu),
        step(q),
        jax.jacfwd(step)(q),
    )


@pytest.mark.parametrize("name", LAYOUTS)
def test_inertia_equals_jax(name, rng):
    model = biplan.Model(LAYOUTS[name]())
    system = model.system()
    assert system is not None
    d, n_q = system.data, model.n_coordinates
    q = 0.05 * rng.normal(size=n_q)
    v, a = rng.normal(size=n_q), rng.normal(size=n_q)
    q0 = q + 0.01 * rng.normal(size=n_q)
    mu, c_v, c_m = model.tube.surface_density, 37.0, 1.3e4
    args = (jnp.asarray(x) for x in (q, v, a, q0))
    ref = [np.asarray(x) for x in _jax_inertia(model.layout, model.params, *args, mu, c_v, c_m)]
    pts, jac, hvv = inertia.quadrature(d, q, v, True)
    assert _relative(pts, ref[0]) < TOL
    assert _relative(jac, ref[1]) < TOL
    assert _relative(hvv, ref[2]) < TOL
    assert _relative(inertia.quadrature_weights(d, mu), ref[3]) < TOL
    m = inertia.mass_matrix(d, q, mu)
    assert _relative(m, ref[4]) < TOL
    assert _relative(inertia.inertia_force(d, q, v, a, mu), ref[5]) < TOL
    assert inertia.kinetic_energy(d, q, v, mu) == pytest.approx(0.5 * v @ ref[4] @ v, rel=TOL)
    kinetic, work = inertia.kinetic_and_work(d, q, v, a, mu)
    assert kinetic == pytest.approx(0.5 * v @ ref[4] @ v, rel=TOL)
    assert work == pytest.approx(a @ ref[4] @ v, rel=TOL)
    r, k = np.zeros(n_q), np.zeros((n_q, n_q))
    inertia.add_inertia(d, q, inertia.step_data(q0, v, a, c_v, c_m, mu), r, k, True)
    assert _relative(r, ref[6]) < TOL
    assert _relative(k, ref[7]) < TOL
    # the public mass matrix goes through the compiled system
    assert _relative(mass_matrix_at(model, q), ref[4]) < TOL


def test_increments_and_their_third_derivatives(model6, rng):
    d = model6.system().data
    h = 1e-6
    for _ in range(3):
        u, phi, pz, ps, ze, s = rng.normal(size=6) * (0.1, 0.3, 1.0, 1.0, 3.0, 5.0)
        h0, h1, h2, h3 = inertia.line_height3(u, phi, pz, ps, ze, s)
        assert np.allclose((h0, h1, h2), elements.line_height(u, phi, pz, ps, ze, s), rtol=1e-14)
        up = inertia.line_height3(u, phi + h, pz, ps, ze, s)[2]
        dn = inertia.line_height3(u, phi - h, pz, ps, ze, s)[2]
        assert h3 == pytest.approx((up - dn) / (2 * h), rel=1e-6, abs=1e-8)
    x, v = 0.1 * rng.normal(size=7), rng.normal(size=7)
    for c in range(d.conn_upper.shape[0]):
        alpha, g, t, jt, ht, tvv = inertia.increment3(x, v, d, c)
        a2, tz, ts, j2, h2_ = chainterm._increment(x, d, c, True)
        assert alpha == a2 and np.allclose(t, (tz, ts), rtol=1e-15, atol=1e-15)
        np.testing.assert_allclose(g, j2[0], atol=1e-15)
        np.testing.assert_allclose(jt, j2[1:], rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(ht, h2_[1:], rtol=1e-14, atol=1e-14)
        fd = np.zeros((2, 7))
        for k in range(7):
            e = np.zeros(7)
            e[k] = h
            hp = inertia.increment3(x + e, v, d, c)[4]
            hm = inertia.increment3(x - e, v, d, c)[4]
            fd[:, k] = np.einsum("rij,i,j->r", hp - hm, v, v) / (2 * h)
        np.testing.assert_allclose(tvv, fd, rtol=1e-6, atol=1e-8)


def test_massless_step_rows_leave_the_newton_iterates_unchanged(model6, reference6):
    """With zero mass the inertia rows of a step add nothing: the Newton on the step system
    takes the iterates, steps and status of the static KKT system."""
    system = model6.system(Load.of_displacement(5.0))
    n_q = model6.n_coordinates
    settings = iteration.settings_array(1e-10, 60, 12, 1e-4, 0, levenberg_marquardt=False)
    zero = np.zeros(n_q)
    data = inertia.step_data(zero, zero, zero, 1.0, 1.0, 0.0)
    args = (system.data, system.load, reference6.z, settings, iteration.NO_BORDER, 0.0)
    out = iteration.newton(*args, data)
    ref = iteration.newton(*args, iteration.NO_STEP)
    assert out[4] == ref[4] and out[5] == ref[5] and out[4] > 3
    np.testing.assert_array_equal(out[0], ref[0])


@pytest.fixture(scope="module")
def jax_model6() -> biplan.Model:
    """The six-module design without its compiled system: the JAX driver."""
    model = biplan.Model(biplan.designs.semi_bistable())
    model.system = lambda load=None: None  # type: ignore[method-assign]
    return model


def _same_run(compiled, reference, q_tol: float) -> None:
    assert compiled.status is reference.status
    assert compiled.stats.n_steps == reference.stats.n_steps
    assert compiled.stats.n_rejected == reference.stats.n_rejected
    assert compiled.stats.newton_iterations == reference.stats.newton_iterations
    np.testing.assert_array_equal(compiled.time, reference.time)
    assert np.max(np.abs(compiled.q - reference.q)) < q_tol * np.max(np.abs(reference.q))
    scale = np.max(np.abs(reference.external_work)) + np.max(reference.kinetic_energy)
    for name in ("kinetic_energy", "external_work", "dissipated_energy", "total_energy"):
        assert np.max(np.abs(getattr(compiled, name) - getattr(reference, name))) < 1e-7 * scale


def test_paper_ramp_equals_jax(model6, reference6, jax_model6):
    scheme = biplan.GeneralizedAlpha()
    compiled = biplan.integrate(model6, scheme, reference6, t_end=2.0)
    reference = biplan.integrate(jax_model6, scheme, reference6, t_end=2.0)
    assert compiled.completed, compiled.message
    _same_run(compiled, reference, 1e-9)
    length = model6.tube.initial_length
    assert compiled.u_z[-1] / length == pytest.approx(reference.u_z[-1] / length, abs=1e-7)
    assert compiled.u_z[-1] / length == pytest.approx(0.045, abs=5e-4)  # README
    assert compiled.force[-1] == pytest.approx(reference.force[-1], abs=1e-7)
    # energy balance: T + Π − W + D is kept to the scheme's (tiny, quasi-static) dissipation
    assert np.ptp(compiled.total_energy) < 1e-6 * np.max(np.abs(compiled.external_work))
    # strongly typed initial state of the JAX driver: later chunks reuse the first compilation
    assert dk.chunk.compiled(model6.layout)._cache_size() == 1


def test_snap_with_contact_impacts_equals_jax(model6, reference6, jax_model6):
    """A violent snap (folds into their contacts at m/s) with step retries: the exact
    derivative of the inertia rows keeps the compiled iteration on JAX's iterates."""
    s = biplan.solve_equilibrium(model6, None, reference6, Load.of_force(1.0))
    for f in np.arange(1.075, 2.05 + 1e-9, 0.075):
        s = biplan.solve_equilibrium(model6, None, s, Load.of_force(float(f)))
        assert s.converged, f
    history = biplan.LoadHistory(ControlKind.FORCE, (0.0, 0.25), (float(s.force), 2.4))
    scheme = BackwardEuler(time_step=0.01, rayleigh=100.0)
    compiled = biplan.integrate(model6, scheme, s, t_end=0.25, load=history)
    reference = biplan.integrate(jax_model6, scheme, s, t_end=0.25, load=history)
    assert compiled.completed, compiled.message
    assert compiled.stats.n_rejected > 0 and compiled.kinetic_energy.max() > 1.0
    _same_run(compiled, reference, 1e-7)
    assert compiled.kinetic_energy[-1] < 1e-6  # settled
