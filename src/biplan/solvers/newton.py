"""Newton solver for the KKT system of a constrained, contact-regularised equilibrium (MODEL §11).

``solve_equilibrium(model, Newton(...), start, load)`` solves r(z) = 0 for z = [q, λ, λ_∂, μ].
Globalisation: Newton direction with Armijo backtracking on the merit ½‖r‖²; when the line
search fails (or the Newton matrix is singular) a Levenberg–Marquardt step on ½‖r‖² is tried
with adaptive damping. The whole loop is one ``jax.lax.while_loop`` compiled once per tube
layout (tolerances and limits are traced), so it is cheap to call repeatedly and ``vmap``-able.
"""

from __future__ import annotations

import enum
import functools
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np

from biplan import _linalg as linalg
from biplan._errors import ConfigError, ConvergenceError, check_integer, check_range
from biplan._jax import jax, jnp, kernel_options
from biplan._kernels import stored_jit
from biplan.assembly import Load, Model, StateData, TubeLayout, kernels, state_from_jacobian

__all__ = ["Newton", "Solution", "Status", "relaxed_reference", "solve_equilibrium"]

Array = Any


class Status(enum.Enum):
    """Outcome of a solve."""

    CONVERGED = 0
    MAX_STEPS = 1
    LINE_SEARCH_FAILED = 2
    NONFINITE = 3

    @property
    def message(self) -> str:
        return {
            0: "converged",
            1: "maximum number of Newton steps reached before the residual tolerance",
            2: "neither the Newton line search nor Levenberg–Marquardt reduced the residual",
            3: "the residual or the Newton step became non-finite",
        }[self.value]


@dataclass(frozen=True)
class Newton:
    """Configured Newton solver.

    Parameters
    ----------
    atol : float
        Convergence when ‖r‖∞ < atol (residual units N, mm), > 0.
    max_steps : int
        Newton iterations, ≥ 1.
    max_backtracks : int
        Step halvings in the Armijo line search, ≥ 1.
    armijo : float
        Sufficient-decrease constant c in (0, 0.5).
    free_steps : int
        Watchdog (Chamberlain et al. 1982): the first ``free_steps`` Newton steps of a solve
        are taken whenever the trial point is finite, without the line-search test; the
        iterate of smallest merit is kept, and a solve that has not converged when they run
        out continues from it with the line search. 0 (default) is the plain globalised
        iteration. Near contact switches the merit ½‖r‖² of the smoothed Fischer–Burmeister
        rows is so curved (ε = 1e-6) that the line search rejects full Newton steps that
        would converge in a few iterations (docs/maps.md); ≥ 0 (steps past ``max_steps``
        never happen).
    contact_restart : bool
        A solve that fails from a start with non-zero contact multipliers λ_∂ (a warm start
        from a Solution) is tried once more from the same q, λ and μ with λ_∂ = 0 (default
        True; :attr:`Solution.restarts` counts it). The contact multipliers of a converged
        state can be artefacts of the smoothing (λ_∂·w_∂ = ε²/2 at gaps ~1e-9 mm): at that
        corner of the Fischer–Burmeister function the Jacobian is near-singular, and with
        ``ModelOptions.contact_compliance = 0`` Newton drifts into penetration and stalls
        when a new load presses the contacts shut. With the default compliance this is a
        safety net (docs/model.md, "Degenerate contacts").
    """

    atol: float = 1e-9
    max_steps: int = 60
    max_backtracks: int = 30
    armijo: float = 1e-4
    free_steps: int = 0
    contact_restart: bool = True

    def __post_init__(self) -> None:
        check_range("Newton.atol", self.atol, low=0.0)
        check_range("Newton.armijo", self.armijo, low=0.0, high=0.5)
        for name in ("max_steps", "max_backtracks"):
            object.__setattr__(
                self, name, check_integer(f"Newton.{name}", getattr(self, name), low=1)
            )
        object.__setattr__(
            self, "free_steps", check_integer("Newton.free_steps", self.free_steps, low=0)
        )
        if not isinstance(self.contact_restart, bool):
            raise ConfigError("Newton.contact_restart", self.contact_restart, "True or False")

    def settings(self) -> Array:
        """[atol, max_steps, max_backtracks, armijo, free_steps]: the traced settings of the
        compiled iterations (:func:`newton_machine`)."""
        return jnp.asarray(
            [self.atol, self.max_steps, self.max_backtracks, self.armijo, self.free_steps]
        )


