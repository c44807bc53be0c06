"""Deflation on the compiled system (:mod:`biplan.solvers.deflated_loop`).

Oracles: the JAX deflated system and Newton it replaced
(``jax_oracle.deflation``: ``deflated_system``, ``deflated_loop``): the same
residual and Jacobian, the same runs (status, root) and the same roots found by
:func:`~biplan.analysis.states.deflation.deflate`; the Newton core of the JAX kernel driven
through callbacks to the compiled deflated system (the same iterates); central finite
differences of the deflated residual and of log M.
"""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan._compile.numba_cache import kernel_array
from biplan._compile.setup import jax, jnp
from biplan.analysis.stability import classify
from biplan.analysis.states import deflation
from biplan.analysis.states.deflation import Deflation, deflate
from biplan.solvers import deflated_loop
from biplan.solvers.iteration import newton_settings
from biplan.solvers.status import Status
from jax_oracle import deflation as jax_deflation
from jax_oracle.core import iterate
from jax_oracle.settings import Settings

CFG = Deflation(n_perturbations=6)


@pytest.fixture(scope="module")
def known(model1):
    """Packed closed and open stable states of model1."""
    law = model1.tube.circular_laws[0]
    out = []
    for q0 in (np.zeros(4), np.array([0.0, 0.0, 0.0, law.wells()[1]])):
        sol = biplan.solve_equilibrium(model1, biplan.Newton(), q0)
        assert sol.converged and classify(model1, sol).stable
        out.append(sol.z)
    return np.stack(out)


@pytest.fixture(scope="module")
def found(model1, known):
    """:func:`deflate` from the two stable states."""
    return deflate(model1, known, CFG)


@pytest.fixture(scope="module")
def starts(model1, known, found):
    """The starts of :func:`deflate` (perturbations and the midpoint) and four perturbations of
    the first root it found, packed."""
    out = [model1.pack(q) for q, _ in deflation._starts(model1, known[:, :4], CFG)]
    rng = np.random.default_rng(5)
    q = found.equilibria[0].q
    return out + [model1.pack(q + 0.02 * rng.standard_normal(4)) for _ in range(4)]


def _jax_system(model, roots):
    padded, mask = jax_deflation.padded(list(roots))
    return jax_deflation.deflated_system(
        model.layout, model.params, jnp.asarray(padded), jnp.asarray(mask), 2.0, 1.0
    )


def test_deflated_system_equals_the_jax_system(model1, known, starts):
    d = model1.system().data
    roots = known[:, :4]
    residual, jacobian, log_m = (jax.jit(f) for f in _jax_system(model1, roots))
    for z in starts[::4]:
        r, jac, m = deflated_loop.deflated_system(d, z, roots, 2.0, 1.0, True)
        eta, grad = deflated_loop.log_deflation(z[:4], roots, 2.0, 1.0)
        assert m == pytest.approx(np.exp(float(log_m(jnp.asarray(z[:4])))), rel=1e-13)
        assert eta == pytest.approx(float(log_m(jnp.asarray(z[:4]))), rel=1e-13, abs=1e-15)
        ref_grad = np.asarray(jax.grad(log_m)(jnp.asarray(z[:4])))
        np.testing.assert_allclose(grad, ref_grad, rtol=1e-12, atol=1e-14)
        ref = np.asarray(residual(jnp.asarray(z)))
        assert np.max(np.abs(r - ref)) < 1e-13 * np.max(np.abs(ref))
        ref = np.asarray(jacobian(jnp.asarray(z)))
        assert np.max(np.abs(jac - ref)) < 1e-10 * np.max(np.abs(ref))
    far = starts[0].copy()
    far[0] = 2.0 * deflated_loop.ESCAPE
    assert np.all(np.isnan(deflated_loop.deflated_system(d, far, roots, 2.0, 1.0, False)[0]))


def test_deflated_jacobian_and_log_m_are_their_derivatives(model1, known, rng):
    d = model1.system().data
    roots = known[:, :4]
    z = known[0] + 0.05 * rng.standard_normal(known.shape[1])
    h = 1e-6
    jac = deflated_loop.deflated_system(d, z, roots, 2.0, 1.0, True)[1]
    fd = np.stack(
        [
            (
                deflated_loop.deflated_system(d, z + e, roots, 2.0, 1.0, False)[0]
                - deflated_loop.deflated_system(d, z - e, roots, 2.0, 1.0, False)[0]
            )
            / (2 * h)
            for e in np.eye(len(z)) * h
        ],
        axis=1,
    )
    np.testing.assert_allclose(jac, fd, rtol=1e-6, atol=1e-6 * np.max(np.abs(jac)))
    grad = deflated_loop.log_deflation(z[:4], roots, 3.0, 0.5)[1]
    fd = [
        (
            deflated_loop.log_deflation(z[:4] + e, roots, 3.0, 0.5)[0]
            - deflated_loop.log_deflation(z[:4] - e, roots, 3.0, 0.5)[0]
        )
        / (2 * h)
        for e in np.eye(4) * h
    ]
    np.testing.assert_allclose(grad, fd, rtol=1e-7, atol=1e-9)


