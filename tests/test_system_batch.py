"""The batched solves on the compiled System (:mod:`biplan.solvers.batch`) take the iterates of
the JAX map kernels they replace: the stability map's tasks those of the lane-refilling pool
(:func:`biplan.solvers.pool.newton_pool`) and of single compiled Newton solves, the design
map's force ramp those of its JAX kernel, the chord start that of
:func:`biplan.solvers.strategies.chord`."""

from __future__ import annotations

import numpy as np
import pytest

from biplan.analysis.maps.design_kernels import (
    CHORD_ITERATIONS,
    _chord,
    ramp_compiled,
    ramp_jax,
)
from biplan.analysis.maps.design_map import ForceRamp
from biplan.analysis.maps.stability_seeds import _line_force, seeds
from biplan.analysis.maps.stability_solve import (
    CompiledTasks,
    PoolTasks,
    solve_and_observe,
    task_solver,
)
from biplan.analysis.maps.sweeps import apply_values
from biplan.model.assembly import Model
from biplan.model.params import Load
from biplan.solvers import batch, iteration
from biplan.solvers.newton import Newton, Status, solve_equilibrium

#: The stability map's seed solves (StabilitySearch: 15 steps, 4 halvings).
SEARCH = Newton(max_steps=15, max_backtracks=4)


@pytest.fixture(scope="module")
def points(model6):
    """Two points of the stability map (other helical stiffness C: other laws, one layout) and
    their seeds at two displacements each: fast, slow and failing solves."""
    models = [Model(apply_values(model6.tube, {"C": c})) for c in (0.5, 3.0)]
    l0 = model6.tube.initial_length
    rows, z0, u = [], [], []
    for j, m in enumerate(models):
        for uu in (0.01 * l0, 0.1 * l0):
            sd = seeds(m, uu, "patterns")
            rows += [j] * len(sd)
            z0 += list(sd)
            u += [uu] * len(sd)
    return models, np.asarray(rows), np.asarray(z0), np.asarray(u)


def _settings(newton: Newton) -> np.ndarray:
    return iteration.settings_array(
        newton.atol, newton.max_steps, newton.max_backtracks, newton.armijo, newton.free_steps
    )


def test_batched_solve_equals_one_compiled_newton_per_task(points) -> None:
    models, _, z0, u = points
    s = _settings(SEARCH)
    data = models[0].system().data
    loads = np.stack([np.zeros_like(u), u, np.ones_like(u)], axis=1)
    z, status, steps = batch.solve_tasks(data, z0, loads, s)
    for i in range(len(z0)):
        no_border, no_step = iteration.NO_BORDER, iteration.NO_STEP
        ref = iteration.newton(data, loads[i], z0[i], s, no_border, 0.0, no_step)
        assert (status[i], steps[i]) == (ref[5], ref[4])
        np.testing.assert_array_equal(z[i], ref[0])
    conv = status == Status.CONVERGED.value
    assert 0 < conv.sum() < len(z0)  # converged and failed solves both checked
    # another tube's data gives other solutions (the data is read, not cached)
    other = batch.solve_tasks(models[1].system().data, z0, loads, s)[0]
    assert np.max(np.abs(other[conv] - z[conv])) > 1e-3


def test_compiled_tasks_equal_the_jax_pool(points) -> None:
    """Same statuses, the same solutions and observables (energy, λ_min, endpoint, force) as
    the lane-refilling JAX pool and its observation kernel, tasks of two points mixed."""
    models, rows, z0, u = points
    layout = models[0].layout
    compiled = task_solver(layout, models, 8, 64)
    assert isinstance(compiled, CompiledTasks)
    from biplan.analysis.maps.design_kernels import stack_params

    pool = PoolTasks(layout, stack_params(models, 8), 64)
    nq = models[0].n_coordinates
    mine = solve_and_observe(compiled, rows, z0, u, 16, SEARCH, nq, 1e-4)
    ref = solve_and_observe(pool, rows, z0, u, 16, SEARCH, nq, 1e-4)
    z, ok = mine[0], mine[1]
    np.testing.assert_array_equal(ok, ref[1])
    assert 0 < ok.sum() < len(z0) and set(rows[ok]) == {0, 1}
    _, status = compiled.solve(rows, z0, u, 16, SEARCH)
    np.testing.assert_array_equal(status, pool.solve(rows, z0, u, 16, SEARCH)[1])
    assert np.max(np.abs(z[ok] - ref[0][ok])) < 1e-10
    # the failed solves end at the same iterate too, up to the rounding of near-singular
    # contact rows amplified by the steps they took (tests/test_system_newton.py)
    assert np.max(np.abs(z[~ok] - ref[0][~ok])) / max(1.0, np.max(np.abs(ref[0]))) < 1e-6
    for a, b in zip(mine[2:], ref[2:], strict=True):
        assert np.isnan(a[~ok]).all() and np.isnan(b[~ok]).all()
        finite = np.isfinite(b[ok])  # λ_min = +∞ at contact-locked states
        np.testing.assert_array_equal(np.isfinite(a[ok]), finite)
        np.testing.assert_allclose(a[ok][finite], b[ok][finite], rtol=1e-9, atol=1e-10)


