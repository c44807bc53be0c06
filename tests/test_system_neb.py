"""The nudged elastic band on the compiled system (:mod:`biplan.solvers.band_loop`,
:mod:`biplan.solvers.manifold`).

Oracles: the JAX kernel it replaced (``jax_oracle.neb``: the return to the
manifold, the band forces and the whole relaxation take the same iterates up to rounding),
the JAX Newton refinement of the JAX band's climbing image (the same barriers), central finite
differences of the constraint rows, and the invariants of a relaxed band (on the manifold,
forces below the tolerance, the projected gradient orthogonal to the active rows).
"""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan._compile.numba_cache import kernel_array
from biplan._compile.setup import jax, jnp
from biplan.analysis.stability import classify
from biplan.analysis.states.barriers import NudgedElasticBand, minimum_energy_path
from biplan.model.params import Load
from biplan.solvers import band_loop, manifold
from biplan.solvers.newton import Status, make_solution
from jax_oracle import neb as _nebkernel
from jax_oracle.core import iterate
from jax_oracle.newton import settings_of, solve_loop
from jax_oracle.settings import Settings


def _stable(model: biplan.Model, q0: np.ndarray) -> np.ndarray:
    sol = biplan.solve_equilibrium(model, biplan.Newton(), q0)
    assert sol.converged and classify(model, sol).stable
    return sol.z


def _straight_band(model: biplan.Model, za: np.ndarray, zb: np.ndarray, n: int) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n)[:, None]
    nq = model.n_coordinates
    return (1.0 - t) * za[None, :nq] + t * zb[None, :nq]


@pytest.fixture(scope="module")
def edge(model4):
    """(data, straight band, NEB settings, compiled output, JAX output) of the edge all closed →
    top connector open of the four-module tube (12 images)."""
    q = np.zeros(model4.n_coordinates)
    q[-1] = model4.tube.circular_laws[-1].wells()[1]
    za, zb = _stable(model4, np.zeros(model4.n_coordinates)), _stable(model4, q)
    band0 = _straight_band(model4, za, zb, 12)
    settings = NudgedElasticBand(n_images=12).loop_settings()
    d = model4.system().data
    out = band_loop.fire_band(d, band0, settings)
    ref = _nebkernel.fire_band.compiled(model4.layout)(
        model4.params, jnp.asarray(band0), jnp.asarray(settings)
    )
    return d, band0, settings, out, ref


def test_constants_are_the_jax_kernels():
    assert manifold.ITERATIONS == _nebkernel.PROJECTION_ITERATIONS
    assert manifold.TOLERANCE == _nebkernel.PROJECTION_TOLERANCE
    fire = (
        band_loop.FIRE_N_MIN,
        band_loop.FIRE_INC,
        band_loop.FIRE_DEC,
        band_loop.FIRE_ALPHA0,
        band_loop.FIRE_FALPHA,
    )
    jax_fire = (
        _nebkernel.FIRE_N_MIN,
        _nebkernel.FIRE_INC,
        _nebkernel.FIRE_DEC,
        _nebkernel.FIRE_ALPHA0,
        _nebkernel.FIRE_FALPHA,
    )
    assert fire == jax_fire


def _core_return(d, n: int):
    """The JAX kernel's return (jax_oracle.core.iterate`, minimum-norm steps, no
    Levenberg–Marquardt, the watchdog) driven through callbacks to the compiled constraints and
    pseudo-inverse: the loop of the JAX kernel on the same numbers (jitted, of q (n,))."""
    m = int(d.sizes[1] + d.sizes[2])

    def res(x):
        shape = jax.ShapeDtypeStruct((m,), jnp.float64)
        return jax.pure_callback(lambda v: manifold.constraints(d, kernel_array(v))[0], shape, x)

    def jac(x):
        shape = jax.ShapeDtypeStruct((m, n), jnp.float64)
        return jax.pure_callback(lambda v: manifold.constraints(d, kernel_array(v))[1], shape, x)

    def solve(a, b):
        shape = jax.ShapeDtypeStruct((n,), jnp.float64)
        return jax.pure_callback(
            lambda a, b: manifold.pinv(kernel_array(a)) @ np.asarray(b), shape, a, b
        )

    settings = Settings.of(manifold.TOLERANCE, manifold.ITERATIONS, 1, 1e-4, 0)
    options = {"levenberg_marquardt": False, "solve": solve, "n_equations": m}
    return jax.jit(
        lambda q: iterate(res, jac, q, settings, free_steps=manifold.ITERATIONS, **options).z
    )


