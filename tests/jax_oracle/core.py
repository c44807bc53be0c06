"""The JAX globalised Newton, kept as the oracle of the compiled one
(:func:`biplan.solvers.iteration.newton`, MODEL §11).

:func:`machine` is a Newton iteration on a square system R(z) = 0 given as two functions,
``residual(z)`` and ``jacobian(z)``: Armijo backtracking on the merit ½‖R‖², a
Levenberg–Marquardt fallback with adaptive damping, and the watchdog of free steps, chosen by
static options; the tolerances and limits are traced (:class:`jax_oracle.settings.Settings`).
:func:`iterate` runs the whole solve as one ``lax.while_loop``; :mod:`jax_oracle.strategies`
builds the damped Newton and the chord start on it. The tests compare the compiled loops with
it on the KKT system (:mod:`jax_oracle.newton`), the deflated system
(:mod:`jax_oracle.deflation`) and the NEB return to the constraints (:mod:`jax_oracle.neb`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from biplan._compile import linalg
from biplan._compile.setup import jax, jnp
from biplan.solvers.status import Status
from jax_oracle.settings import Settings

__all__ = ["LoopState", "iterate", "machine"]

Array = Any


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


def machine(
    residual: Callable[[Array], Array],
    jacobian: Callable[[Array], Array],
    settings: Settings,
    *,
    line_search_loop: bool = False,
    free_steps: int | None = 0,
    levenberg_marquardt: bool = True,
    converged: Callable[[Array, Array], Array] | None = None,
    solve: Callable[[Array, Array], Array] | None = None,
    n_equations: int | None = None,
    axis_name: str | None = None,
) -> tuple:
    """(init, body, running, finish) of the globalised Newton iteration on R(z) = 0.

    ``residual(z)`` and ``jacobian(z)`` are traced once each. ``init(z0)`` is the state before
    the first step, ``body(state)`` one step, ``running(state)`` whether another step is due
    and ``finish(state)`` sets the final status. :func:`iterate` drives them with
    ``lax.while_loop``.

    Newton steps with Armijo backtracking on ½‖R‖² that fall back, once α is exhausted, to
    Levenberg–Marquardt steps with growing damping (solved with the Jacobian of the current
    iterate). The start z0 enters as the first trial point (merit +∞, accepted when finite),
    so that the residual and the Jacobian each have one site in the compiled graph. Two
    equivalent drivers of the search (static ``line_search_loop``):

    * ``False`` (default): ``body`` is one pass — one trial point, its residual and its
      Jacobian (used only if the trial is accepted), with a single residual and a single
      Jacobian site and one merged LM solve: the smallest graph and the cheapest pass when
      nearly every trial is accepted (load stepping, the design map);
    * ``True``: ``body`` is a line search on residuals alone (an inner ``while_loop`` over
      trial points) followed by one Jacobian at the accepted point. Under ``vmap`` a lane
      that has accepted waits (cheap: residuals and solves) while the others backtrack, so a
      batch evaluates one Jacobian per accepted step instead of one per trial point: faster
      when many trials are rejected (multi-start searches from far-off seeds, the path
      corrector and the time step).

    Both visit the same trial points (results equal to rounding; a solve that grinds through
    hundreds of LM trials can end differently). ``free_steps`` (static) is the watchdog of
    :class:`~biplan.solvers.Newton`; with 0 its state fields are carried but never computed.
    With None the watchdog is compiled in and its length is traced (``settings.free_steps``):
    one kernel serves every watchdog length, and a length of 0 takes the same iterates as the
    static 0 (the bookkeeping runs, but never accepts a step nor reverts).

    ``levenberg_marquardt`` (static): with False, a search that exhausts its
    ``max_backtracks`` halvings (or meets a singular Newton system) ends the solve with
    ``Status.LINE_SEARCH_FAILED`` instead of switching to Levenberg–Marquardt steps: the
    plain damped Newton of the path corrector and the time step, where a failed step is cut
    back by the driver instead.

    ``converged(z, R)`` (static): the convergence test at an accepted point; default
    ‖R‖∞ < ``settings.atol``. The deflated system converges on its *undeflated* residual
    (:mod:`biplan.analysis.states.deflation`).

    ``solve(J, b)`` (static): the Newton direction's linear solve, default LU. With the
    minimum-norm least-squares solve (:func:`~jax_oracle.strategies.minimum_norm`) the
    system may be rectangular (fewer equations than unknowns: a Gauss–Newton return to a
    constraint manifold); then
    ``n_equations`` (static) is the length of R (default: the number of unknowns — given,
    not traced, so that the residual is traced only once).

    ``axis_name`` (static): the name of an enclosing ``vmap`` axis (``jax.vmap(...,
    axis_name=...)``). The Levenberg–Marquardt direction (a normal-equations solve, ≈ 1/4 of
    a pass) is then computed only when some lane of the batch needs it (``lax.cond`` on a
    ``psum`` over the axis); without it, ``vmap`` turns that ``cond`` into a select and every
    lane pays for it on every pass. Unbatched, the ``cond`` skips it per solve. Same results
    either way (a skipped direction is never selected).
    """
    atol, max_steps, max_bt, c_arm = (
        settings.atol,
        settings.max_steps,
        settings.max_backtracks,
        settings.armijo,
    )
    watchdog = free_steps is None or free_steps > 0
    free0 = (
        jnp.asarray(settings.free_steps).astype(jnp.asarray(0).dtype)
        if free_steps is None
        else free_steps
    )
    alpha_min = 0.5**max_bt
    # max_steps = 0 evaluates R and its Jacobian at z0 only (one trial, the start)
    max_evals = jnp.maximum(max_steps, 1) * (max_bt + 1)

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
        computed only if some lane of the ``axis_name`` batch needs it; NaN (a failed
        search) when Levenberg–Marquardt is off."""
        n = jac.shape[1]
        if not levenberg_marquardt:
            return jnp.full(n, jnp.nan, r.dtype)
        return jax.lax.cond(
            any_lane(need), lambda: lm_direction(jac, r, damping), lambda: jnp.zeros(n, r.dtype)
        )

    direction = linalg.solve if solve is None else solve

    def done(z: Array, r: Array) -> Array:
        if converged is not None:
            return converged(z, r)
        return jnp.max(jnp.abs(r)) < atol

    def search_failed(to_lm: Array, damping: Array) -> Array:
        """A rejected trial ends the search: LM damping past 1e12, or the halvings spent
        when there is no Levenberg–Marquardt."""
        return (damping > 1e12) | (to_lm if not levenberg_marquardt else False)

    def stuck(newton_ok: Array) -> Array:
        """A singular Newton system ends the solve when there is no Levenberg–Marquardt."""
        return ~newton_ok if not levenberg_marquardt else jnp.asarray(False)

    def evaluate(s: LoopState) -> tuple:
        """The trial point z + α dz, its residual and merit, and whether it is accepted
        (Armijo on ½‖r‖², plain decrease in LM mode, anything finite at the start)."""
        zt = s.z + s.alpha * s.dz
        rt = residual(zt)
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
        failed = search_failed(to_lm, damping_r)
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
        jt = jacobian(zt)
        dz_n = direction(jt, -rt)
        newton_ok = jnp.all(jnp.isfinite(dz_n))
        # singular Newton system: a Levenberg–Marquardt step instead
        dz_a = jnp.where(newton_ok, dz_n, lm_if(s.pending & ~newton_ok, jt, rt, s.damping))
        steps = s.steps + jnp.where(jnp.isfinite(s.f), 1, 0)
        status = jnp.where(
            done(zt, rt),
            Status.CONVERGED.value,
            jnp.where(
                stuck(newton_ok),
                Status.LINE_SEARCH_FAILED.value,
                jnp.where(steps >= max_steps, Status.MAX_STEPS.value, -1),
            ),
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
        jt = jacobian(zt)

        # accepted: new iterate and Newton direction
        dz_n = direction(jt, -rt)
        newton_ok = jnp.all(jnp.isfinite(dz_n))
        converged = done(zt, rt)

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
        failed = jnp.where(
            accept,
            stuck(newton_ok),
            search_failed(to_lm, damping_r),
        )
        status = jnp.where(
            accept & converged,
            Status.CONVERGED.value,
            jnp.where(
                failed,
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
        m = n if n_equations is None else n_equations
        return LoopState(
            z=z0,
            r=jnp.zeros(m),
            f=jnp.asarray(jnp.inf),
            jac=jnp.eye(m, n),
            dz=jnp.zeros(n),
            slope=jnp.asarray(0.0),
            alpha=jnp.asarray(0.0),
            lm=jnp.asarray(False),
            damping=jnp.asarray(1e-3),
            steps=jnp.asarray(0),
            evals=jnp.asarray(0),
            status=jnp.asarray(-1),
            pending=jnp.asarray(False),
            r_trial=jnp.zeros(m),
            f_trial=jnp.asarray(jnp.inf),
            free=jnp.asarray(free0),
            best_z=z0,
            best_r=jnp.zeros(m),
            best_f=jnp.asarray(jnp.inf),
            best_jac=jnp.eye(m, n),
            best_dz=jnp.zeros(n),
            best_lm=jnp.asarray(False),
        )

    def finish(out: LoopState) -> LoopState:
        status = jnp.where(out.status < 0, Status.MAX_STEPS.value, out.status)
        status = jnp.where(jnp.isfinite(out.f), status, Status.NONFINITE.value)
        return out._replace(status=status)

    return init, body, cond, finish


def iterate(
    residual: Callable[[Array], Array],
    jacobian: Callable[[Array], Array],
    z0: Array,
    settings: Settings,
    **options: Any,
) -> LoopState:
    """Solve R(z) = 0 from z0 by :func:`machine` in one ``lax.while_loop`` (pure; jit- and
    vmap-able). ``options``: the static options of :func:`machine`. The returned state's
    ``jac`` is the Jacobian at ``z`` once a pass was accepted (finite ``f``)."""
    init, body, cond, finish = machine(residual, jacobian, settings, **options)
    return finish(jax.lax.while_loop(cond, body, init(z0)))