def test_seed_gaps_from_the_system_equal_the_jax_model(points) -> None:
    m = points[0][0]
    w_b = m.tube.circular_laws[0].hilltop()
    for u in (0.5 * w_b, 1.01 * w_b):  # past w_b one open fold pushes: pressed seeds
        np.testing.assert_array_equal(seeds(m, u, system=m.system()), seeds(m, u))
    assert len(seeds(m, 1.01 * w_b, pressed_only=True, system=m.system())) > 0
    # the push test's law forces (NumPy) are the laws' own
    law = m.tube.circular_laws[0]
    w = np.linspace(-0.5, 3.0, 71)
    np.testing.assert_allclose(_line_force(law.coefficients, w), law.force(w), rtol=1e-15)


def test_chord_equals_the_jax_chord(model6, reference6) -> None:
    """A design-map load step's start: from the equilibrium at 0.1 N with its Jacobian, chord
    iterates at 0.2 N (to the map's tolerance, and all :data:`CHORD_ITERATIONS`)."""
    sol = solve_equilibrium(model6, None, reference6, Load.of_force(0.1))
    z = np.asarray(sol.z)
    jac = np.asarray(model6.system(Load.of_force(0.1)).jacobian(z))
    load = Load.of_force(0.2)
    data, f = model6.system().data, np.array([0.2, 0.0, 0.0])
    r0 = np.max(np.abs(model6.system(load).residual(z)))
    for atol in (1e-9, 1e-30):
        mine = batch.chord(data, z, jac, f, atol, CHORD_ITERATIONS)
        ref = np.asarray(_chord.compiled(model6.layout)(model6.params, z, jac, load, atol))
        np.testing.assert_allclose(mine, ref, rtol=0, atol=1e-12)
        # the chord moved to the new equilibrium (the residual dropped)
        assert np.max(np.abs(model6.system(load).residual(mine))) < 1e-8 * r0
    fewer = batch.chord(data, z, jac, f, 1e-30, 1)  # one step: not there yet
    assert np.max(np.abs(fewer - mine)) > 1e-6


@pytest.mark.parametrize(
    "ramp",
    [ForceRamp(), ForceRamp(rate=2.0), ForceRamp(atol=1e-30, max_steps=1)],
    ids=["converges", "fails past the limit point", "cannot converge"],
)
def test_compiled_ramp_equals_the_jax_design_kernel(model6, ramp) -> None:
    models = [Model(apply_values(model6.tube, {"b": b, "C": c})) for b, c in
              ((0.45, 0.5), (0.57, 3.0))]  # fmt: skip
    newton = ramp.newton()
    mine, z_mine = ramp_compiled(models, ramp.forces, newton)
    ref, z_ref = ramp_jax(models[0].layout, models, ramp.forces, newton, 4)
    ok = mine[0]
    np.testing.assert_array_equal(ok, ref[0])
    for i in range(len(models)):
        failed = np.flatnonzero(~ok[i])
        upto = failed[0] + 1 if failed.size else ok.shape[1]
        np.testing.assert_array_equal(mine[1][i, :upto], ref[1][i, :upto])
    for a, b in zip(mine[2:], ref[2:], strict=True):
        np.testing.assert_array_equal(np.isfinite(a[ok]), np.isfinite(b[ok]))
        finite = np.isfinite(b[ok])
        np.testing.assert_allclose(a[ok][finite], b[ok][finite], rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(z_mine, z_ref, rtol=0, atol=1e-10)
    if ramp.max_steps == 1:
        assert not ok.any() and (mine[1][:, 0] == Status.MAX_STEPS.value).all()
    elif ramp.rate == 2.0:
        assert ok[:, 0].all() and not ok.all()
    else:
        assert ok.all()