def test_return_to_the_manifold_takes_the_jax_iterates(model4, edge, rng):
    """The same iterates as the Newton core on the same numbers; from the straight band the
    same landing point as the JAX kernel (from elsewhere the two can land apart: where an
    iterate has a gap within rounding of zero, the sign of that rounding decides whether the
    contact row takes part in the next step)."""
    d, band0 = edge[0], edge[1]
    project = jax.jit(lambda x: _nebkernel.project(model4.layout, model4.params, x))
    core = _core_return(d, model4.n_coordinates)
    moved, reductions = 0.0, []
    for q in band0[1:-1]:
        ref = np.asarray(project(jnp.asarray(q)))
        assert np.max(np.abs(manifold.project(d, q) - ref)) < 1e-12
        for scale in (1e-4, 0.02):
            x = q + scale * rng.standard_normal(q.shape)
            p = manifold.project(d, x)
            assert np.max(np.abs(p - np.asarray(core(jnp.asarray(x))))) < 1e-15
            before = np.max(np.abs(manifold.constraints(d, x)[0]))
            after = np.max(np.abs(manifold.constraints(d, p)[0]))
            # four Gauss–Newton steps: where a contact switches on the way (which, near a
            # zero gap, rounding decides) the last of them may not yet be quadratic
            assert after < 1e-2 * before
            reductions.append(after / before)
            if after < manifold.TOLERANCE:  # on the manifold: it stays
                assert np.max(np.abs(manifold.project(d, p) - p)) < 1e-14
            moved = max(moved, float(np.max(np.abs(p - x))))
    assert moved > 1e-3  # the return did work
    # and most returns land on the manifold to rounding
    assert np.median(reductions) < 1e-10
    assert np.mean(np.asarray(reductions) < 1e-8) >= 0.75


def test_constraint_rows_are_their_derivative(model4, rng):
    d = model4.system().data
    ng, h = model4.n_guides, 1e-6
    for _ in range(3):
        q = 0.05 * rng.standard_normal(model4.n_coordinates)
        _, jac, gaps = manifold.constraints(d, q)
        fd = np.stack(
            [
                (manifold.constraints(d, q + e)[0] - manifold.constraints(d, q - e)[0]) / (2 * h)
                for e in np.eye(len(q)) * h
            ],
            axis=1,
        )
        smooth = np.concatenate([np.ones(ng, bool), np.abs(gaps) > 1e-4])  # off the kink
        assert np.any(gaps < -1e-4)  # penetrated contacts took part
        np.testing.assert_allclose(jac[smooth], fd[smooth], rtol=0, atol=1e-7)
        assert np.all(jac[ng:][gaps > 0.0] == 0.0)


def test_band_forces_equal_the_jax_forces(model4, edge):
    d, band0, settings, out, _ = edge
    spring, contact_tol = settings.spring, settings.contact_tolerance
    forces = jax.jit(
        lambda q, climb: _nebkernel.band_forces(
            model4.layout, model4.params, q, spring, contact_tol, climb
        )
    )
    for q in (
        np.stack([band0[0], *(manifold.project(d, x) for x in band0[1:-1]), band0[-1]]),
        out[0],
    ):
        for climb in (False, True):
            f, e, lam, lam_c, top = band_loop.band_forces(d, q, spring, contact_tol, climb)
            ref = forces(jnp.asarray(q), climb)
            scale = max(1.0, float(np.max(np.abs(np.asarray(ref[0])))))
            assert np.max(np.abs(f - np.asarray(ref[0]))) < 1e-9 * scale
            np.testing.assert_allclose(e, np.asarray(ref[1]), rtol=1e-13, atol=1e-13)
            np.testing.assert_allclose(lam, np.asarray(ref[2]), rtol=0, atol=1e-8)
            np.testing.assert_allclose(lam_c, np.asarray(ref[3]), rtol=0, atol=1e-8)
            assert top == int(ref[4])


