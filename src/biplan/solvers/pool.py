"""A pool of independent Newton solves run on a fixed number of ``vmap`` lanes.

Under ``vmap`` a ``lax.while_loop`` runs until its *slowest* lane has finished, so a plain
batched Newton solve costs (number of solves) × (passes of the slowest solve): one seed that
needs 175 passes while its neighbours converge in 6 makes the whole batch pay 175. The
multi-start searches of the stability map have exactly that mix (most seeds converge in 6–8
passes, a few grind to the iteration cap).

:func:`newton_pool` instead keeps ``lanes`` solves in flight and hands a finished lane the
next task of a queue (lane refilling), so the cost is ≈ the *sum* of the passes over all tasks
divided by the number of lanes, plus a short tail. Each lane runs exactly the iteration of
:func:`biplan.solvers.newton.newton_loop` (same state machine, same settings), so a task's
result equals a single ``newton_loop(..., line_search_loop=True)`` solve from the same start.
Each step of a lane is a line search on residuals followed by one Jacobian at the accepted
point (``line_search_loop``), so lanes grinding through rejected trials of far-off seeds cost
residuals, not Jacobians.

All shapes are fixed by the (padded) task arrays and ``lanes``: the number of real tasks is a
traced scalar, so one compiled kernel serves every chunk of a sweep.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from biplan._compile.kernel import kernel
from biplan._compile.setup import jax, jnp
from biplan.geometry.layout import TubeLayout
from biplan.model.params import Load
from biplan.solvers.core_settings import Settings
from biplan.solvers.newton import newton_machine

__all__ = ["PoolResult", "newton_pool", "refill"]

Array = Any

#: Name of the lane (vmap) axis: Newton computes a Levenberg–Marquardt direction only when
#: some lane needs one (``newton_machine(axis_name=...)``).
LANES = "lanes"


class PoolResult(NamedTuple):
    """Per task (leading axis: task, padded): final iterate, status (Status value; −1 for
    padding tasks) and residual evaluations."""

    z: Array
    status: Array
    evals: Array


def refill(
    lanes: int,
    n_tasks: Array,
    n_total: int,
    init_lane: Callable[[Array], Any],
    step_lane: Callable[[Array, Any], tuple[Any, Array, Any]],
    out0: Any,
    axis_name: str | None = None,
) -> Any:
    """Run tasks 0 … n_tasks−1 on ``lanes`` refilled ``vmap`` lanes (pure; module docstring).

    Parameters
    ----------
    lanes : int
        Tasks in flight (static).
    n_tasks : int scalar
        Number of real tasks (traced); tasks n_tasks … n_total−1 are padding.
    n_total : int
        Length of the task arrays (static).
    init_lane : callable
        ``init_lane(task) -> state`` of one lane (vmapped).
    step_lane : callable
        ``step_lane(task, state) -> (state, running, result)``: one iteration of a lane;
        ``result`` (a pytree of per-lane values) is written for a lane that stops running.
    out0 : pytree
        Output arrays with a leading task axis (n_total, …); row t receives task t's result.
    axis_name : str, optional
        Name of the lane axis inside ``step_lane``.

    Returns
    -------
    pytree
        ``out0`` with the rows of the finished tasks written.
    """

    def select(mask: Array, a: Any, b: Any) -> Any:
        return jax.tree_util.tree_map(
            lambda x, y: jnp.where(mask.reshape((-1,) + (1,) * (x.ndim - 1)), x, y), a, b
        )

    lane_ids = jnp.arange(lanes)
    tasks0 = jnp.where(lane_ids < n_tasks, lane_ids, -1)
    state0 = jax.vmap(init_lane)(jnp.clip(tasks0, 0, n_total - 1))

    def cond(c: tuple) -> Array:
        return jnp.any(c[0] >= 0)

    def body(c: tuple) -> tuple:
        tasks, state, nxt, out = c
        active = tasks >= 0
        safe = jnp.clip(tasks, 0, n_total - 1)
        state, running, result = jax.vmap(step_lane, axis_name=axis_name)(safe, state)
        done = active & ~running
        idx = jnp.where(done, tasks, n_total)  # out of range: dropped
        out = jax.tree_util.tree_map(
            lambda o, r: o.at[idx].set(r.astype(o.dtype), mode="drop"), out, result
        )
        new = nxt + jnp.cumsum(done) - 1
        take = done & (new < n_tasks)
        tasks = jnp.where(take, new, jnp.where(done, -1, tasks))
        fresh = jax.vmap(init_lane)(jnp.clip(new, 0, n_total - 1))
        state = select(take, fresh, state)
        return tasks, state, nxt + jnp.sum(done), out

    nxt0 = jnp.minimum(jnp.asarray(lanes), n_tasks)
    return jax.lax.while_loop(cond, body, (tasks0, state0, nxt0, out0))[3]


@kernel("newton_pool", statics=2)
def newton_pool(
    layout: TubeLayout,
    lanes: int,
    params: Any,
    point: Array,
    z0: Array,
    loads: Load,
    n_tasks: Array,
    settings: Settings,
) -> PoolResult:
    """Solve tasks 0 … n_tasks−1 on ``lanes`` lanes (pure; jit-able;
    ``newton_pool.compiled(layout, lanes)`` is its kernel).

    Parameters
    ----------
    layout : TubeLayout
    lanes : int
        Solves in flight (static).
    params : ModelParams
        Stacked along a leading "point" axis (P, …).
    point : int array (T,)
        The point (row of ``params``) of each task.
    z0 : array (T, n_z)
        Start of each task.
    loads : Load
        Of (T,) arrays: each task's load.
    n_tasks : int scalar
        Number of real tasks (the first n_tasks of the T); the rest is padding.
    settings : Settings
        ``Newton.settings()``.
    """
    n_total = z0.shape[0]

    def parts(task: Array) -> tuple:
        p = jax.tree_util.tree_map(lambda a: a[point[task]], params)
        load = Load(*(jnp.asarray(v)[task] for v in loads))
        return newton_machine(layout, p, load, settings, line_search_loop=True, axis_name=LANES)

    def init_lane(task: Array) -> Any:
        return parts(task)[0](z0[task])

    def step_lane(task: Array, s: Any) -> tuple:
        _, body, running, finish = parts(task)
        s = body(s)
        fin = finish(s)
        return s, running(s), PoolResult(fin.z, fin.status, fin.evals)

    out0 = PoolResult(
        z=jnp.asarray(z0),
        status=jnp.full(n_total, -1),
        evals=jnp.zeros(n_total, dtype=jnp.int32),
    )
    return refill(lanes, n_tasks, n_total, init_lane, step_lane, out0, axis_name=LANES)
