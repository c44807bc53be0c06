"""Newton strategies built on the core (:mod:`jax_oracle.core`).

* :func:`damped` — the plain damped Newton of the path corrector and the time step;
* :func:`chord` — chord (modified Newton) iterates with a Jacobian factored once (the design
  map's load steps start with its compiled form, :func:`biplan.solvers.batch.chord`);
* :func:`minimum_norm` — the minimum-norm least-squares step of an underdetermined system
  (a Gauss–Newton return to a constraint manifold);
* :func:`residual_norm` — ‖R‖∞ of a finished iteration.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from biplan._compile import linalg
from biplan._compile.setup import jax, jnp
from jax_oracle.core import LoopState, iterate
from jax_oracle.settings import Settings

__all__ = ["DAMPED_BACKTRACKS", "chord", "damped", "minimum_norm", "residual_norm"]

Array = Any


#: Step halvings of :func:`damped` (smallest step fraction 2⁻¹²).
DAMPED_BACKTRACKS = 12


def damped(
    residual: Callable[[Array], Array],
    jacobian: Callable[[Array], Array],
    z0: Array,
    atol: Array,
    max_steps: Array,
    axis_name: str | None = None,
) -> LoopState:
    """The plain damped Newton of the path corrector and the time step:
    :func:`~jax_oracle.core.iterate` with Armijo backtracking (c = 1e-4,
    :data:`DAMPED_BACKTRACKS` halvings), the Jacobian formed at accepted points only
    (``line_search_loop``) and no Levenberg–Marquardt fallback — a step that fails is cut back
    by its driver. Needed at the kinks of the piecewise-linear fold laws and of the contact
    complementarity, where plain Newton can cycle."""
    settings = Settings.of(atol, max_steps, DAMPED_BACKTRACKS, 1e-4, 0)
    return iterate(
        residual,
        jacobian,
        z0,
        settings,
        line_search_loop=True,
        levenberg_marquardt=False,
        axis_name=axis_name,
    )


def residual_norm(state: LoopState) -> Array:
    """‖R‖∞ at the state's iterate (+∞ when no point was accepted: a non-finite start)."""
    return jnp.where(jnp.isfinite(state.f), jnp.max(jnp.abs(state.r)), jnp.inf)


def minimum_norm(jac: Array, b: Array) -> Array:
    """The minimum-norm least-squares x of J x ≈ b (pseudo-inverse; singular values below
    1e-10 of the largest are dropped): the Gauss–Newton step of an underdetermined system."""
    return linalg.pinv(jac, rtol=1e-10) @ b


def chord(
    residual: Callable[[Array], Array], jac: Array, z: Array, atol: Array, iterations: int
) -> Array:
    """Chord (modified Newton) iterates z ← z − J⁻¹ R(z) with the fixed Jacobian ``jac``
    (factored once), until ‖R‖∞ < atol or ``iterations`` steps (static); returns the iterate
    of smallest ‖R‖∞ (z itself when every step made it worse or non-finite). A start for
    :func:`~jax_oracle.core.iterate`: an iterate below ``atol`` is accepted by its first
    pass, which then only evaluates the Jacobian there."""
    lu, piv = linalg.lu_factor(jac)

    def residual_and_norm(zc: Array) -> tuple[Array, Array]:
        r = residual(zc)
        return r, jnp.where(jnp.all(jnp.isfinite(r)), jnp.max(jnp.abs(r)), jnp.inf)

    def cond(c: tuple) -> Array:
        k, _, _, _, best_norm, last_norm = c
        return (k < iterations) & (best_norm >= atol) & jnp.isfinite(last_norm)

    def step(c: tuple) -> tuple:
        k, zc, r, best, best_norm, _ = c
        dz = linalg.lu_solve(lu, piv, -r)
        zn = jnp.where(jnp.all(jnp.isfinite(dz)), zc + dz, zc)
        rn, nn = residual_and_norm(zn)
        take = nn < best_norm
        return k + 1, zn, rn, jnp.where(take, zn, best), jnp.where(take, nn, best_norm), nn

    r0, n0 = residual_and_norm(z)
    init = (jnp.asarray(0), z, r0, z, n0, n0)
    return jax.lax.while_loop(cond, step, init)[3]