def _core_newton(d, roots, n: int, cfg: Deflation):
    """The JAX kernel's deflated Newton (jax_oracle.core.iterate`, converged on the
    undeflated residual) driven through callbacks to the compiled deflated system and NumPy's
    solve (the Levenberg–Marquardt solves stay JAX's): the loop of the JAX kernel on the same
    numbers (jitted, of z (n,))."""

    def res(z):
        shape = jax.ShapeDtypeStruct((n,), jnp.float64)

        def fn(v):
            return deflated_loop.deflated_system(d, kernel_array(v), roots, 2.0, 1.0, False)[0]

        return jax.pure_callback(fn, shape, z)

    def jac(z):
        shape = jax.ShapeDtypeStruct((n, n), jnp.float64)

        def fn(v):
            return deflated_loop.deflated_system(d, kernel_array(v), roots, 2.0, 1.0, True)[1]

        return jax.pure_callback(fn, shape, z)

    def scale(z):
        shape = jax.ShapeDtypeStruct((), jnp.float64)

        def fn(v):
            return np.float64(deflated_loop.log_deflation(kernel_array(v), roots, 2.0, 1.0)[0])

        return jnp.exp(jax.pure_callback(fn, shape, z[:4]))

    def solve(a, b):
        shape = jax.ShapeDtypeStruct((n,), jnp.float64)
        return jax.pure_callback(lambda a, b: np.linalg.solve(a, b), shape, a, b)

    settings = Settings.of(cfg.tolerance, cfg.max_steps, deflation.BACKTRACKS)

    def converged(z, r):
        return jnp.max(jnp.abs(r)) < settings.atol * scale(z)

    return jax.jit(lambda z: iterate(res, jac, z, settings, converged=converged, solve=solve))


def test_deflated_newton_takes_the_jax_iterates(model1, known, starts):
    """Every start of :func:`deflate` from the two known states, and starts near the root it
    finds: the same status, steps and
    iterate as the Newton core on the same numbers, and the same outcome as the JAX kernel
    (the iterate of a failed run is compared only through its status and steps: such a run
    wanders far from the roots and takes Levenberg–Marquardt steps, whose solves stay JAX's,
    and their rounding grows with every step)."""
    d = model1.system().data
    roots = kernel_array(known[:, :4])
    settings = newton_settings(CFG.tolerance, CFG.max_steps, deflation.BACKTRACKS, 1e-4, 0)
    core = _core_newton(d, roots, len(starts[0]), CFG)
    padded, mask = jax_deflation.padded(list(roots))
    kernel = jax_deflation.deflated_loop.compiled(model1.layout)
    jax_settings = Settings.of(CFG.tolerance, CFG.max_steps, deflation.BACKTRACKS)
    outcomes = []
    for z0 in starts:
        z, status, res, steps = deflated_loop.deflated_newton(d, z0, roots, 2.0, 1.0, settings)
        out = core(jnp.asarray(z0))
        assert status == int(out.status)
        assert steps == int(out.steps)
        z_ref, status_ref, _ = kernel(
            model1.params, jnp.asarray(z0), padded, mask, 2.0, 1.0, jax_settings
        )
        assert status == int(status_ref)
        if status == Status.CONVERGED.value:
            assert np.max(np.abs(z - np.asarray(out.z))) < 1e-13 * max(1.0, np.max(np.abs(z)))
            assert res < CFG.tolerance
            assert np.max(np.abs(z[:4] - np.asarray(z_ref)[:4])) < 1e-9
        outcomes.append(status)
    assert outcomes.count(Status.CONVERGED.value) >= 4 and len(set(outcomes)) > 1


def test_deflate_finds_the_jax_roots(model1, known, found, monkeypatch):
    kernel = jax_deflation.deflated_loop.compiled(model1.layout)
    jax_settings = Settings.of(CFG.tolerance, CFG.max_steps, deflation.BACKTRACKS)

    def jax_run(system, z0, roots, cfg):
        padded, mask = jax_deflation.padded(roots)
        z, status, res = kernel(
            model1.params, jnp.asarray(z0), padded, mask, 2.0, 1.0, jax_settings
        )
        res = float(res)
        return np.asarray(z), res, int(status) == Status.CONVERGED.value and res < cfg.tolerance

    monkeypatch.setattr(deflation, "_deflated_newton", jax_run)
    ref = deflate(model1, known, CFG)
    counts = ("n_new", "n_stable", "n_runs", "n_converged", "n_inadmissible")
    assert [getattr(found, c) for c in counts] == [getattr(ref, c) for c in counts]
    assert found.n_new >= 1
    for e, e_ref in zip(found.equilibria, ref.equilibria, strict=True):
        assert e.start == e_ref.start
        assert np.max(np.abs(e.q - e_ref.q)) < 1e-9
        assert e.energy == pytest.approx(e_ref.energy, abs=1e-12)
        assert (e.stable, e.n_negative, e.bits, e.partial) == (
            e_ref.stable,
            e_ref.n_negative,
            e_ref.bits,
            e_ref.partial,
        )
        assert e.min_eigenvalue == pytest.approx(e_ref.min_eigenvalue, rel=1e-8)
