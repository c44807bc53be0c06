"""The compiled dynamics (:mod:`biplan.model.system.inertia`, :mod:`biplan.solvers.step_loop`)
equal the JAX dynamics (:mod:`biplan.model.inertia`, and the reference time loop of
``tests/jax_oracle/dynamics.py`` on the JAX model's terms), under every chain reading.

* the quadrature points, their Jacobians and velocity-quadratic terms, the weights, the mass
  matrix, the inertia force, the kinetic energy and the exact derivative of the inertia rows of
  a step equal JAX's (autodiff) to 1e-10 on layouts with and without a base fold and without
  connectors, on the default chain, under R3 ``EDGE_FIT`` (curved frame angles: the
  semi-bistable design and the fully bistable four-module tube) and under R1 ``PAPER``; the
  step's Jacobian equals central differences of the compiled inertia rows;
* the increments' third derivatives (hand-written on the default chain, forward-mode jets under
  the other readings) equal finite differences, their values and first two derivatives the
  statics' (:func:`biplan.model.system.chainterm._increment`, :func:`.readings.increment`);
* the damped Newton of a step takes the iterates of :func:`biplan.solvers.iteration.newton`;
* the paper's ramp, a snap with contact impacts (backward Euler) and the fully bistable tube
  under ``EDGE_FIT`` (a generalized-α ramp, a damped snap) take the same steps, retries and
  Newton iterations as the reference time loop on the JAX model and end in the same state,
  with the same energy balance.
"""

from __future__ import annotations

import functools
import subprocess
import sys

import numpy as np
import pytest

import biplan
from biplan._compile.setup import jax, jnp, xla_options
from biplan.geometry.layout import TubeLayout
from biplan.model import inertia as jax_inertia
from biplan.model.assembly import Load
from biplan.model.system import chainterm, elements, increments, inertia, quadrature, readings
from biplan.options import ChainAttachment, ChainOffset, ModelOptions
from biplan.solvers import BackwardEuler, ControlKind, iteration
from biplan.solvers.dynamics import mass_matrix_at
from conftest import make_tube
from jax_oracle import dynamics as _jax_dynamics

TOL = 1e-10

#: Small layouts (the JAX reference compiles per layout, its graph unrolled over the chain):
#: the clamp's translation, a TPC and an SPC; module 0 at the identity; no connector at all;
#: the chain readings of tests/test_system_oracle.py (R3 ``EDGE_FIT``: the base connector's
#: clamp line, split edges, curved frame angles; R1 ``PAPER``: SPC frames turned by the lower
#: element). The six-module design is compared through whole trajectories below.
LAYOUTS = {
    "two modules on a base fold": lambda: make_tube(2),
    "three modules, no base fold": lambda: make_tube(3, base_fold=False),
    "one module, no connector": lambda: make_tube(1, base_fold=False),
    "two modules on a base fold, edge fit": lambda: make_tube(2).with_options(
        chain_attachment=ChainAttachment.EDGE_FIT
    ),
    "paper offset": lambda: make_tube(3).with_options(chain_offset=ChainOffset.PAPER),
    "fully bistable, edge fit": lambda: biplan.designs.fully_bistable(),
    "semi-bistable, edge fit": lambda: biplan.designs.semi_bistable(
        ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT)
    ),
}
#: About a minute of JAX compilation each.
SLOW = ("semi-bistable, edge fit",)
CASES = [pytest.param(name, marks=pytest.mark.slow) if name in SLOW else name for name in LAYOUTS]


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    b = np.asarray(b)
    return float(np.max(np.abs(np.asarray(a) - b)) / max(np.max(np.abs(b)), 1e-300))


@functools.partial(jax.jit, static_argnums=0, compiler_options=xla_options())
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


