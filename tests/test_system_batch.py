"""The batched solves of the maps on the compiled System (:mod:`biplan.solvers.batch`): the
stability map's tasks are single compiled Newton solves, converged to equilibria of their own
point and observed as each state observed alone; the design map's chord start is the chord
iteration it names and ends at the Newton solution; its force ramp is the step-by-step chain of
chord start, Newton and a fresh observation."""

from __future__ import annotations

import numpy as np
import pytest

from biplan.analysis.maps.design_kernels import CHORD_ITERATIONS, ramp_compiled
from biplan.analysis.maps.design_map import ForceRamp
from biplan.analysis.maps.stability_seeds import PRESS, Seeding, _line_force, seeds
from biplan.analysis.maps.stability_solve import CompiledTasks, solve_and_observe
from biplan.analysis.maps.sweeps import apply_values
from biplan.model.assembly import Model
from biplan.model.params import Load
from biplan.solvers import batch, iteration
from biplan.solvers.newton import Newton, Status, solve_equilibrium
from biplan.solvers.observation import ACTIVE_GAP, observe

#: The stability map's seed solves (StabilitySearch: 15 steps, 4 halvings).
SEARCH = Newton(max_steps=15, max_backtracks=4)
NO_BORDER, NO_STEP, NO_DEFLATION = iteration.NO_BORDER, iteration.NO_STEP, iteration.NO_DEFLATION


@pytest.fixture(scope="module")
def points(model6):
    """Two points of the stability map (other helical stiffness C: other laws, one layout) and
    their seeds at two displacements each: fast, slow and failing solves."""
    models = [Model(apply_values(model6.tube, {"C": c})) for c in (0.5, 3.0)]
    l0 = model6.tube.initial_length
    rows, z0, u = [], [], []
    for j, m in enumerate(models):
        for uu in (0.01 * l0, 0.1 * l0):
            sd = seeds(m, uu, Seeding.PATTERNS)
            rows += [j] * len(sd)
            z0 += list(sd)
            u += [uu] * len(sd)
    return models, np.asarray(rows), np.asarray(z0), np.asarray(u)


def _settings(newton: Newton) -> np.ndarray:
    return iteration.newton_settings(
        newton.atol, newton.max_steps, newton.max_backtracks, newton.armijo, newton.free_steps
    )


def _displacement(u: np.ndarray) -> np.ndarray:
    return np.stack([np.zeros_like(u), u, np.ones_like(u)], axis=1)


def test_batched_solve_equals_one_compiled_newton_per_task(points) -> None:
    models, _, z0, u = points
    s = _settings(SEARCH)
    data = models[0].system().data
    loads = _displacement(u)
    z, status, steps = batch.solve_tasks(data, z0, loads, s)
    for i in range(len(z0)):
        ref = iteration.solve(data, loads[i], z0[i], s, NO_BORDER, 0.0, NO_STEP, NO_DEFLATION)
        assert (status[i], steps[i]) == (ref[5], ref[4])
        np.testing.assert_array_equal(z[i], ref[0])
    conv = status == Status.CONVERGED.value
    assert 0 < conv.sum() < len(z0)  # converged and failed solves both checked
    # another tube's data gives other solutions (the data is read, not cached)
    other = batch.solve_tasks(models[1].system().data, z0, loads, s)[0]
    assert np.max(np.abs(other[conv] - z[conv])) > 1e-3


