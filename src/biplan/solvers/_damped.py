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
) -> NewtonOut:
    """Solve R(x) = 0 from x0 to ‖R‖∞ < atol within ``max_iterations`` Newton steps."""

    def direction(x: Array, r: Array) -> tuple[Array, Array]:
        jac = jacobian(x)
        d = linalg.solve(jac, -r)
        return jnp.where(jnp.isfinite(d), d, 0.0), jac

    r0 = residual(x0)
    d0, j0 = direction(x0, r0)
    f0 = 0.5 * r0 @ r0
    flag0 = jnp.where(jnp.max(jnp.abs(r0)) < atol, 1, jnp.where(jnp.isfinite(f0), -1, 0))

    def body(s: tuple) -> tuple:
        x, r, f, d, alpha, it, _flag, jac = s
        xt = x + alpha * d
        rt = residual(xt)
        ft = 0.5 * rt @ rt
        accept = jnp.isfinite(ft) & (ft <= (1.0 - 2e-4 * alpha) * f)
        d_new, jac_new = jax.lax.cond(accept, lambda: direction(xt, rt), lambda: (d, jac))
        it_new = it + accept.astype(it.dtype)
        converged = accept & (jnp.max(jnp.abs(rt)) < atol)
        alpha_new = jnp.where(accept, 1.0, 0.5 * alpha)
        failed = (alpha_new < MIN_ALPHA) | ((it_new >= max_iterations) & ~converged)
        flag = jnp.where(converged, 1, jnp.where(failed, 0, -1))
        return (
            jnp.where(accept, xt, x),
            jnp.where(accept, rt, r),
            jnp.where(accept, ft, f),
            d_new,
            alpha_new,
            it_new,
            flag,
            jac_new,
        )

    init = (x0, r0, f0, d0, jnp.asarray(1.0), jnp.asarray(0), flag0, j0)
    x, r, _f, _d, _a, it, flag, jac = jax.lax.while_loop(lambda s: s[6] < 0, body, init)
    return NewtonOut(x, flag == 1, it, jnp.max(jnp.abs(r)), jac)