@pytest.mark.parametrize("name", CASES)
def test_inertia_equals_jax(name, rng):
    model = biplan.Model(LAYOUTS[name]())
    d, n_q = model.system().data, model.n_coordinates
    if "edge fit" in name or "paper" in name:  # the reading under test
        assert d.flags[2 if "edge fit" in name else 3] == 1
    q = 0.05 * rng.normal(size=n_q)
    v, a = rng.normal(size=n_q), rng.normal(size=n_q)
    q0 = q + 0.01 * rng.normal(size=n_q)
    mu, c_v, c_m = model.tube.surface_density, 37.0, 1.3e4
    args = (jnp.asarray(x) for x in (q, v, a, q0))
    ref = [np.asarray(x) for x in _jax_inertia(model.layout, model.params, *args, mu, c_v, c_m)]
    pts, jac, hvv = quadrature.quadrature(d, q, v, True)
    assert _relative(pts, ref[0]) < TOL
    assert _relative(jac, ref[1]) < TOL
    assert _relative(hvv, ref[2]) < TOL
    assert _relative(quadrature.quadrature_weights(d, mu), ref[3]) < TOL
    m = inertia.mass_matrix(d, q, mu)
    assert _relative(m, ref[4]) < TOL
    assert _relative(inertia.inertia_force(d, q, v, a, mu), ref[5]) < TOL
    assert inertia.kinetic_energy(d, q, v, mu) == pytest.approx(0.5 * v @ ref[4] @ v, rel=TOL)
    kinetic, work = inertia.kinetic_and_work(d, q, v, a, mu)
    assert kinetic == pytest.approx(0.5 * v @ ref[4] @ v, rel=TOL)
    assert work == pytest.approx(a @ ref[4] @ v, rel=TOL)
    data = inertia.step_data(q0, v, a, c_v, c_m, mu)
    r, k = np.zeros(n_q), np.zeros((n_q, n_q))
    inertia.add_inertia(d, q, data, r, k, True)
    assert _relative(r, ref[6]) < TOL
    assert _relative(k, ref[7]) < TOL
    # the public mass matrix goes through the compiled system
    assert _relative(mass_matrix_at(model, q), ref[4]) < TOL
    # the step's Jacobian against central differences of the compiled inertia rows
    h, fd, none = 1e-6, np.zeros((n_q, n_q)), np.zeros((0, 0))
    for j in range(n_q):
        step = np.zeros(n_q)
        step[j] = h
        up, down = np.zeros(n_q), np.zeros(n_q)
        inertia.add_inertia(d, q + step, data, up, none, False)
        inertia.add_inertia(d, q - step, data, down, none, False)
        fd[:, j] = (up - down) / (2 * h)
    assert _relative(k, fd) < 1e-6


def _increment3(x, v, d, c):  # type: ignore[no-untyped-def]
    """:func:`increments.increment3` as a tuple (α, ∇α, ∇²α, ∂(vᵀ∂²α v), t, ∂t, ∂²t,
    ∂(vᵀ∂²t v))."""
    out = (np.zeros(7), np.zeros((7, 7)), np.zeros(7))
    out += (np.zeros(2), np.zeros((2, 7)), np.zeros((2, 7, 7)), np.zeros((2, 7)))
    alpha = increments.increment3(x, v, d, c, *out, np.zeros((3, 7)))
    return (alpha, *out)


def test_line_height_and_its_third_derivative(rng):
    h = 1e-6
    for _ in range(3):
        u, phi, pz, ps, ze, s = rng.normal(size=6) * (0.1, 0.3, 1.0, 1.0, 3.0, 5.0)
        h0, h1, h2, h3 = increments.line_height3(u, phi, pz, ps, ze, s)
        assert np.allclose((h0, h1, h2), elements.line_height(u, phi, pz, ps, ze, s), rtol=1e-14)
        up = increments.line_height3(u, phi + h, pz, ps, ze, s)[2]
        dn = increments.line_height3(u, phi - h, pz, ps, ze, s)[2]
        assert h3 == pytest.approx((up - dn) / (2 * h), rel=1e-6, abs=1e-8)


