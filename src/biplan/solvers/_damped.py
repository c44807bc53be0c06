"""A compact damped Newton iteration for jitted inner loops (path corrector, time steps).

Newton directions with Armijo backtracking on the merit ½‖R‖²; the Jacobian is evaluated only
at accepted points (``lax.cond``), so a rejected trial costs one residual. Needed at the kinks
of the piecewise-linear fold laws and of the contact complementarity, where plain Newton can
cycle. Pure and ``vmap``-able.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

from biplan import _linalg as linalg
from biplan._jax import jax, jnp

Array = Any

#: Smallest step fraction of the backtracking line search.
MIN_ALPHA = 2.0**-12


class NewtonOut(NamedTuple):
    x: Array
    converged: Array
    iterations: Array  # accepted Newton steps
    residual: Array  # ‖R‖∞ at x
    jacobian: Array  # at x (the last accepted point)


def damped_newton(
    residual: Callable[[Array], Array],
    jacobian: Callable[[Array], Array],
    x0: Array,
    atol: Array,
    max_iterations: Array,
    axis_name: str | None = None,
) -> NewtonOut:
    """Solve R(x) = 0 from x0 to ‖R‖∞ < atol within ``max_iterations`` Newton steps.

    ``residual`` and ``jacobian`` are each traced once, inside the loop: x0 enters as the first
    trial point (direction 0, merit +∞), and the Jacobian and Newton direction of an accepted
    point are formed at the start of the next pass — also after the last acceptance, so that
    ``NewtonOut.jacobian`` is the Jacobian at ``x``. Tracing them a second time for the start
    (as an initial ``direction(x0)`` outside the loop would) doubles the largest part of the
    compiled kernel: the time-step and path-corrector Jacobians (docs/performance.md).

    ``axis_name`` (static): the name of an enclosing ``vmap`` axis. The Jacobian is then
    formed only on passes where some lane of the batch has accepted a point (``lax.cond`` on a
    ``psum``); without it ``vmap`` turns the ``cond`` into a select and every lane pays for a
    Jacobian on every backtracking pass. Same iterates either way (to rounding).
    """

    def direction(x: Array, r: Array) -> tuple[Array, Array]:
        jac = jacobian(x)
        d = linalg.solve(jac, -r)
        return jnp.where(jnp.isfinite(d), d, 0.0), jac

    def body(s: tuple) -> tuple:
        x, r, f, d, alpha, it, flag, jac, fresh = s
        need = fresh
        if axis_name is not None:
            need = jax.lax.psum(fresh.astype(jnp.int32), axis_name) > 0
        d_new, jac_new = jax.lax.cond(need, lambda: direction(x, r), lambda: (d, jac))
        d = jnp.where(fresh, d_new, d)
        jac = jnp.where(fresh, jac_new, jac)
        running = flag < 0
        xt = x + alpha * d
        rt = residual(xt)
        ft = 0.5 * rt @ rt
        accept = running & jnp.isfinite(ft) & (ft <= (1.0 - 2e-4 * alpha) * f)
        it_new = it + (accept & jnp.isfinite(f)).astype(it.dtype)  # x0 is not a step
        converged = accept & (jnp.max(jnp.abs(rt)) < atol)
        alpha_new = jnp.where(accept, 1.0, 0.5 * alpha)
        failed = (
            (~accept & ~jnp.isfinite(f))  # x0 itself not finite
            | (alpha_new < MIN_ALPHA)
            | ((it_new >= max_iterations) & ~converged)
        )
        flag_new = jnp.where(running, jnp.where(converged, 1, jnp.where(failed, 0, -1)), flag)
        return (
            jnp.where(accept, xt, x),
            jnp.where(accept, rt, r),
            jnp.where(accept, ft, f),
            d,
            alpha_new,
            it_new,
            flag_new,
            jac,
            accept,
        )

    n = x0.shape[0]
    init = (
        x0,
        jnp.full_like(x0, jnp.inf),
        jnp.asarray(jnp.inf, x0.dtype),
        jnp.zeros_like(x0),
        jnp.asarray(1.0, x0.dtype),
        jnp.asarray(0),
        jnp.asarray(-1),
        jnp.zeros((n, n), x0.dtype),
        jnp.asarray(False),
    )
    x, r, _f, _d, _a, it, flag, jac, _fresh = jax.lax.while_loop(
        lambda s: (s[6] < 0) | s[8], body, init
    )
    return NewtonOut(x, flag == 1, it, jnp.max(jnp.abs(r)), jac)