class LoopState(NamedTuple):
    z: Array  # accepted iterate
    r: Array  # residual at z
    f: Array  # merit ½‖r‖² at z
    jac: Array  # Jacobian at z
    dz: Array  # current search direction
    slope: Array  # r·J dz (directional derivative of the merit)
    alpha: Array  # trial step length
    lm: Array  # True while trying Levenberg–Marquardt steps
    damping: Array  # LM damping
    steps: Array  # accepted steps
    evals: Array  # residual evaluations
    status: Array  # -1 running, else Status value
    pending: Array  # True: the trial z + α dz was accepted, its Jacobian is still due
    r_trial: Array  # residual at the pending trial
    f_trial: Array  # merit at the pending trial
    free: Array  # watchdog steps left (Newton.free_steps)
    best_z: Array  # watchdog: iterate of smallest merit, its residual, merit, Jacobian,
    best_r: Array  # direction and LM flag
    best_f: Array
    best_jac: Array
    best_dz: Array
    best_lm: Array


#: The fields of the iterate that the watchdog keeps for its best point (``best_<name>``).
_WATCHED = ("z", "r", "f", "jac", "dz", "lm")


def newton_machine(
    layout: TubeLayout,
    params: Any,
    load: Load,
    settings: Array,
    line_search_loop: bool = False,
    free_steps: int | None = 0,
    axis_name: str | None = None,
) -> tuple:
    """(init, body, running, finish) of the globalised Newton iteration of :func:`newton_loop`.

    ``init(z0)`` is the state before the first step, ``body(state)`` one step,
    ``running(state)`` whether another step is due and ``finish(state)`` sets the final
    status. Exposed so that a driver other than ``lax.while_loop`` (e.g.
    :func:`biplan.solvers.pool.newton_pool`) can run the same iteration.

    Newton steps with Armijo backtracking on ½‖r‖² that fall back, once α is exhausted, to
    Levenberg–Marquardt steps with growing damping (solved with the Jacobian of the current
    iterate). Two equivalent drivers of that search (static ``line_search_loop``):

    * ``False`` (default): ``body`` is one pass — one trial point, its residual and its
      Jacobian (used only if the trial is accepted), with a single residual and a single
      Jacobian site and one merged LM solve: the smallest graph and the cheapest pass when
      nearly every trial is accepted (load stepping, the design map);
    * ``True``: ``body`` is a line search on residuals alone (an inner ``while_loop`` over
      trial points) followed by one Jacobian at the accepted point. Under ``vmap`` a lane
      that has accepted waits (cheap: residuals and solves) while the others backtrack, so a
      batch evaluates one Jacobian per accepted step instead of one per trial point: faster
      when many trials are rejected (multi-start searches from far-off seeds, the
      stability map's pool).

    Both visit the same trial points (results equal to rounding; a solve that grinds through
    hundreds of LM trials can end differently). ``free_steps`` (static) is the watchdog of
    :class:`Newton`; with 0 its state fields are carried but never computed. With None the
    watchdog is compiled in and its length is traced (``settings[4]``, as
    :meth:`Newton.settings`): one kernel serves every watchdog length, and a length of 0 takes
    the same iterates as the static 0 (the bookkeeping runs, but never accepts a step nor
    reverts).

    ``axis_name`` (static): the name of an enclosing ``vmap`` axis (``jax.vmap(...,
    axis_name=...)``). The Levenberg–Marquardt direction (a normal-equations solve, ≈ 1/4 of
    a pass) is then computed only when some lane of the batch needs it (``lax.cond`` on a
    ``psum`` over the axis); without it, ``vmap`` turns that ``cond`` into a select and every
    lane pays for it on every pass. Unbatched, the ``cond`` skips it per solve. Same results
    either way (a skipped direction is never selected).
    """
    k = kernels(layout)
    atol, max_steps, max_bt, c_arm = settings[0], settings[1], settings[2], settings[3]
    watchdog = free_steps is None or free_steps > 0
    free0 = settings[4].astype(jnp.asarray(0).dtype) if free_steps is None else free_steps
    alpha_min = 0.5**max_bt
    max_evals = max_steps * (max_bt + 1)

    def lm_direction(jac: Array, r: Array, damping: Array) -> Array:
        jtj = jac.T @ jac
        step = linalg.solve(jtj + damping * jnp.diag(jnp.diag(jtj) + 1e-12), -(jac.T @ r))
        return jnp.where(jnp.isfinite(step), step, 0.0)

    def any_lane(need: Array) -> Array:
        if axis_name is not None:
            return jax.lax.psum(need.astype(jnp.int32), axis_name) > 0
        return need

    def lm_if(need: Array, jac: Array, r: Array, damping: Array) -> Array:
        """:func:`lm_direction` where ``need`` (zeros elsewhere: never selected there),
        computed only if some lane of the ``axis_name`` batch needs it."""
        return jax.lax.cond(
            any_lane(need), lambda: lm_direction(jac, r, damping), lambda: jnp.zeros_like(r)
        )

    def evaluate(s: LoopState) -> tuple:
        """The trial point z + α dz, its residual and merit, and whether it is accepted
        (Armijo on ½‖r‖², plain decrease in LM mode, anything finite at the start)."""
        zt = s.z + s.alpha * s.dz
        rt = k.residual(params, zt, load)
        ft = 0.5 * rt @ rt
        ft = jnp.where(jnp.isfinite(ft), ft, jnp.inf)
        armijo = ft <= s.f + c_arm * s.alpha * s.slope
        accept = jnp.where(s.lm, ft < s.f, armijo) | ~jnp.isfinite(s.f)
        if watchdog:
            accept = accept | (s.free > 0)
        return zt, rt, ft, accept & jnp.isfinite(ft)

    def watch(prev: LoopState, new: LoopState, accepted: Array) -> LoopState:
        """Watchdog bookkeeping after a pass: count the free step, keep the best iterate and,
        when the free steps are spent without convergence, go back to the best one."""
        if not watchdog:
            return new
        used = accepted & jnp.isfinite(prev.f) & (prev.free > 0)
        free = prev.free - used.astype(prev.free.dtype)
        better = accepted & (new.f < prev.best_f)

        best = {k: jnp.where(better, getattr(new, k), getattr(prev, f"best_{k}")) for k in _WATCHED}
        out = new._replace(free=free, **{f"best_{k}": v for k, v in best.items()})
        # spent without convergence (also at the step limit: a failed solve returns its best)
        unconverged = new.status != Status.CONVERGED.value
        revert = used & (free == 0) & unconverged & (best["f"] < new.f)
        back = out._replace(
            **best, slope=best["r"] @ (best["jac"] @ best["dz"]), alpha=jnp.asarray(1.0)
        )
        return jax.tree_util.tree_map(lambda a, b: jnp.where(revert, a, b), back, out)

    def searching(s: LoopState) -> Array:
        return (s.status < 0) & ~s.pending & (s.evals < max_evals)

    def trial(s: LoopState) -> LoopState:
        """Evaluate the trial point: accept it (pending its Jacobian) or step back."""
        _, rt, ft, accept = evaluate(s)
        # rejected: backtrack, then Levenberg–Marquardt with growing damping
        to_lm = s.lm | (s.alpha * 0.5 < alpha_min)
        damping_r = jnp.where(s.lm, s.damping * 10.0, s.damping)
        dz_r = jnp.where(to_lm, lm_if(~accept & to_lm, s.jac, s.r, damping_r), s.dz)
        failed = damping_r > 1e12
        # only the search fields change (z, r, f, jac and steps stay until the update)
        return s._replace(
            dz=jnp.where(accept, s.dz, dz_r),
            slope=jnp.where(accept, s.slope, s.r @ (s.jac @ dz_r)),
            alpha=jnp.where(accept, s.alpha, jnp.where(to_lm, 1.0, 0.5 * s.alpha)),
            lm=jnp.where(accept, s.lm, to_lm),
            damping=jnp.where(accept, s.damping, damping_r),
            status=jnp.where(~accept & failed, Status.LINE_SEARCH_FAILED.value, s.status),
            pending=accept,
            r_trial=jnp.where(accept, rt, s.r_trial),
            f_trial=jnp.where(accept, ft, s.f_trial),
            evals=s.evals + 1,
        )

    def update(s: LoopState) -> LoopState:
        """Move to the accepted trial point: its Jacobian and Newton direction."""
        zt, rt, ft = s.z + s.alpha * s.dz, s.r_trial, s.f_trial
        jt = k.jacobian(params, zt, load)
        dz_n = linalg.solve(jt, -rt)
        newton_ok = jnp.all(jnp.isfinite(dz_n))
        # singular Newton system: a Levenberg–Marquardt step instead
        dz_a = jnp.where(newton_ok, dz_n, lm_if(s.pending & ~newton_ok, jt, rt, s.damping))
        steps = s.steps + jnp.where(jnp.isfinite(s.f), 1, 0)
        status = jnp.where(
            jnp.max(jnp.abs(rt)) < atol,
            Status.CONVERGED.value,
            jnp.where(steps >= max_steps, Status.MAX_STEPS.value, -1),
        )
        moved = s._replace(
            z=zt,
            r=rt,
            f=ft,
            jac=jt,
            dz=dz_a,
            slope=rt @ (jt @ dz_a),
            alpha=jnp.asarray(1.0),
            lm=~newton_ok,
            damping=jnp.maximum(s.damping * 0.3, 1e-9),
            steps=steps,
            status=status,
            pending=jnp.asarray(False),
        )
        new = jax.tree_util.tree_map(lambda a, b: jnp.where(s.pending, a, b), moved, s)
        return watch(s, new, s.pending)

    def one_pass(s: LoopState) -> LoopState:
        """One trial point and its Jacobian (accepted or not): the default step."""
        zt, rt, ft, accept = evaluate(s)
        jt = k.jacobian(params, zt, load)

        # accepted: new iterate and Newton direction
        dz_n = linalg.solve(jt, -rt)
        newton_ok = jnp.all(jnp.isfinite(dz_n))
        converged = jnp.max(jnp.abs(rt)) < atol

        # rejected: backtrack, then Levenberg–Marquardt with growing damping
        to_lm = s.lm | (s.alpha * 0.5 < alpha_min)
        damping_r = jnp.where(s.lm, s.damping * 10.0, s.damping)

        # one Levenberg–Marquardt solve serves both outcomes (an accepted trial whose Newton
        # system is singular, or a rejected one that switches to LM): select its inputs
        dz_lm = lm_if(
            jnp.where(accept, ~newton_ok, to_lm),
            jnp.where(accept, jt, s.jac),
            jnp.where(accept, rt, s.r),
            jnp.where(accept, s.damping, damping_r),
        )
        dz_a = jnp.where(newton_ok, dz_n, dz_lm)
        slope_a = rt @ (jt @ dz_a)
        dz_r = jnp.where(to_lm, dz_lm, s.dz)
        alpha_r = jnp.where(to_lm, 1.0, 0.5 * s.alpha)

        z = jnp.where(accept, zt, s.z)
        steps = s.steps + jnp.where(accept & jnp.isfinite(s.f), 1, 0)
        status = jnp.where(
            accept & converged,
            Status.CONVERGED.value,
            jnp.where(
                ~accept & (damping_r > 1e12),
                Status.LINE_SEARCH_FAILED.value,
                jnp.where(steps >= max_steps, Status.MAX_STEPS.value, -1),
            ),
        )
        new = s._replace(
            z=z,
            r=jnp.where(accept, rt, s.r),
            f=jnp.where(accept, ft, s.f),
            jac=jnp.where(accept, jt, s.jac),
            dz=jnp.where(accept, dz_a, dz_r),
            slope=jnp.where(accept, slope_a, s.r @ (s.jac @ dz_r)),
            alpha=jnp.where(accept, 1.0, alpha_r),
            lm=jnp.where(accept, ~newton_ok, to_lm),
            damping=jnp.where(accept, jnp.maximum(s.damping * 0.3, 1e-9), damping_r),
            steps=steps,
            evals=s.evals + 1,
            status=status,
        )
        return watch(s, new, accept)

    def search_step(s: LoopState) -> LoopState:
        return update(jax.lax.while_loop(searching, trial, s))

    body = search_step if line_search_loop else one_pass

    def cond(s: LoopState) -> Array:
        return (s.status < 0) & (s.evals < max_evals)

    def init(z0: Array) -> LoopState:
        n = z0.shape[0]
        return LoopState(
            z=z0,
            r=jnp.zeros(n),
            f=jnp.asarray(jnp.inf),
            jac=jnp.eye(n),
            dz=jnp.zeros(n),
            slope=jnp.asarray(0.0),
            alpha=jnp.asarray(0.0),
            lm=jnp.asarray(False),
            damping=jnp.asarray(1e-3),
            steps=jnp.asarray(0),
            evals=jnp.asarray(0),
            status=jnp.asarray(-1),
            pending=jnp.asarray(False),
            r_trial=jnp.zeros(n),
            f_trial=jnp.asarray(jnp.inf),
            free=jnp.asarray(free0),
            best_z=z0,
            best_r=jnp.zeros(n),
            best_f=jnp.asarray(jnp.inf),
            best_jac=jnp.eye(n),
            best_dz=jnp.zeros(n),
            best_lm=jnp.asarray(False),
        )

    def finish(out: LoopState) -> LoopState:
        status = jnp.where(out.status < 0, Status.MAX_STEPS.value, out.status)
        status = jnp.where(jnp.isfinite(out.f), status, Status.NONFINITE.value)
        return out._replace(status=status)

    return init, body, cond, finish