def test_relaxed_band_takes_the_jax_iterates(edge):
    _, _, settings, out, ref = edge
    q, e, _, _, fmax, climbing, iterations, violation = out
    assert iterations == int(ref.iterations)
    assert climbing == int(ref.climbing) > 0
    # 221 FIRE steps with resets and contact switches amplify rounding (which differs between
    # the two compilers, and between CPUs): q agree to 1e-5, the energies to what that moves
    # along the band's gradient
    assert np.max(np.abs(q - np.asarray(ref.q))) < 1e-5
    assert np.max(np.abs(e - np.asarray(ref.energy))) < 1e-4 * max(1.0, float(np.max(e)))
    # both stopped on the force tolerance, at the same step
    assert fmax < settings.tolerance and float(ref.max_force) < settings.tolerance
    assert fmax == pytest.approx(float(ref.max_force), rel=1e-2)
    assert violation < 1e-12 and float(ref.constraint_residual) < 1e-12


def test_relaxed_band_is_converged_on_the_manifold(model4, edge):
    d, _, settings, out, _ = edge
    q, e, _, lam_c, fmax, climbing, _, violation = out
    assert fmax < settings.tolerance
    # the forces at the band it returns: below the tolerance but for the last FIRE step
    f, e_again, *_ = band_loop.band_forces(d, q, settings.spring, settings.contact_tolerance, True)
    assert np.max(np.abs(f)) < 10 * settings.tolerance
    np.testing.assert_array_equal(e, e_again)
    assert climbing == int(np.argmax(e[1:-1])) + 1
    for i in range(len(q)):
        energy, proj, _, lam_c_i, rows, _ = band_loop.image_gradient(
            d, q[i], settings.contact_tolerance
        )
        assert energy == pytest.approx(model4.energy(q[i]), rel=1e-12, abs=1e-14)
        # P∇Π lies in the null space of the active rows; the active contacts push
        assert np.max(np.abs(rows @ proj)) < 1e-9 * max(1.0, float(np.max(np.abs(proj))))
        assert np.all(lam_c_i >= -1e-9)  # (least-squares multipliers: ≥ 0 up to rounding)
        np.testing.assert_array_equal(lam_c_i, lam_c[i])
    assert violation < 1e-12


@pytest.mark.parametrize("n_images", [8, 16])
def test_barriers_equal_the_refined_jax_band(model1, n_images):
    """The compiled path's barriers equal those of the JAX band's climbing image refined by the
    JAX Newton (on model1 the contact rows of the band are ill-conditioned, condition ~1e8:
    the two bands differ by ~1e-4, the saddle they lead to does not)."""
    law = model1.tube.circular_laws[0]
    za = _stable(model1, np.zeros(4))
    zb = _stable(model1, np.array([0.0, 0.0, 0.0, law.wells()[1]]))
    neb = NudgedElasticBand(n_images=n_images)
    mep = minimum_energy_path(model1, za, zb, neb)
    band0 = _straight_band(model1, za, zb, n_images)
    ref = _nebkernel.fire_band.compiled(model1.layout)(
        model1.params, jnp.asarray(band0), jnp.asarray(neb.loop_settings())
    )
    top = int(ref.climbing)
    assert top == mep.saddle_index
    z0 = model1.pack(np.asarray(ref.q)[top], np.asarray(ref.guide_multipliers)[top])
    load = Load.of_force(0.0)
    out, _ = solve_loop.compiled(model1.layout)(
        model1.params, jnp.asarray(z0), load.for_jax(), settings_of(neb.refine)
    )
    assert int(out.status) == Status.CONVERGED.value
    z = np.asarray(out.z)
    sol = make_solution(model1, z, load, Status.CONVERGED, 0.0, 0)
    nq = model1.n_coordinates
    assert np.max(np.abs(mep.saddle_z[:nq] - z[:nq])) < 1e-9
    assert mep.barrier_forward == pytest.approx(sol.energy - model1.energy(za[:nq]), abs=1e-9)
    assert mep.barrier_backward == pytest.approx(sol.energy - model1.energy(zb[:nq]), abs=1e-9)