def test_point_tasks_are_equilibria_of_their_own_point_observed_alone(points) -> None:
    """Tasks of two points mixed: each is one compiled Newton solve on its own point's System
    (same status and iterate); a converged one is an equilibrium there (‖r‖∞ < atol, the
    load point at the prescribed U); the observables of every converged task — those of the
    one observed solution per distinct equilibrium and those its copies share — are those of
    the state observed alone, and NaN where the solve failed."""
    models, rows, z0, u = points
    tasks = CompiledTasks.of(models)
    nq = models[0].n_coordinates
    z, ok, *obs = solve_and_observe(tasks, rows, z0, u, SEARCH, nq, 1e-4)
    s, loads = _settings(SEARCH), _displacement(u)
    status = np.empty(len(rows), dtype=np.int64)
    for i, row in enumerate(rows):
        data = models[row].system().data
        ref = iteration.solve(data, loads[i], z0[i], s, NO_BORDER, 0.0, NO_STEP, NO_DEFLATION)
        status[i] = ref[5]
        np.testing.assert_array_equal(z[i], ref[0])
    np.testing.assert_array_equal(tasks.solve(rows, z0, u, SEARCH)[1], status)
    np.testing.assert_array_equal(ok, status == Status.CONVERGED.value)
    assert 0 < ok.sum() < len(z0) and set(rows[ok]) == {0, 1}
    for k in np.flatnonzero(ok):
        at = models[rows[k]].system(Load(0.0, u[k], 1.0))
        assert np.max(np.abs(at.residual(z[k]))) < SEARCH.atol
    for j, m in enumerate(models):
        sel = ok & (rows == j)
        fresh = observe(m, z[sel], loads[sel])
        np.testing.assert_allclose(fresh.displacement, u[sel], rtol=0, atol=1e-8)
        ref = (fresh.energy, fresh.min_eigenvalue, fresh.u_z, fresh.u_r, fresh.force)
        for mine, want in zip(obs, ref, strict=True):
            np.testing.assert_array_equal(np.isfinite(mine[sel]), np.isfinite(want))
            finite = np.isfinite(want)  # λ_min = +∞ at contact-locked states
            np.testing.assert_allclose(mine[sel][finite], want[finite], rtol=1e-9, atol=1e-10)
    for o in obs:
        assert np.isnan(o[~ok]).all()
    # copies share an observation: fewer distinct equilibria than converged tasks
    distinct = sum(len({tuple(np.round(zi[:nq], 4)) for zi in z[ok & (rows == j)]}) for j in (0, 1))
    assert distinct < ok.sum()


def test_pressed_seeds_press_the_closed_contacts_of_the_model(points) -> None:
    """The pressed seeds carry :data:`PRESS` on exactly the contacts that the (JAX) model
    finds closed; the push test's law forces (NumPy) are the laws' own."""
    m = points[0][0]
    w_b = m.tube.circular_laws[0].hilltop()
    nq, lam_c = m.n_coordinates, slice(m.n_coordinates + m.n_guides, -1)
    assert len(seeds(m, 0.5 * w_b, pressed_only=True)) == 0  # below w_b nothing pushes
    pressed = seeds(m, 1.01 * w_b, pressed_only=True)  # past w_b one open fold pushes
    assert len(pressed) > 0
    for z in pressed:
        closed = m.contact_gaps(z[:nq]) < ACTIVE_GAP
        np.testing.assert_array_equal(z[lam_c], np.where(closed, PRESS, 0.0))
        assert closed.any() and not closed.all()
    everything = seeds(m, 1.01 * w_b)
    np.testing.assert_array_equal(everything[-len(pressed) :], pressed)
    law = m.tube.circular_laws[0]
    w = np.linspace(-0.5, 3.0, 71)
    np.testing.assert_allclose(_line_force(law.coefficients, w), law.force(w), rtol=1e-15)


def _chord_reference(model: Model, z: np.ndarray, jac: np.ndarray, load: Load, atol: float,
                     iterations: int) -> np.ndarray:  # fmt: skip
    """The chord iteration written out: z ← z − J⁻¹ r(z), the iterate of smallest ‖r‖∞."""
    residual = model.system(load).residual
    best, best_norm = z, np.max(np.abs(residual(z)))
    for _ in range(iterations):
        if best_norm < atol:
            break
        z = z - np.linalg.solve(jac, residual(z))
        norm = np.max(np.abs(residual(z)))
        if norm < best_norm:
            best, best_norm = z, norm
    return best