def newton_loop(
    layout: TubeLayout,
    params: Any,
    z0: Array,
    load: Load,
    settings: Array,
    line_search_loop: bool = False,
    free_steps: int | None = 0,
    axis_name: str | None = None,
) -> LoopState:
    """Pure (jit/vmap-able) globalised Newton iteration (:func:`newton_machine`): Newton steps
    with an Armijo line search on ½‖r‖² that falls back to Levenberg–Marquardt steps with
    growing damping; one residual evaluation site (the line search) and one Jacobian
    evaluation site (the accepted point), so that the compiled graph is small.
    """
    init, body, cond, finish = newton_machine(
        layout, params, load, settings, line_search_loop, free_steps, axis_name
    )
    return finish(jax.lax.while_loop(cond, body, init(z0)))


def solve_loop(
    layout: TubeLayout, params: Any, z0: Array, load: Load, settings: Array
) -> tuple[LoopState, StateData]:
    """:func:`newton_loop` (watchdog length traced) and the :class:`StateData` of its last
    iterate, taken from the Jacobian the loop evaluated there (no second assembly; valid once
    the loop accepted a pass, i.e. its merit ``f`` is finite)."""
    out = newton_loop(layout, params, z0, load, settings, free_steps=None)
    return out, state_from_jacobian(layout, params, out.z, load, out.jac)


