"""Common behaviour of fold laws: elementwise evaluation through their JAX forms
(:mod:`biplan.laws._jax`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from biplan._compile.setup import jax, jnp
from biplan.laws import _jax as K


def _out(result: Any, *inputs: Any) -> Any:
    """Return NumPy for NumPy/Python input and JAX arrays for JAX input (incl. tracers)."""
    if any(isinstance(x, jax.Array) for x in inputs):
        return result
    out = np.asarray(result)
    return out.item() if out.ndim == 0 else out


class LawMixin:
    """Elementwise methods shared by :class:`TrilinearLaw` and :class:`LinearLaw`.

    Subclasses provide :attr:`coefficients` ``(k1, k2, k3, w1, w2)``.
    """

    @property
    def coefficients(self) -> tuple[float, float, float, float, float]:  # pragma: no cover
        raise NotImplementedError

    def _c(self) -> K.Coefficients:
        return tuple(jnp.asarray(v, dtype=jnp.float64) for v in self.coefficients)  # type: ignore[return-value]

    def differential_stiffness(self, w: Any) -> Any:
        """Differential stiffness k_bi(w) [N/mm²] at elongation ``w`` [mm] (main Eq. stiffness).

        (Named so because the constructor field ``stiffness`` holds the coefficients.)
        """
        return _out(K.stiffness(jnp.asarray(w, dtype=jnp.float64), self._c()), w)

    def force(self, w: Any) -> Any:
        """Line force F(w) [N/mm] at elongation ``w`` [mm] (main Eq. field_constitutive_energy)."""
        return _out(K.force(jnp.asarray(w, dtype=jnp.float64), self._c()), w)

    def energy_density(self, w: Any) -> Any:
        """Energy per unit fold length Ψ(w) [N] at elongation ``w`` [mm]."""
        return _out(K.energy_density(jnp.asarray(w, dtype=jnp.float64), self._c()), w)

    def antiderivative(self, w: Any) -> Any:
        """P(w) = ∫_0^w Ψ(ξ) dξ [N·mm]."""
        return _out(K.antiderivative(jnp.asarray(w, dtype=jnp.float64), self._c()), w)

    def field_energy(self, w0: Any, w1: Any, length: Any) -> Any:
        """Exact strain energy ∫_0^L Ψ(w(x)) dx [N·mm] of a field with w linear from w0 to w1.

        Parameters
        ----------
        w0, w1 : array_like
            Boundary elongations [mm] at x = 0 and x = L.
        length : array_like
            Field length L [mm].

        Notes
        -----
        Main Eq. (field_strain_energy) with SI Eq. (17); closed form of MODEL.md §2.
        """
        f = jnp.asarray
        res = K.field_energy(
            f(w0, dtype=float), f(w1, dtype=float), f(length, dtype=float), self._c()
        )
        return _out(res, w0, w1, length)

    def phase_fractions(self, w0: Any, w1: Any) -> Any:
        """Fractions (closed, spinodal, open) of a linear field w0 → w1 on each branch."""
        res = K.phase_fractions(
            jnp.asarray(w0, dtype=float), jnp.asarray(w1, dtype=float), self._c()
        )
        return _out(res, w0, w1)
