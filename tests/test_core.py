"""The JAX Newton oracle (``jax_oracle.core``) on small closed-form systems.

Its damped form (the path corrector and the time step): it converges to the root with the
Newton iterates, the Jacobian it returns is the one at the root, a converged start costs no
step, a non-finite start fails at once, and the residual and the Jacobian are each traced once
(the size of the compiled kernels, docs/performance.md). Its Levenberg–Marquardt fallback and
its chord start, and the two search drivers visiting the same iterates.
"""

from __future__ import annotations

import numpy as np
import pytest

from biplan._compile.setup import jax, jnp
from biplan.solvers.status import Status
from jax_oracle.core import iterate
from jax_oracle.settings import Settings
from jax_oracle.strategies import chord, damped, minimum_norm, residual_norm


def _residual(x):
    """Intersection of the circle ‖x‖ = 2 and the cubic x₁ = x₀³ (one root with x₀ > 0)."""
    return jnp.stack([x[0] ** 2 + x[1] ** 2 - 4.0, x[1] - x[0] ** 3])


def _jacobian(x):
    return jnp.array([[2.0 * x[0], 2.0 * x[1]], [-3.0 * x[0] ** 2, 1.0]])


def _converged(out) -> bool:
    return int(out.status) == Status.CONVERGED.value


def _solve(x0, max_iterations=50):
    run = jax.jit(lambda x: damped(_residual, _jacobian, x, 1e-12, max_iterations))
    return run(jnp.asarray(x0, dtype=float))


def _newton_reference(x0, atol=1e-12):
    """Plain full-step Newton in NumPy (the damped iteration takes full steps here)."""
    x = np.asarray(x0, dtype=float)
    for k in range(50):
        r = np.asarray(_residual(x))
        if np.max(np.abs(r)) < atol:
            return x, k
        x = x - np.linalg.solve(np.asarray(_jacobian(x)), r)
    raise AssertionError("reference Newton did not converge")


def test_converges_to_the_root_with_the_newton_iterates() -> None:
    out = _solve([1.5, 1.5])
    x_ref, steps_ref = _newton_reference([1.5, 1.5])
    assert _converged(out)
    assert int(out.steps) == steps_ref
    np.testing.assert_allclose(np.asarray(out.z), x_ref, rtol=0, atol=1e-13)
    assert float(residual_norm(out)) < 1e-12
    # the Jacobian returned is the one at the root
    np.testing.assert_allclose(np.asarray(out.jac), np.asarray(_jacobian(out.z)), atol=0)


def test_backtracking_reaches_the_root_from_far_away() -> None:
    """From x0 = (0.35, 3.5) the full Newton step does not decrease the merit ½‖R‖²; the
    Armijo line search still reaches the root."""
    x0 = np.array([0.35, 3.5])
    r0 = np.asarray(_residual(x0))
    full = x0 - np.linalg.solve(np.asarray(_jacobian(x0)), r0)
    r1 = np.asarray(_residual(full))
    assert r1 @ r1 > r0 @ r0  # the line search must cut the first step
    out = _solve(x0)
    assert _converged(out)
    x = np.asarray(out.z)
    assert x[0] ** 2 + x[1] ** 2 == pytest.approx(4.0, abs=1e-11)
    assert x[1] == pytest.approx(x[0] ** 3, abs=1e-11)


def test_converged_start_costs_no_step_and_returns_its_jacobian() -> None:
    root = np.asarray(_solve([1.5, 1.5]).z)
    out = _solve(root)
    assert _converged(out) and int(out.steps) == 0
    np.testing.assert_array_equal(np.asarray(out.z), root)
    np.testing.assert_allclose(np.asarray(out.jac), np.asarray(_jacobian(root)), atol=0)


def test_non_finite_start_fails_at_once() -> None:
    out = _solve([np.nan, 1.0])
    assert not _converged(out) and int(out.steps) == 0


def test_step_budget_is_respected() -> None:
    out = _solve([1.5, 1.5], max_iterations=2)
    assert not _converged(out) and int(out.steps) == 2


def test_residual_and_jacobian_are_traced_once() -> None:
    calls = {"residual": 0, "jacobian": 0}

    def residual(x):
        calls["residual"] += 1
        return _residual(x)

    def jacobian(x):
        calls["jacobian"] += 1
        return _jacobian(x)

    jax.jit(lambda x: damped(residual, jacobian, x, 1e-12, 50)).lower(jnp.ones(2))
    assert calls == {"residual": 1, "jacobian": 1}