@functools.lru_cache(maxsize=64)
def compiled_loop(layout: TubeLayout) -> Any:
    """The jitted :func:`solve_loop` of a layout, ``(LoopState, StateData)`` (built once;
    the watchdog length is traced, so every :class:`Newton` shares it)."""
    fn = functools.partial(solve_loop, layout)
    return stored_jit(fn, "newton_loop", layout, kernel_options(runs_often=True))


@dataclass(frozen=True)
class Solution:
    """A (possibly failed) equilibrium solve.

    Attributes
    ----------
    q : ndarray
        Generalised coordinates (n_q,).
    multipliers : ndarray
        Guide multipliers λ [N] (2N,).
    contact_multipliers : ndarray
        Contact multipliers λ_∂ [N] (n_c,).
    force : float
        End force [N]: the applied F, or the reaction −μ under displacement control.
    displacement : float
        Axial displacement z_p [mm] of the load point.
    load : Load
        The load solved for.
    status : Status
    residual_norm : float
        ‖r‖∞ at the returned point.
    iterations : int
        Newton steps, summed over the attempts.
    energy : float
        Π(q) [N·mm].
    restarts : int
        Restarts from zero contact multipliers tried (0 or 1; :attr:`Newton.contact_restart`).
    """

    q: np.ndarray
    multipliers: np.ndarray
    contact_multipliers: np.ndarray
    force: float
    displacement: float
    load: Load
    status: Status
    residual_norm: float
    iterations: int
    energy: float
    z: np.ndarray = field(repr=False)
    data: StateData = field(repr=False, compare=False)
    restarts: int = 0

    @property
    def converged(self) -> bool:
        return self.status is Status.CONVERGED

    @property
    def message(self) -> str:
        text = (
            f"{self.status.message} after {self.iterations} iterations "
            f"(‖r‖∞ = {self.residual_norm:.3e})"
        )
        if self.restarts:
            text += (
                ", restarted from zero contact multipliers"
                if self.converged
                else "; a restart from zero contact multipliers failed too"
            )
        return text