def test_chord_start_is_the_chord_iteration_and_ends_at_the_newton_solution(
    model6, reference6
) -> None:
    """A design-map load step's start: from the equilibrium at 0.1 N with its Jacobian, chord
    iterates at 0.2 N (to the map's tolerance, and all :data:`CHORD_ITERATIONS`): the
    iteration written out, converged to the equilibrium that Newton finds there."""
    sol = solve_equilibrium(model6, None, reference6, Load.of_force(0.1))
    z = np.asarray(sol.z)
    jac = np.asarray(model6.system(Load.of_force(0.1)).jacobian(z))
    load = Load.of_force(0.2)
    target = np.asarray(solve_equilibrium(model6, None, z, load).z)
    data, f = model6.system().data, np.array([0.2, 0.0, 0.0])
    r0 = np.max(np.abs(model6.system(load).residual(z)))
    for atol in (1e-9, 1e-30):
        mine = batch.chord(data, z, jac, f, atol, CHORD_ITERATIONS)
        ref = _chord_reference(model6, z, jac, load, atol, CHORD_ITERATIONS)
        np.testing.assert_allclose(mine, ref, rtol=0, atol=1e-12)
        # the chord moved to the new equilibrium (the residual dropped), Newton's
        assert np.max(np.abs(model6.system(load).residual(mine))) < 1e-8 * r0
        np.testing.assert_allclose(mine, target, rtol=0, atol=1e-7)
    fewer = batch.chord(data, z, jac, f, 1e-30, 1)  # one step: not there yet
    assert np.max(np.abs(fewer - mine)) > 1e-6
    np.testing.assert_allclose(fewer, _chord_reference(model6, z, jac, load, 1e-30, 1),
                               rtol=0, atol=1e-12)  # fmt: skip
    # a singular Jacobian gives no step: the start itself
    np.testing.assert_array_equal(batch.chord(data, z, np.zeros_like(jac), f, 1e-30, 4), z)


def _ramp_reference(model: Model, forces: np.ndarray, newton: Newton) -> tuple:
    """The ramp step by step: the chord start, one compiled Newton solve and a fresh
    observation (its own Hessian) per load step, stopping at the first failed step."""
    data, s = model.system().data, _settings(newton)
    n = len(forces)
    ok, bad = np.zeros(n, dtype=bool), np.full(n, -1)
    rec = np.full((4, n), np.nan)
    z = np.asarray(model.pack(model.zeros()), dtype=float)
    jac = np.asarray(model.system(Load.of_force(forces[0])).jacobian(z))
    for k, force in enumerate(forces):
        f = np.array([force, 0.0, 0.0])
        start = batch.chord(data, z, jac, f, newton.atol, CHORD_ITERATIONS)
        out = iteration.solve(data, f, start, s, NO_BORDER, 0.0, NO_STEP, NO_DEFLATION)
        if out[5] != Status.CONVERGED.value or not np.all(np.isfinite(out[0])):
            bad[k] = out[5]
            break
        z, jac = out[0], out[3]
        ob = observe(model, z[None], f)
        ok[k] = True
        rec[:, k] = ob.u_z[0], ob.u_r[0], ob.displacement[0], ob.min_eigenvalue[0]
    return (ok, bad, *rec), z


@pytest.mark.parametrize(
    "ramp",
    [ForceRamp(), ForceRamp(rate=2.0), ForceRamp(atol=1e-30, max_steps=1)],
    ids=["converges", "fails past the limit point", "cannot converge"],
)
def test_compiled_ramp_is_the_step_by_step_chain(model6, ramp) -> None:
    models = [Model(apply_values(model6.tube, {"b": b, "C": c})) for b, c in
              ((0.45, 0.5), (0.57, 3.0))]  # fmt: skip
    newton = ramp.newton()
    mine, z_mine = ramp_compiled(models, ramp.forces, newton)
    ok = mine[0]
    for i, m in enumerate(models):
        ref, z_ref = _ramp_reference(m, ramp.forces, newton)
        np.testing.assert_array_equal(ok[i], ref[0])
        np.testing.assert_array_equal(mine[1][i], ref[1])
        for a, b in zip(mine[2:], ref[2:], strict=True):
            np.testing.assert_array_equal(np.isfinite(a[i]), np.isfinite(b))
            finite = np.isfinite(b)
            np.testing.assert_allclose(a[i][finite], b[finite], rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(z_mine[i], z_ref, rtol=0, atol=1e-10)
        if ok[i].any():  # the last converged state is an equilibrium at its force
            last = ramp.forces[np.flatnonzero(ok[i])[-1]]
            residual = m.system(Load.of_force(last)).residual(z_mine[i])
            assert np.max(np.abs(residual)) < ramp.atol
    if ramp.max_steps == 1:
        assert not ok.any() and (mine[1][:, 0] == Status.MAX_STEPS.value).all()
    elif ramp.rate == 2.0:
        assert ok[:, 0].all() and not ok.all()
    else:
        assert ok.all()
        # a stable tube under a rising pull extends at every step
        assert (np.diff(mine[4], axis=1) > 0).all() and (mine[5] > 0).all()
