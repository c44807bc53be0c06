"""The damped Newton iteration of the jitted inner loops (``solvers._damped``).

Checked on small closed-form systems: it converges to the root with the Newton iterates, the
Jacobian it returns is the one at the root, a converged start costs no step, a non-finite start
fails at once, and the residual and the Jacobian are each traced once (the size of the compiled
time-step and path-corrector kernels, docs/performance.md).
"""

from __future__ import annotations

import numpy as np
import pytest

from biplan._jax import jax, jnp
from biplan.solvers._damped import damped_newton


def _residual(x):
    """Intersection of the circle ‖x‖ = 2 and the cubic x₁ = x₀³ (one root with x₀ > 0)."""
    return jnp.stack([x[0] ** 2 + x[1] ** 2 - 4.0, x[1] - x[0] ** 3])


def _jacobian(x):
    return jnp.array([[2.0 * x[0], 2.0 * x[1]], [-3.0 * x[0] ** 2, 1.0]])


def _solve(x0, max_iterations=50):
    run = jax.jit(lambda x: damped_newton(_residual, _jacobian, x, 1e-12, max_iterations))
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
    assert bool(out.converged)
    assert int(out.iterations) == steps_ref
    np.testing.assert_allclose(np.asarray(out.x), x_ref, rtol=0, atol=1e-13)
    assert float(out.residual) < 1e-12
    # the Jacobian returned is the one at the root
    np.testing.assert_allclose(np.asarray(out.jacobian), np.asarray(_jacobian(out.x)), atol=0)


def test_backtracking_reaches_the_root_from_far_away() -> None:
    """From x0 = (0.35, 3.5) the full Newton step does not decrease the merit ½‖R‖²; the
    Armijo line search still reaches the root."""
    x0 = np.array([0.35, 3.5])
    r0 = np.asarray(_residual(x0))
    full = x0 - np.linalg.solve(np.asarray(_jacobian(x0)), r0)
    r1 = np.asarray(_residual(full))
    assert r1 @ r1 > r0 @ r0  # the line search must cut the first step
    out = _solve(x0)
    assert bool(out.converged)
    x = np.asarray(out.x)
    assert x[0] ** 2 + x[1] ** 2 == pytest.approx(4.0, abs=1e-11)
    assert x[1] == pytest.approx(x[0] ** 3, abs=1e-11)


def test_converged_start_costs_no_step_and_returns_its_jacobian() -> None:
    root = np.asarray(_solve([1.5, 1.5]).x)
    out = _solve(root)
    assert bool(out.converged) and int(out.iterations) == 0
    np.testing.assert_array_equal(np.asarray(out.x), root)
    np.testing.assert_allclose(np.asarray(out.jacobian), np.asarray(_jacobian(root)), atol=0)


def test_non_finite_start_fails_at_once() -> None:
    out = _solve([np.nan, 1.0])
    assert not bool(out.converged) and int(out.iterations) == 0


def test_step_budget_is_respected() -> None:
    out = _solve([1.5, 1.5], max_iterations=2)
    assert not bool(out.converged) and int(out.iterations) == 2


def test_residual_and_jacobian_are_traced_once() -> None:
    calls = {"residual": 0, "jacobian": 0}

    def residual(x):
        calls["residual"] += 1
        return _residual(x)

    def jacobian(x):
        calls["jacobian"] += 1
        return _jacobian(x)

    jax.jit(lambda x: damped_newton(residual, jacobian, x, 1e-12, 50)).lower(jnp.ones(2))
    assert calls == {"residual": 1, "jacobian": 1}


def test_batched_with_axis_name_equals_one_solve_per_lane() -> None:
    """Under ``vmap`` with ``axis_name`` the Jacobian is formed only on passes where some lane
    accepted a point; every lane still follows its own unbatched iteration."""
    starts = np.array([[1.5, 1.5], [0.35, 3.5], [0.05, -3.0], [-1.2, 0.4], [2.5, 2.5]])

    def solve(x, axis_name=None):
        return damped_newton(_residual, _jacobian, x, 1e-12, 50, axis_name=axis_name)

    batched = jax.jit(jax.vmap(lambda x: solve(x, "lanes"), axis_name="lanes"))(jnp.asarray(starts))
    for i, x0 in enumerate(starts):
        one = _solve(x0)
        assert bool(batched.converged[i]) == bool(one.converged)
        assert int(batched.iterations[i]) == int(one.iterations)
        np.testing.assert_allclose(np.asarray(batched.x[i]), np.asarray(one.x), atol=1e-13)
        np.testing.assert_allclose(
            np.asarray(batched.jacobian[i]), np.asarray(one.jacobian), atol=1e-12
        )
