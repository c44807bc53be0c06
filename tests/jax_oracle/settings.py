"""The traced :class:`Settings` of the JAX Newton oracle (:mod:`jax_oracle.core`)."""

from __future__ import annotations

from typing import Any, NamedTuple

from biplan._compile.setup import jnp

__all__ = ["Settings"]

Array = Any


class Settings(NamedTuple):
    """The traced settings of the compiled iteration (float64 scalars;
    :func:`jax_oracle.newton.settings_of` builds them from a Newton).

    Attributes
    ----------
    atol : scalar
        Convergence when ‖R‖∞ < atol (the residual's units).
    max_steps : scalar
        Accepted Newton steps allowed.
    max_backtracks : scalar
        Step halvings of the line search before Levenberg–Marquardt (or failure).
    armijo : scalar
        Sufficient-decrease constant c of the Armijo test.
    free_steps : scalar
        Watchdog length (read only by a machine built with ``free_steps=None``).
    """

    atol: Array
    max_steps: Array
    max_backtracks: Array
    armijo: Array
    free_steps: Array

    @classmethod
    def of(
        cls,
        atol: Any,
        max_steps: Any,
        max_backtracks: Any = 30,
        armijo: Any = 1e-4,
        free_steps: Any = 0,
    ) -> Settings:
        """Settings from numbers or traced scalars (each as a float64 array)."""
        values = (atol, max_steps, max_backtracks, armijo, free_steps)
        return cls(*(jnp.asarray(v, dtype=jnp.float64) for v in values))