def _start_vector(model: Model, start: Any) -> np.ndarray:
    if isinstance(start, Solution):
        z = np.asarray(start.z, dtype=float)
        if z.shape != (model.n_unknowns,):
            raise ConfigError(
                "start", z.shape, f"a Solution of this model ({model.n_unknowns} unknowns)"
            )
        return z
    arr = np.asarray(start, dtype=float)
    if arr.shape == (model.n_unknowns,):
        z = arr.copy()
    elif arr.shape == (model.n_coordinates,):
        z = model.pack(arr)
    else:
        raise ConfigError(
            "start",
            arr.shape,
            f"q of shape ({model.n_coordinates},), z of shape ({model.n_unknowns},) or a Solution",
        )
    if not np.all(np.isfinite(z)):
        raise ConfigError("start", "non-finite entries", "finite coordinates")
    return z


def make_solution(
    model: Model,
    z: np.ndarray,
    load: Load,
    status: Status,
    rnorm: float,
    it: int,
    data: StateData | None = None,
) -> Solution:
    """Wrap a packed solution vector into a :class:`Solution` (``data``: its
    :class:`StateData` when the solver returned it; else evaluated here)."""
    q, lam, lam_c, mu = model.split(z)
    data = model.state(z, load) if data is None else jax.tree_util.tree_map(np.asarray, data)
    zp = float(data.load_displacement)
    force = -mu if load.is_displacement_controlled else float(load.force)
    return Solution(
        q=q,
        multipliers=lam,
        contact_multipliers=lam_c,
        force=float(force),
        displacement=zp,
        load=load,
        status=status,
        residual_norm=float(rnorm),
        iterations=int(it),
        energy=float(data.energy),
        z=np.asarray(z),
        data=data,
    )


