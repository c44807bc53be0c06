"""Batched seeded relaxation: fold-state seeds → stable equilibria at zero end load (MODEL §15).

One pure function per seed, ``vmap``-ped and jitted once per tube layout:

1. **Kinematic seed.** Gauss–Newton on r(q) = [g(q); m ⊙ (w̄(q) − t)] from q = 0, where g are
   the guides, w̄ the length-mean elongation of every fold
   (:func:`biplan.model.potential.fold_openings`),
   t the target of each fold (0 for closed, the law's open well for open) and m masks the folds
   that take part (bistable ones). The system is square for a fully bistable tube (DOF = number
   of folds); a small Levenberg damping keeps it well posed otherwise. Steps are capped so that
   the seed never leaves the kinematically admissible range of the helical folds.
2. **Quasi-static relaxation.** A descent method on the energy, so that the configuration
   slides downhill into the well its seed lies in and never stops on a saddle: modified Newton
   (Hessian shifted to positive definite, Armijo backtracking over a fixed set of step lengths
   evaluated together) on the penalised energy Π(q) + ½k_p(‖g(q)‖² + ‖min(w_∂(q), 0)‖²),
   the guides and contacts as stiff penalties (MODEL §15 leaves the relaxation open; a
   penalty keeps every iteration smooth where the Fischer–Burmeister Newton stalls on
   contact switches far from the solution).
3. **KKT polish.** The Newton solver of the package on the exact KKT system (guides,
   smoothed Fischer–Burmeister contacts), started from the descent's q with the penalty
   forces as multiplier estimates (λ = k_p g, λ_∂ = k_p max(−w_∂, 0)), so that every returned
   state is an equilibrium of the same equations as every other solve.

Everything is fixed-shape (a chunk of seeds, bounded loops), so one compilation
serves every chunk and every law/geometry of the layout.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any, NamedTuple

from biplan._compile import linalg
from biplan._compile.kernel import kernel
from biplan._compile.setup import jax, jnp
from biplan.geometry.layout import TubeLayout
from biplan.model.lagrangian import kkt_jacobian_at_rest, residual_at_rest, sizes
from biplan.model.params import AT_REST, ModelParams
from biplan.model.potential import contact_gaps, energy, fold_openings, guide_values
from biplan.solvers.core import machine
from biplan.solvers.core_settings import Settings
from biplan.solvers.newton import newton_loop
from biplan.solvers.pool import LANES, refill

__all__ = ["RelaxOutput", "relax_pool", "relax_seed"]

Array = Any

#: Gauss–Newton iterations of the kinematic seed (at most), the largest step [mm, rad] per
#: iteration, and the step below which the seed has converged [mm, rad].
SEED_ITERATIONS = 40
SEED_MAX_STEP = 0.2
SEED_STEP_TOL = 1e-13
#: Descent: trial step lengths 1, 1/2, … (evaluated together), Armijo constant, largest step
#: [mm, rad], gradient tolerance [N, N·mm] and the smallest Hessian eigenvalue after the shift.
LINE_SEARCH_POINTS = 16
ARMIJO = 1e-4
DESCENT_MAX_STEP = 0.1
DESCENT_GTOL = 1e-9
SHIFT_FLOOR = 1e-6


class RelaxOutput(NamedTuple):
    """Per-seed outcome (leading axis: seed once vmapped)."""

    q_seed: Array  # kinematic seed
    seed_residual: Array  # max |r| of the seed system [mm]
    q_descent: Array  # end of the penalised descent
    iterations: Array  # descent iterations
    z: Array  # final packed state
    status: Array  # Status value of the final KKT Newton solve
    residual: Array  # max |KKT residual| at z


def _seed(layout: TubeLayout, p: ModelParams, target: Array, mask: Array) -> tuple[Array, Array]:
    nq = layout.n_coordinates

    def res(q: Array) -> Array:
        return jnp.concatenate(
            [guide_values(layout, p, q), mask * (fold_openings(layout, p, q) - target)]
        )

    def body(s: tuple[Array, Array, Array]) -> tuple[Array, Array, Array]:
        k, q, _ = s
        r = res(q)
        j = jax.jacfwd(res)(q)
        jtj = j.T @ j
        step = linalg.solve(jtj + 1e-10 * jnp.eye(nq), -(j.T @ r))
        scale = jnp.minimum(1.0, SEED_MAX_STEP / (jnp.max(jnp.abs(step)) + 1e-300))
        new = q + scale * step
        ok = jnp.all(jnp.isfinite(new))
        moved = jnp.max(jnp.abs(scale * step))
        return k + 1, jnp.where(ok, new, q), ok & (moved < SEED_STEP_TOL)

    def cond(s: tuple[Array, Array, Array]) -> Array:
        return (s[0] < SEED_ITERATIONS) & ~s[2]

    start = (jnp.asarray(0), jnp.zeros(nq), jnp.asarray(False))
    _, q, _ = jax.lax.while_loop(cond, body, start)
    return q, jnp.max(jnp.abs(res(q)))


def _penalized_energy(layout: TubeLayout, p: ModelParams, q: Array, stiffness: Array) -> Array:
    g = guide_values(layout, p, q)
    gap = contact_gaps(layout, p, q)
    return energy(layout, p, q) + 0.5 * stiffness * (g @ g + jnp.sum(jnp.minimum(gap, 0.0) ** 2))


def _descent(
    layout: TubeLayout, p: ModelParams, stiffness: Array, max_iterations: Array
) -> tuple[Callable[[Array], tuple], Callable[[tuple], tuple], Callable[[tuple], Array]]:
    """Modified Newton descent on the penalised energy as (init, body, running) of a loop
    whose state is (q, iterations, done)."""
    fun = functools.partial(_penalized_energy, layout, p, stiffness=stiffness)
    grad = jax.grad(fun)
    hess = jax.hessian(fun)
    alphas = 0.5 ** jnp.arange(LINE_SEARCH_POINTS, dtype=float)

    def init(q0: Array) -> tuple:
        return q0, jnp.asarray(0), jnp.asarray(False)

    def running(s: tuple) -> Array:
        _, it, done = s
        return (~done) & (it < max_iterations)

    def body(s: tuple) -> tuple:
        q, it, _ = s
        e, gr, h = fun(q), grad(q), hess(q)
        lo = linalg.eigvalsh(h)[0]
        shift = jnp.maximum(0.0, SHIFT_FLOOR - lo)
        step = linalg.solve(h + shift * jnp.eye(q.shape[0]), -gr)
        scale = jnp.minimum(1.0, DESCENT_MAX_STEP / (jnp.max(jnp.abs(step)) + 1e-300))
        step = scale * step
        trial = jax.vmap(lambda a: fun(q + a * step))(alphas)
        ok = jnp.isfinite(trial) & (trial <= e + ARMIJO * alphas * (gr @ step))
        k = jnp.argmax(ok)
        new = jnp.where(jnp.any(ok), q + alphas[k] * step, q)
        done = (jnp.max(jnp.abs(gr)) < DESCENT_GTOL) | ~jnp.any(ok)
        return new, it + 1, done

    return init, body, running


def _multipliers_start(layout: TubeLayout, p: ModelParams, q: Array, stiffness: Array) -> Array:
    """The KKT start of the polish: q with the penalty forces as multiplier estimates."""
    lam = stiffness * guide_values(layout, p, q)
    lam_c = stiffness * jnp.maximum(-contact_gaps(layout, p, q), 0.0)
    return jnp.concatenate([q, lam, lam_c, jnp.zeros(1)])


def relax_seed(
    layout: TubeLayout,
    p: ModelParams,
    target: Array,
    mask: Array,
    stiffness: Array,
    max_iterations: Array,
    settings: Array,
) -> RelaxOutput:
    """Seed one fold-state combination and relax it (pure; see the module docstring): the
    same three stages as :func:`relax_pool` run for one seed (``vmap`` runs them in
    lock-step; the tests compare the two).

    Parameters
    ----------
    target : array (N + Nc,)
        Target mean elongation [mm] of every fold (helical then circular).
    mask : array (N + Nc,)
        1 for folds whose target is imposed, 0 for the others.
    stiffness : scalar
        Penalty stiffness k_p [N/mm] of the guides and contacts during the descent.
    max_iterations : scalar
        Most descent iterations.
    settings : array
        Newton settings of the final KKT solve (:meth:`biplan.solvers.Newton.settings`).
    """
    q_seed, seed_res = _seed(layout, p, target, mask)
    init, body, running = _descent(layout, p, stiffness, max_iterations)
    q, iterations, _ = jax.lax.while_loop(running, body, init(q_seed))
    z0 = _multipliers_start(layout, p, q, stiffness)
    out = newton_loop(layout, p, z0, AT_REST.for_kernel(), settings)
    return RelaxOutput(
        q_seed=q_seed,
        seed_residual=seed_res,
        q_descent=q,
        iterations=iterations,
        z=out.z,
        status=out.status,
        residual=jnp.max(jnp.abs(out.r)),
    )


@kernel("relax_pool", statics=2)
def relax_pool(
    layout: TubeLayout,
    lanes: int,
    p: ModelParams,
    target: Array,
    mask: Array,
    n_tasks: Array,
    stiffness: Array,
    max_iterations: Array,
    settings: Settings,
) -> RelaxOutput:
    """Relax seeds 0 … n_tasks−1 of (T, N + Nc) ``target``/``mask`` (pure; jit-able;
    ``relax_pool.compiled(layout, lanes)`` is its kernel).

    The kinematic seeds run in blocks of ``lanes`` (a few Gauss–Newton iterations each, in
    lock-step; blocks past n_tasks are skipped); the descent and the KKT polish run on
    ``lanes`` refilled lanes each (:func:`biplan.solvers.pool.refill`), so a seed that needs
    200 descent iterations occupies one lane while the others move on; the polish assembles
    without the load point's terms, which vanish at rest
    (:func:`biplan.model.lagrangian.residual_at_rest`). Each seed's result is :func:`relax_seed`'s
    up to rounding (the test compares them). Rows ≥ n_tasks are padding (status −1).
    """
    t_total = target.shape[0]
    nq = layout.n_coordinates
    n_blocks = (n_tasks + lanes - 1) // lanes
    seed_block = jax.vmap(functools.partial(_seed, layout, p))

    def seed_body(b: Array, acc: tuple[Array, Array]) -> tuple[Array, Array]:
        lo = jnp.minimum(b * lanes, t_total - lanes)
        t = jax.lax.dynamic_slice_in_dim(target, lo, lanes)
        m = jax.lax.dynamic_slice_in_dim(mask, lo, lanes)
        q, r = seed_block(t, m)
        return (
            jax.lax.dynamic_update_slice_in_dim(acc[0], q, lo, 0),
            jax.lax.dynamic_update_slice_in_dim(acc[1], r, lo, 0),
        )

    q_seed, seed_res = jax.lax.fori_loop(
        0, n_blocks, seed_body, (jnp.zeros((t_total, nq)), jnp.zeros(t_total))
    )

    d_init, d_body, d_running = _descent(layout, p, stiffness, max_iterations)

    def descent_step(task: Array, s: tuple) -> tuple:
        s = d_body(s)
        return s, d_running(s), (s[0], s[1])

    q_desc, iterations = refill(
        lanes,
        n_tasks,
        t_total,
        lambda task: d_init(q_seed[task]),
        descent_step,
        (q_seed, jnp.zeros(t_total, dtype=jnp.int32)),
    )

    # at rest the load point's terms vanish: the polish assembles without them
    n_init, n_body, n_running, n_finish = machine(
        functools.partial(residual_at_rest, layout, p),
        functools.partial(kkt_jacobian_at_rest, layout, p),
        settings,
        line_search_loop=True,
        axis_name=LANES,
    )

    def polish_step(task: Array, s: Any) -> tuple:
        s = n_body(s)
        fin = n_finish(s)
        return s, n_running(s), (fin.z, fin.status, jnp.max(jnp.abs(fin.r)))

    n_z = nq + sum(sizes(layout)[1:]) + 1
    z, status, residual = refill(
        lanes,
        n_tasks,
        t_total,
        lambda task: n_init(_multipliers_start(layout, p, q_desc[task], stiffness)),
        polish_step,
        (jnp.zeros((t_total, n_z)), jnp.full(t_total, -1), jnp.full(t_total, jnp.inf)),
        axis_name=LANES,
    )
    return RelaxOutput(q_seed, seed_res, q_desc, iterations, z, status, residual)
