"""The compiled Newton (:mod:`biplan.solvers.iteration`) takes the same iterates as the JAX
Newton core (jax_oracle.core.machine`): same status, same step count, the same
solution to round-off; and :func:`biplan.solve_equilibrium` returns the compiled system's
state data (energies, endpoint, Hessian, constraint rows) equal to the JAX model's."""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan.model.params import Load
from biplan.solvers import iteration
from jax_oracle.newton import settings_of, solve_loop

CASES = {
    "displacement 1 mm": (Load(0.0, 1.0, 1.0), {}),
    "force 1.5 N": (Load(1.5, 0.0, 0.0), {}),
    "displacement 5 mm, past the snaps": (Load(0.0, 5.0, 1.0), {}),
    "watchdog": (Load(0.0, 5.0, 1.0), {"free_steps": 5}),
    "two steps only": (Load(0.0, 5.0, 1.0), {"max_steps": 2}),
    "short line search": (Load(2.0, 0.0, 0.0), {"max_backtracks": 2}),
}


@pytest.mark.parametrize("case", CASES)
def test_compiled_newton_takes_the_jax_iterates(model6, reference6, case):
    load, options = CASES[case]
    method = biplan.Newton(**options)
    system = model6.system(load)
    s = iteration.newton_settings(
        method.atol, method.max_steps, method.max_backtracks, method.armijo, method.free_steps
    )
    z, _, _, jac, steps, status = iteration.solve_system(system, reference6.z, s)
    out, _ = solve_loop.compiled(model6.layout)(
        model6.params, reference6.z, load.for_jax(), settings_of(method)
    )
    assert status == int(out.status)
    assert steps == int(out.steps)
    scale = max(1.0, float(np.max(np.abs(np.asarray(out.z)))))
    # an unconverged iterate carries the rounding of near-singular contact rows (λ_∂ at the
    # smoothed Fischer–Burmeister corner), amplified by the steps it took
    tol = 1e-10 if status == 0 else 1e-6
    assert np.max(np.abs(z - np.asarray(out.z))) / scale < tol
    assert np.max(np.abs(jac - model6.jacobian(z, load))) < 1e-9 * np.max(np.abs(jac))


def test_solution_data_equal_the_jax_model(model6, reference6):
    load = Load.of_displacement(2.0)
    sol = biplan.solve_equilibrium(model6, biplan.Newton(), reference6, load)
    assert sol.converged
    ref = model6.state(sol.z, load)
    assert sol.energy == pytest.approx(float(ref.energy), rel=1e-12)
    np.testing.assert_allclose(sol.data.helical_energy, ref.helical_energy, rtol=1e-11, atol=1e-15)
    np.testing.assert_allclose(
        sol.data.circular_energy, ref.circular_energy, rtol=1e-11, atol=1e-15
    )
    np.testing.assert_allclose(sol.data.endpoint, ref.endpoint, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(sol.data.gaps, ref.gaps, atol=1e-13)
    np.testing.assert_allclose(
        sol.data.constraint_jacobian, ref.constraint_jacobian, rtol=1e-11, atol=1e-12
    )
    k = np.asarray(ref.lagrangian_hessian)
    assert np.max(np.abs(sol.data.lagrangian_hessian - k)) < 1e-10 * np.max(np.abs(k))
    assert sol.displacement == pytest.approx(2.0, abs=1e-9)
    # the reaction is the multiplier of the displacement row
    assert sol.force == pytest.approx(-sol.z[-1])


def test_failed_compiled_solve_says_so(model6, reference6):
    sol = biplan.solve_equilibrium(
        model6, biplan.Newton(max_steps=2), reference6, Load.of_displacement(5.0)
    )
    assert not sol.converged
    assert sol.status is biplan.Status.MAX_STEPS
    assert "maximum number of Newton steps" in sol.message
    with pytest.raises(biplan.ConvergenceError, match="maximum number of Newton steps"):
        biplan.solve_equilibrium(
            model6, biplan.Newton(max_steps=2), reference6, Load.of_displacement(5.0), throw=True
        )


def test_non_finite_start_ends_at_once(model6, reference6):
    """A start whose residual is not finite has no point to step from: the compiled Newton
    returns it with status NONFINITE after no step, and an n × n Jacobian placeholder."""
    start = reference6.z.copy()
    start[0] = np.nan
    s = iteration.newton_settings(1e-9, 30, 8, 1e-4, 0)
    z, _, f, jac, steps, status = iteration.solve_system(
        model6.system(Load(0.5, 0.0, 0.0)), start, s
    )
    assert status == biplan.Status.NONFINITE.value
    assert steps == 0 and not np.isfinite(f)
    np.testing.assert_array_equal(z, start)
    assert jac.shape == (start.size, start.size)


def test_a_start_of_the_wrong_length_is_refused(model6, reference6):
    """The compiled loop would read past a short start: it is refused before the call."""
    s = iteration.newton_settings(1e-9, 30, 8, 1e-4, 0)
    system = model6.system(Load(0.5, 0.0, 0.0))
    for start in (reference6.z[:-1], np.append(reference6.z, 0.0), reference6.z[None]):
        with pytest.raises(ValueError, match=f"the system has {system.n_unknowns} unknowns"):
            iteration.solve_system(system, start, s)