def test_batched_with_axis_name_equals_one_solve_per_lane() -> None:
    """Under ``vmap`` with ``axis_name`` the Jacobian is formed only on passes where some lane
    accepted a point; every lane still follows its own unbatched iteration."""
    starts = np.array([[1.5, 1.5], [0.35, 3.5], [0.05, -3.0], [-1.2, 0.4], [2.5, 2.5]])

    def solve(x, axis_name=None):
        return damped(_residual, _jacobian, x, 1e-12, 50, axis_name=axis_name)

    batched = jax.jit(jax.vmap(lambda x: solve(x, "lanes"), axis_name="lanes"))(jnp.asarray(starts))
    for i, x0 in enumerate(starts):
        one = _solve(x0)
        assert int(batched.status[i]) == int(one.status)
        assert int(batched.steps[i]) == int(one.steps)
        np.testing.assert_allclose(np.asarray(batched.z[i]), np.asarray(one.z), atol=1e-13)
        np.testing.assert_allclose(np.asarray(batched.jac[i]), np.asarray(one.jac), atol=1e-12)


def test_levenberg_marquardt_leaves_a_singular_start_that_plain_damped_newton_cannot() -> None:
    """At x0 = (1, −1/3) the Jacobian [[2, −2/3], [−3, 1]] is singular (det = 2x₀(1 + 3x₀x₁)):
    the damped form ends there (a failed search, cut back by its driver), the full core steps
    off by Levenberg–Marquardt and reaches a root."""
    x0 = jnp.asarray([1.0, -1.0 / 3.0])
    plain = _solve(x0)
    assert int(plain.status) == Status.LINE_SEARCH_FAILED.value and int(plain.steps) == 0
    settings = Settings.of(1e-12, 60)
    out = jax.jit(lambda x: iterate(_residual, _jacobian, x, settings))(x0)
    assert _converged(out)
    np.testing.assert_allclose(np.asarray(_residual(out.z)), 0.0, atol=1e-12)


@pytest.mark.parametrize("x0", [[1.5, 1.5], [0.35, 3.5], [0.05, -3.0], [-1.2, 0.4]])
def test_one_pass_and_line_search_loop_visit_the_same_iterates(x0) -> None:
    settings = Settings.of(1e-12, 60)
    runs = [
        jax.jit(lambda x, ls=ls: iterate(_residual, _jacobian, x, settings, line_search_loop=ls))(
            jnp.asarray(x0, dtype=float)
        )
        for ls in (False, True)
    ]
    assert int(runs[0].status) == int(runs[1].status) == Status.CONVERGED.value
    assert int(runs[0].steps) == int(runs[1].steps)
    np.testing.assert_allclose(np.asarray(runs[0].z), np.asarray(runs[1].z), atol=1e-13)


def test_chord_converges_with_a_fixed_jacobian_and_keeps_its_best_iterate() -> None:
    root = np.asarray(_solve([1.5, 1.5]).z)
    jac = _jacobian(jnp.asarray(root))
    near = jnp.asarray(root + np.array([2e-3, -1e-3]))
    z = jax.jit(lambda z: chord(_residual, jac, z, 1e-12, 30))(near)
    assert float(jnp.max(jnp.abs(_residual(z)))) < 1e-12
    # chord steps from far away diverge here: the start itself is returned
    far = jnp.asarray([-1.2, 0.4])
    z = jax.jit(lambda z: chord(_residual, jac, z, 1e-12, 8))(far)
    r_far = float(jnp.max(jnp.abs(_residual(far))))
    assert float(jnp.max(jnp.abs(_residual(z)))) <= r_far


def test_minimum_norm_gauss_newton_returns_to_a_manifold_along_its_normal() -> None:
    """One equation in two unknowns (the circle ‖x‖ = 2): minimum-norm Gauss–Newton steps are
    radial, so from (1, 1) the core lands on the circle at (√2, √2)."""

    def residual(x):
        return jnp.stack([x[0] ** 2 + x[1] ** 2 - 4.0])

    settings = Settings.of(1e-13, 30)
    out = jax.jit(
        lambda x: iterate(
            residual, jax.jacfwd(residual), x, settings, solve=minimum_norm, n_equations=1
        )
    )(jnp.asarray([1.0, 1.0]))
    assert _converged(out)
    np.testing.assert_allclose(np.asarray(out.z), [np.sqrt(2.0), np.sqrt(2.0)], atol=1e-12)