def solve_equilibrium(
    model: Model,
    solver: Newton | None = None,
    start: Any = None,
    load: Load | None = None,
    *,
    throw: bool = False,
) -> Solution:
    """Solve the KKT equilibrium system for one load.

    Parameters
    ----------
    model : Model
    solver : Newton, optional
        Defaults to ``Newton()``.
    start : array_like or Solution, optional
        q (n_q,), a packed z, or a previous Solution (warm start with its multipliers).
        Defaults to q = 0.
    load : Load, optional
        Defaults to zero end force.
    throw : bool
        Raise :class:`~biplan.ConvergenceError` instead of returning a failed Solution.

    Returns
    -------
    Solution
        Check ``solution.status``; a non-converged solution is never marked converged.
    """
    solver = solver or Newton()
    load = load or Load.of_force(0.0)
    if not isinstance(load, Load):
        raise ConfigError("load", load, "a biplan Load (Load.of_force / Load.of_displacement)")
    z0 = _start_vector(model, model.zeros() if start is None else start)
    loop = compiled_loop(model.layout)
    jload = load.for_kernel()
    out, data = loop(model.params, jnp.asarray(z0), jload, solver.settings())
    steps, restarts = int(out.steps), 0
    q0, lam0, lam_c0, mu0 = model.split(z0)
    if solver.contact_restart and int(out.status) != Status.CONVERGED.value and np.any(lam_c0):
        # the start's contact multipliers can be smoothing artefacts (Newton.contact_restart)
        cold = model.pack(q0, lam0, None, mu0)
        retry, retry_data = loop(model.params, jnp.asarray(cold), jload, solver.settings())
        restarts, steps = 1, steps + int(retry.steps)
        if int(retry.status) == Status.CONVERGED.value:
            out, data = retry, retry_data
    status = Status(int(out.status))
    rnorm = float(np.max(np.abs(np.asarray(out.r))))
    # the loop's Jacobian is at its iterate once a pass was accepted (finite merit); a solve
    # whose start was already non-finite has none, and its state is evaluated afresh
    data = data if np.isfinite(float(out.f)) else None
    sol = make_solution(model, np.asarray(out.z), load, status, rnorm, steps, data)
    sol = replace(sol, restarts=restarts) if restarts else sol
    if throw and not sol.converged:
        raise ConvergenceError(f"equilibrium solve for {load}: {sol.message}")
    return sol


def relaxed_reference(
    model: Model, solver: Newton | None = None, *, throw: bool = True
) -> Solution:
    """The relaxed reference configuration q_ref: clamped base only, no load (SI "Numerical
    solver"). Starts from q = 0, which is an equilibrium up to the contact regularisation."""
    return solve_equilibrium(model, solver, model.zeros(), Load.of_force(0.0), throw=throw)
