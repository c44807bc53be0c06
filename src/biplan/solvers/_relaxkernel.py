"""Batched seeded relaxation: fold-state seeds → stable equilibria at zero end load (MODEL §15).

One pure function per seed, ``vmap``-ped and jitted once per tube layout. The first two
stages work in the reduced coordinates x = (u, γ) of :mod:`biplan.model.elements.reduced`
(the guides solved in closed form, MODEL §16: N + Nc unknowns instead of 3N + Nc, and no
guide penalty to make the descent stiff):

1. **Kinematic seed.** Gauss–Newton on r(x) = m ⊙ (w̄(q(x)) − t) from x = 0, where w̄ is the
   length-mean elongation of every fold (:func:`biplan.model.potential.fold_openings`),
   t the target of each fold (0 for closed, the law's open well for open) and m masks the folds
   that take part (bistable ones). The system is square for a fully bistable tube (DOF = number
   of folds); a small Levenberg damping keeps it well posed otherwise. Steps are capped, and a
   step into a kinematically locked module (q(x) undefined) ends the seed where it is.
2. **Quasi-static relaxation.** A descent method on the energy, so that the configuration
   slides downhill into the well its seed lies in and never stops on a saddle: modified Newton
   (Hessian shifted to positive definite, Armijo backtracking over a fixed set of step lengths)
   on the penalised energy Π(q(x)) + ½k_p‖min(w_∂(q(x)), 0)‖², the contacts as stiff
   penalties (MODEL §15 leaves the relaxation open; a penalty keeps every iteration smooth
   where the Fischer–Burmeister Newton stalls on contact switches far from the solution). The
   gradient and Hessian are assembled per element
   (:func:`biplan.model.elements.reduced.penalized_terms`). A Cholesky factorisation of the
   Hessian (less the shift floor) decides whether it needs a shift; its eigenvalues are computed
   only when some lane's factorisation fails. The step lengths 1, ½, ¼, ⅛ are tried first; the
   twelve shorter ones only when some lane of the batch rejected all four.
3. **KKT polish.** The Newton solver of the package (:func:`biplan.solvers.core.machine`) on
   the exact KKT system at rest in reduced coordinates
   (:func:`biplan.model.lagrangian.reduced_residual_at_rest`: stationarity and smoothed
   Fischer–Burmeister contacts, the guides satisfied exactly), started from the descent's x
   with contact multiplier estimates: the penalty force k_p max(−w_∂, 0) or, if larger, the
   multiplier on the smoothed Fischer–Burmeister curve at max(w_∂, 0) (a closed contact that
   carries almost no force would otherwise start at λ_∂ = 0 and Newton crawl towards the
   curve's corner, halving the residual per step). The solution is mapped to the full state
   (:func:`biplan.model.lagrangian.full_state`: q(x), the guide multipliers by least squares)
   and the full KKT residual evaluated there is the one reported; a solve whose full residual
   misses the tolerance is not converged. So every returned state is an equilibrium of the
   same equations as every other solve.

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
from biplan.model.elements.reduced import (
    full_coordinates,
    n_reduced,
    penalized_energy,
    penalized_terms,
)
from biplan.model.lagrangian import (
    full_state,
    reduced_kkt_jacobian_at_rest,
    reduced_residual_at_rest,
    residual_at_rest,
    sizes,
)
from biplan.model.params import ModelParams
from biplan.model.potential import contact_gaps, fold_openings
from biplan.solvers.core import iterate, machine
from biplan.solvers.core_settings import Settings, Status
from biplan.solvers.pool import LANES, refill

__all__ = ["RelaxOutput", "relax_pool", "relax_seed"]

Array = Any

#: Gauss–Newton iterations of the kinematic seed (at most), the largest step [mm] per
#: iteration, and the step below which the seed has converged [mm].
SEED_ITERATIONS = 40
SEED_MAX_STEP = 0.2
SEED_STEP_TOL = 1e-13
#: Descent: trial step lengths 1, 1/2, … (the first FIRST_POINTS of them tried first), Armijo
#: constant, largest step [mm], gradient tolerance [N, N·mm] and the smallest Hessian
#: eigenvalue after the shift.
LINE_SEARCH_POINTS = 16
FIRST_POINTS = 4
ARMIJO = 1e-4
DESCENT_MAX_STEP = 1.0
DESCENT_GTOL = 1e-3
SHIFT_FLOOR = 1e-6


class RelaxOutput(NamedTuple):
    """Per-seed outcome (leading axis: seed once vmapped); coordinates are full (3N + Nc)."""

    q_seed: Array  # kinematic seed
    seed_residual: Array  # max |r| of the seed system [mm]
    q_descent: Array  # end of the penalised descent
    iterations: Array  # descent iterations
    z: Array  # final packed state
    status: Array  # Status value of the final KKT Newton solve
    residual: Array  # max |KKT residual| at z


def _seed(layout: TubeLayout, p: ModelParams, target: Array, mask: Array) -> tuple[Array, Array]:
    """Kinematic seed in reduced coordinates x and the max |r| of its system [mm]."""
    nx = n_reduced(layout)

    def res(x: Array) -> Array:
        return mask * (fold_openings(layout, p, full_coordinates(layout, p, x)) - target)

    def body(s: tuple[Array, Array, Array]) -> tuple[Array, Array, Array]:
        k, x, _ = s
        r = res(x)
        j = jax.jacfwd(res)(x)
        step = linalg.solve(j.T @ j + 1e-10 * jnp.eye(nx), -(j.T @ r))
        scale = jnp.minimum(1.0, SEED_MAX_STEP / (jnp.max(jnp.abs(step)) + 1e-300))
        new = x + scale * step
        ok = jnp.all(jnp.isfinite(res(new)))  # not into a locked module
        moved = jnp.max(jnp.abs(scale * step))
        return k + 1, jnp.where(ok, new, x), ~ok | (moved < SEED_STEP_TOL)

    def cond(s: tuple[Array, Array, Array]) -> Array:
        return (s[0] < SEED_ITERATIONS) & ~s[2]

    start = (jnp.asarray(0), jnp.zeros(nx), jnp.asarray(False))
    _, x, _ = jax.lax.while_loop(cond, body, start)
    return x, jnp.max(jnp.abs(res(x)))


def _descent(
    layout: TubeLayout,
    p: ModelParams,
    stiffness: Array,
    max_iterations: Array,
    axis_name: str | None = None,
) -> tuple[Callable[[Array], tuple], Callable[[tuple], tuple], Callable[[tuple], Array]]:
    """Modified Newton descent on the penalised energy in reduced coordinates as (init, body,
    running) of a loop whose state is (x, iterations, done). With ``axis_name`` (the lanes'
    ``vmap`` axis) the short step lengths are evaluated only when some lane needs them."""
    alphas = 0.5 ** jnp.arange(LINE_SEARCH_POINTS, dtype=float)

    def energy_at(x: Array, step: Array, a: Array) -> Array:
        return jax.vmap(lambda t: penalized_energy(layout, p, x + t * step, stiffness))(a)

    def init(x0: Array) -> tuple:
        return x0, jnp.asarray(0), jnp.asarray(False)

    def running(s: tuple) -> Array:
        _, it, done = s
        return (~done) & (it < max_iterations)

    def body(s: tuple) -> tuple:
        x, it, _ = s
        terms = penalized_terms(layout, p, x, stiffness)
        e, gr, h = terms.value, terms.gradient, terms.hessian
        lo = _smallest_eigenvalue(h, axis_name)
        shift = jnp.maximum(0.0, SHIFT_FLOOR - lo)
        step = linalg.solve(h + shift * jnp.eye(x.shape[0]), -gr)
        scale = jnp.minimum(1.0, DESCENT_MAX_STEP / (jnp.max(jnp.abs(step)) + 1e-300))
        step = scale * step
        slope = gr @ step

        def accepted(trial: Array, a: Array) -> Array:
            return jnp.isfinite(trial) & (trial <= e + ARMIJO * a * slope)

        first = energy_at(x, step, alphas[:FIRST_POINTS])
        need = ~jnp.any(accepted(first, alphas[:FIRST_POINTS]))
        if axis_name is not None:
            need = jax.lax.psum(need.astype(jnp.int32), axis_name) > 0
        rest = jax.lax.cond(
            need,
            lambda: energy_at(x, step, alphas[FIRST_POINTS:]),
            lambda: jnp.full(LINE_SEARCH_POINTS - FIRST_POINTS, jnp.inf),
        )
        ok = accepted(jnp.concatenate([first, rest]), alphas)
        k = jnp.argmax(ok)
        new = jnp.where(jnp.any(ok), x + alphas[k] * step, x)
        done = ((jnp.max(jnp.abs(gr)) < DESCENT_GTOL) & (lo > SHIFT_FLOOR)) | ~jnp.any(ok)
        return new, it + 1, done

    return init, body, running


def _smallest_eigenvalue(h: Array, axis_name: str | None) -> Array:
    """λ_min of the Hessian h where it matters: +∞ when h − SHIFT_FLOOR·I is positive definite
    (a Cholesky factorisation succeeds, so no shift is needed and the curvature test passes),
    else the eigenvalue. With ``axis_name`` the eigenvalues are computed only when some lane's
    factorisation failed (they cost eight times a factorisation)."""
    floor = SHIFT_FLOOR * jnp.eye(h.shape[0])
    definite = jnp.all(jnp.isfinite(linalg.cholesky(h - floor)))
    need = ~definite
    if axis_name is not None:
        need = jax.lax.psum(need.astype(jnp.int32), axis_name) > 0
    lo = jax.lax.cond(need, lambda: linalg.eigvalsh(h)[0], lambda: jnp.asarray(jnp.inf))
    return jnp.where(definite, jnp.inf, lo)


def _polish_start(layout: TubeLayout, p: ModelParams, x: Array, stiffness: Array) -> Array:
    """The start v = [x, λ_∂, μ] of the reduced KKT polish (module docstring, stage 3)."""
    w = contact_gaps(layout, p, full_coordinates(layout, p, x))
    eps2, c = p.smoothing**2, p.compliance
    wp = jnp.maximum(w, 0.0)
    denominator = wp + jnp.sqrt(wp**2 + 2.0 * c * eps2)
    on_curve = jnp.where(denominator > 0.0, eps2 / jnp.maximum(denominator, 1e-300), p.smoothing)
    lam_c = jnp.maximum(-stiffness * w, on_curve)
    return jnp.concatenate([x, lam_c, jnp.zeros(1)])


def _polish_functions(layout: TubeLayout, p: ModelParams) -> tuple[Callable, Callable]:
    return (
        functools.partial(reduced_residual_at_rest, layout, p),
        functools.partial(reduced_kkt_jacobian_at_rest, layout, p),
    )


def _full_result(
    layout: TubeLayout, p: ModelParams, v: Array, status: Array, atol: Array
) -> tuple[Array, Array, Array]:
    """(z, status, max |r|) in the full coordinates of a polished reduced state v: the full
    KKT residual is evaluated, and a solve whose full residual misses ``atol`` is not
    converged (:attr:`Status.MAX_STEPS`)."""
    z = full_state(layout, p, v)
    residual = jnp.max(jnp.abs(residual_at_rest(layout, p, z)))
    missed = (status == Status.CONVERGED.value) & ~(residual < atol)
    return z, jnp.where(missed, Status.MAX_STEPS.value, status), residual


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
        Penalty stiffness k_p [N/mm] of the contacts during the descent.
    max_iterations : scalar
        Most descent iterations.
    settings : array
        Newton settings of the final KKT solve (:meth:`biplan.solvers.Newton.settings`).
    """
    x_seed, seed_res = _seed(layout, p, target, mask)
    init, body, running = _descent(layout, p, stiffness, max_iterations)
    x, iterations, _ = jax.lax.while_loop(running, body, init(x_seed))
    res, jac = _polish_functions(layout, p)
    out = iterate(res, jac, _polish_start(layout, p, x, stiffness), settings)
    z, status, residual = _full_result(layout, p, out.z, out.status, settings.atol)
    return RelaxOutput(
        q_seed=full_coordinates(layout, p, x_seed),
        seed_residual=seed_res,
        q_descent=full_coordinates(layout, p, x),
        iterations=iterations,
        z=z,
        status=status,
        residual=residual,
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
    nx = n_reduced(layout)
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

    x_seed, seed_res = jax.lax.fori_loop(
        0, n_blocks, seed_body, (jnp.zeros((t_total, nx)), jnp.zeros(t_total))
    )

    d_init, d_body, d_running = _descent(layout, p, stiffness, max_iterations, LANES)

    def descent_step(task: Array, s: tuple) -> tuple:
        s = d_body(s)
        return s, d_running(s), (s[0], s[1])

    x_desc, iterations = refill(
        lanes,
        n_tasks,
        t_total,
        lambda task: d_init(x_seed[task]),
        descent_step,
        (x_seed, jnp.zeros(t_total, dtype=jnp.int32)),
        axis_name=LANES,
    )

    n_init, n_body, n_running, n_finish = machine(
        *_polish_functions(layout, p), settings, line_search_loop=True, axis_name=LANES
    )

    def polish_step(task: Array, s: Any) -> tuple:
        s = n_body(s)
        fin = n_finish(s)
        return s, n_running(s), (fin.z, fin.status)

    n_v = nx + sizes(layout)[2] + 1
    v, status = refill(
        lanes,
        n_tasks,
        t_total,
        lambda task: n_init(_polish_start(layout, p, x_desc[task], stiffness)),
        polish_step,
        (jnp.zeros((t_total, n_v)), jnp.full(t_total, -1)),
        axis_name=LANES,
    )
    z, status, residual = jax.vmap(lambda v_, s_: _full_result(layout, p, v_, s_, settings.atol))(
        v, status
    )
    padding = jnp.arange(t_total) >= n_tasks
    status = jnp.where(padding, -1, status)
    residual = jnp.where(padding, jnp.inf, residual)
    full = jax.vmap(functools.partial(full_coordinates, layout, p))
    return RelaxOutput(full(x_seed), seed_res, full(x_desc), iterations, z, status, residual)