#: One tube per chain reading: the default chain, R3 ``EDGE_FIT``, R1 ``PAPER``.
READINGS = {
    "default": lambda: biplan.designs.semi_bistable(),
    "edge fit": lambda: biplan.designs.semi_bistable(
        ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT)
    ),
    "edge fit, no base fold": lambda: biplan.designs.fully_bistable(),
    "paper": lambda: make_tube(3).with_options(chain_offset=ChainOffset.PAPER),
}


@pytest.mark.parametrize("reading", READINGS)
def test_increments_and_their_third_derivatives(reading, rng):
    d = biplan.Model(READINGS[reading]()).system().data
    h = 1e-6
    default = d.flags[2] == 0 and d.flags[3] == 0
    for c in range(d.conn_upper.shape[0]):
        q = 0.1 * rng.normal(size=d.sizes[0])
        dofs = d.conn_dofs[c]
        free = dofs >= 0
        x, v = np.where(free, q[dofs], 0.0), np.where(free, rng.normal(size=7), 0.0)
        alpha, g, ha, a3, t, jt, ht, tvv = _increment3(x, v, d, c)
        if default:
            a2, tz, ts, j2, h2 = chainterm._increment(x, d, c, True)
            y, jac, hess = np.array([a2, tz, ts]), j2, h2
            assert not ha.any() and not a3.any()  # α_c is an element angle
        else:
            y, jac, hess = readings.increment(d, q, c)
        jac, hess = jac * free, hess * free[:, None] * free[None, :]
        np.testing.assert_allclose([alpha, *t], y, rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(np.concatenate([g[None], jt]) * free, jac, atol=1e-13)
        both = np.concatenate([ha[None], ht]) * free[:, None] * free[None, :]
        np.testing.assert_allclose(both, hess, rtol=1e-13, atol=1e-13)
        fd = np.zeros((3, 7))
        for k in np.flatnonzero(free):
            e = np.zeros(7)
            e[k] = h
            hp, hm = _increment3(x + e, v, d, c), _increment3(x - e, v, d, c)
            plus = np.concatenate([hp[2][None], hp[6]])
            minus = np.concatenate([hm[2][None], hm[6]])
            fd[:, k] = np.einsum("rij,i,j->r", plus - minus, v, v) / (2 * h)
        third = np.concatenate([a3[None], tvv]) * free
        np.testing.assert_allclose(third, fd, rtol=1e-6, atol=1e-8 * max(1.0, np.abs(fd).max()))


def test_massless_step_rows_leave_the_newton_iterates_unchanged(model6, reference6):
    """With zero mass the inertia rows of a step add nothing: the Newton on the step system
    takes the iterates, steps and status of the static KKT system."""
    system = model6.system(Load.of_displacement(5.0))
    n_q = model6.n_coordinates
    settings = iteration.newton_settings(1e-10, 60, 12, 1e-4, 0, levenberg_marquardt=False)
    zero = np.zeros(n_q)
    data = inertia.step_data(zero, zero, zero, 1.0, 1.0, 0.0)
    args = (system.data, system.load, reference6.z, settings, iteration.NO_BORDER, 0.0)
    out = iteration.solve(*args, data, iteration.NO_DEFLATION)
    ref = iteration.solve(*args, iteration.NO_STEP, iteration.NO_DEFLATION)
    assert out[4] == ref[4] and out[5] == ref[5] and out[4] > 3
    np.testing.assert_array_equal(out[0], ref[0])


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


def test_paper_ramp_equals_jax(model6, reference6, monkeypatch):
    scheme = biplan.GeneralizedAlpha()
    compiled = biplan.integrate(model6, scheme, reference6, t_end=2.0)
    _jax_dynamics.step_system.clear_cache()
    reference = _jax_dynamics.integrate(monkeypatch, model6, scheme, reference6, t_end=2.0)
    assert compiled.completed, compiled.message
    _same_run(compiled, reference, 1e-9)
    length = model6.tube.initial_length
    assert compiled.u_z[-1] / length == pytest.approx(reference.u_z[-1] / length, abs=1e-7)
    assert compiled.u_z[-1] / length == pytest.approx(0.045, abs=5e-4)  # README
    assert compiled.force[-1] == pytest.approx(reference.force[-1], abs=1e-7)
    # energy balance: T + Π − W + D is kept to the scheme's (tiny, quasi-static) dissipation
    assert np.ptp(compiled.total_energy) < 1e-6 * np.max(np.abs(compiled.external_work))
    # one input type per argument: every step reuses the first compilation of the step system
    assert _jax_dynamics.step_system._cache_size() == 1


def test_snap_with_contact_impacts_equals_jax(model6, reference6, monkeypatch):
    """A violent snap (folds into their contacts at m/s) with step retries: the exact
    derivative of the inertia rows keeps the compiled iteration on the reference loop's iterates."""
    s = biplan.solve_equilibrium(model6, None, reference6, Load.of_force(1.0))
    for f in np.arange(1.075, 2.05 + 1e-9, 0.075):
        s = biplan.solve_equilibrium(model6, None, s, Load.of_force(float(f)))
        assert s.converged, f
    history = biplan.LoadHistory(ControlKind.FORCE, (0.0, 0.25), (float(s.force), 2.4))
    scheme = BackwardEuler(time_step=0.01, rayleigh=100.0)
    compiled = biplan.integrate(model6, scheme, s, t_end=0.25, load=history)
    reference = _jax_dynamics.integrate(monkeypatch, model6, scheme, s, t_end=0.25, load=history)
    assert compiled.completed, compiled.message
    assert compiled.stats.n_rejected > 0 and compiled.kinetic_energy.max() > 1.0
    _same_run(compiled, reference, 1e-7)
    assert compiled.kinetic_energy[-1] < 1e-6  # settled


def test_edge_fit_trajectories_equal_jax(monkeypatch):
    """The fully bistable tube under R3 ``EDGE_FIT`` (curved frame angles): the paper's
    generalized-α ramp up to its first snap, then the snap itself, damped (backward Euler with
    Rayleigh damping, step retries), take the reference loop's steps, retries and iterations."""
    model = biplan.Model(biplan.designs.fully_bistable())
    assert model.system().data.flags[2] == 1
    start = biplan.relaxed_reference(model)
    scheme = biplan.GeneralizedAlpha()
    compiled = biplan.integrate(model, scheme, start, t_end=0.6)
    reference = _jax_dynamics.integrate(monkeypatch, model, scheme, start, t_end=0.6)
    assert compiled.completed, compiled.message
    _same_run(compiled, reference, 1e-10)
    # T + Π − W + D kept to the scheme's error, which grows towards the limit point
    assert np.ptp(compiled.total_energy) < 1e-4 * np.max(np.abs(compiled.external_work))
    snap = BackwardEuler(time_step=0.01, rayleigh=100.0)
    compiled = biplan.integrate(model, snap, start, t_end=0.8)
    reference = _jax_dynamics.integrate(monkeypatch, model, snap, start, t_end=0.8)
    assert compiled.completed, compiled.message
    assert compiled.stats.n_rejected > 0 and compiled.kinetic_energy.max() > 0.01
    _same_run(compiled, reference, 1e-7)


def test_dynamics_under_every_reading_import_no_jax():
    """The dynamics run compiled under R3 ``EDGE_FIT`` and R1 ``PAPER``: no JAX imported."""
    code = (
        "import sys, biplan\n"
        "from biplan.options import ChainOffset\n"
        "tubes = [biplan.designs.fully_bistable(),\n"
        "         biplan.designs.fully_bistable().with_options(chain_offset=ChainOffset.PAPER)]\n"
        "for tube in tubes:\n"
        "    model = biplan.Model(tube)\n"
        "    trajectory = biplan.integrate(model, t_end=0.05)\n"
        "    assert trajectory.completed, trajectory.message\n"
        "assert 'jax' not in sys.modules, 'jax imported by the dynamics'\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
