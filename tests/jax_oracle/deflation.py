"""The JAX deflated Newton, kept as the oracle of the compiled one
(:func:`biplan.solvers.deflated_loop.deflated_newton`): the deflated system M(q) r(z) = 0 at
zero end load with its Jacobian by autodiff of the small operator, and Newton on it
(:func:`jax_oracle.core.iterate`), one kernel per layout and bucket of known roots.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from biplan._compile.setup import jax, jnp
from biplan._compile.traced import traced
from biplan.geometry.layout import TubeLayout
from biplan.model.assembly import Load, autodiff_functions
from biplan.solvers import deflated_loop as compiled_loop
from jax_oracle.core import iterate
from jax_oracle.settings import Settings

__all__ = ["deflated_loop", "deflated_system", "padded"]

Array = Any

#: Coordinates beyond this [mm or rad] end a deflated run (an iterate pushed off to infinity).
ESCAPE = compiled_loop.ESCAPE
#: Known states are padded to multiples of this (a kernel per bucket, not per count).
ROOT_BUCKET = 64


def deflated_system(
    layout: TubeLayout, p: Any, roots: Array, mask: Array, power: Array, shift: Array
) -> tuple[Callable[[Array], Array], Callable[[Array], Array], Callable[[Array], Array]]:
    """(residual, jacobian, η) of the deflated system M(q) r(z) = 0 at zero end load.

    ``roots`` (R, n_q) are the known states where ``mask`` is True (the others padding);
    η(q) = log M(q). The Jacobian is M J + r ∇Mᵀ (∇M = M ∇η by autodiff of the small
    operator), whose Newton step is the Sherman–Morrison step d / (1 − ∇η · d_q) of the module
    docstring. A point with a coordinate beyond :data:`ESCAPE` has a NaN residual (a trial
    point there is rejected).
    """
    k = autodiff_functions(layout)
    zero = jnp.asarray(0.0)
    load = Load(zero, zero, zero)
    nq = layout.n_coordinates

    def log_m(q: Array) -> Array:
        d = q[None, :] - roots
        r2 = jnp.maximum(jnp.sum(d * d, axis=1), 1e-300)
        return jnp.sum(jnp.where(mask, jnp.log(r2 ** (-0.5 * power) + shift), 0.0))

    def deflated(z: Array) -> Array:
        out = jnp.exp(log_m(z[:nq])) * k.residual(p, z, load)
        return jnp.where(jnp.max(jnp.abs(z[:nq])) > ESCAPE, jnp.nan, out)

    def jacobian(z: Array) -> Array:
        eta, grad = jax.value_and_grad(log_m)(z[:nq])
        m = jnp.exp(eta)
        r = k.residual(p, z, load)
        g = jnp.zeros(z.shape[0]).at[:nq].set(grad)
        return m * k.jacobian(p, z, load) + m * r[:, None] * g[None, :]

    return deflated, jacobian, log_m


@traced("deflated_newton")
def deflated_loop(
    layout: TubeLayout,
    p: Any,
    z0: Array,
    roots: Array,
    mask: Array,
    power: Array,
    shift: Array,
    settings: Settings,
) -> tuple[Array, Array, Array]:
    """Newton (:func:`jax_oracle.core.iterate`) on the deflated system
    (:func:`deflated_system`) from z0 (pure; jit-able). Converged when the *undeflated*
    residual ‖M⁻¹ R‖∞ is below ``settings.atol``. Returns (z, status, ‖r‖∞ undeflated)."""
    deflated, jacobian, log_m = deflated_system(layout, p, roots, mask, power, shift)
    nq = layout.n_coordinates

    def undeflated_converged(z: Array, r_deflated: Array) -> Array:
        return jnp.max(jnp.abs(r_deflated)) < settings.atol * jnp.exp(log_m(z[:nq]))

    out = iterate(deflated, jacobian, z0, settings, converged=undeflated_converged)
    zero = jnp.asarray(0.0)
    r = autodiff_functions(layout).residual(p, out.z, Load(zero, zero, zero))
    return out.z, out.status, jnp.max(jnp.abs(r))


def padded(roots: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The roots padded to the next multiple of :data:`ROOT_BUCKET` rows, and their mask (the
    arguments of the JAX kernel :func:`deflated_loop`)."""
    size = ROOT_BUCKET * (len(roots) // ROOT_BUCKET + 1)
    out = np.zeros((size, roots[0].shape[0]))
    out[: len(roots)] = roots
    return out, np.arange(size) < len(roots)
