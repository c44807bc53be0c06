"""Batched seeded relaxation: fold-state seeds → stable equilibria at zero end load (MODEL §15).

One pure function per seed, ``vmap``-ped and jitted once per tube layout:

1. **Kinematic seed.** Gauss–Newton on r(q) = [g(q); m ⊙ (w̄(q) − t)] from q = 0, where g are
   the guides, w̄ the length-mean elongation of every fold (:func:`biplan.assembly.fold_openings`),
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
from typing import Any, NamedTuple

from biplan import _linalg as linalg
from biplan._jax import jax, jnp
from biplan._kernels import kernel
from biplan.assembly import (
    Load,
    ModelParams,
    TubeLayout,
    contact_gaps,
    energy,
    fold_openings,
    guide_values,
    sizes,
)
from biplan.solvers.newton import newton_loop

__all__ = ["RelaxOutput", "relax_seed"]

Array = Any

#: Gauss–Newton iterations of the kinematic seed and the largest step [mm, rad] per iteration.
SEED_ITERATIONS = 40
SEED_MAX_STEP = 0.2
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

    def body(_: int, q: Array) -> Array:
        r = res(q)
        j = jax.jacfwd(res)(q)
        jtj = j.T @ j
        step = linalg.solve(jtj + 1e-10 * jnp.eye(nq), -(j.T @ r))
        scale = jnp.minimum(1.0, SEED_MAX_STEP / (jnp.max(jnp.abs(step)) + 1e-300))
        new = q + scale * step
        return jnp.where(jnp.all(jnp.isfinite(new)), new, q)

    q = jax.lax.fori_loop(0, SEED_ITERATIONS, body, jnp.zeros(nq))
    return q, jnp.max(jnp.abs(res(q)))


def _penalized_energy(layout: TubeLayout, p: ModelParams, q: Array, stiffness: Array) -> Array:
    g = guide_values(layout, p, q)
    gap = contact_gaps(layout, p, q)
    return energy(layout, p, q) + 0.5 * stiffness * (g @ g + jnp.sum(jnp.minimum(gap, 0.0) ** 2))


def _descend(
    layout: TubeLayout, p: ModelParams, q0: Array, stiffness: Array, max_iterations: Array
) -> tuple[Array, Array]:
    """Modified Newton descent on the penalised energy: (q, iterations)."""
    fun = functools.partial(_penalized_energy, layout, p, stiffness=stiffness)
    grad = jax.grad(fun)
    hess = jax.hessian(fun)
    alphas = 0.5 ** jnp.arange(LINE_SEARCH_POINTS, dtype=float)
    nq = q0.shape[0]

    def cond(s: tuple[Array, Array, Array]) -> Array:
        _, it, done = s
        return (~done) & (it < max_iterations)

    def body(s: tuple[Array, Array, Array]) -> tuple[Array, Array, Array]:
        q, it, _ = s
        e, gr, h = fun(q), grad(q), hess(q)
        lo = linalg.eigvalsh(h)[0]
        shift = jnp.maximum(0.0, SHIFT_FLOOR - lo)
        step = linalg.solve(h + shift * jnp.eye(nq), -gr)
        scale = jnp.minimum(1.0, DESCENT_MAX_STEP / (jnp.max(jnp.abs(step)) + 1e-300))
        step = scale * step
        trial = jax.vmap(lambda a: fun(q + a * step))(alphas)
        ok = jnp.isfinite(trial) & (trial <= e + ARMIJO * alphas * (gr @ step))
        k = jnp.argmax(ok)
        new = jnp.where(jnp.any(ok), q + alphas[k] * step, q)
        done = (jnp.max(jnp.abs(gr)) < DESCENT_GTOL) | ~jnp.any(ok)
        return new, it + 1, done

    q, it, _ = jax.lax.while_loop(cond, body, (q0, jnp.asarray(0), jnp.asarray(False)))
    return q, it


@kernel("relax", in_axes=(None, 0, 0, None, None, None))
def relax_seed(
    layout: TubeLayout,
    p: ModelParams,
    target: Array,
    mask: Array,
    stiffness: Array,
    max_iterations: Array,
    settings: Array,
) -> RelaxOutput:
    """Seed one fold-state combination and relax it (pure; see the module docstring).

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
    _nq, _ng, _nc = sizes(layout)
    q_seed, seed_res = _seed(layout, p, target, mask)
    q, iterations = _descend(layout, p, q_seed, stiffness, max_iterations)
    lam = stiffness * guide_values(layout, p, q)
    lam_c = stiffness * jnp.maximum(-contact_gaps(layout, p, q), 0.0)
    z0 = jnp.concatenate([q, lam, lam_c, jnp.zeros(1)])
    load = Load(jnp.asarray(0.0), jnp.asarray(0.0), jnp.asarray(0.0))
    out = newton_loop(layout, p, z0, load, settings)
    return RelaxOutput(
        q_seed=q_seed,
        seed_residual=seed_res,
        q_descent=q,
        iterations=iterations,
        z=out.z,
        status=out.status,
        residual=jnp.max(jnp.abs(out.r)),
    )
