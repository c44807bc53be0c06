"""Elementwise JAX functions of the trilinear fold law.

Main Eqs. (stiffness) and (field_constitutive_energy).

Every function takes the local elongation ``w`` [mm] and the law coefficients
``c = (k1, k2, k3, w1, w2)`` (stiffnesses in N/mm², breakpoints in mm); all arguments broadcast,
so the assembly evaluates a whole tube's folds in one call. A linear law is the special case
``k1 = k2 = k3`` (its breakpoints are then irrelevant).

Closed forms (MODEL.md §1), with ``D = w2 - w1``::

    F(w)  = k1 w                | F1 + k2 (w-w1)              | F2 + k3 (w-w2)
    Ψ(w)  = k1 w²/2             | Ψ1 + F1 d1 + k2 d1²/2       | Ψ2 + F2 d2 + k3 d2²/2
    P(w)  = ∫_0^w Ψ             (piecewise cubic, C²)

For ``w < 0`` (reachable only inside the contact regularisation) the branch-1 expressions are
continued: the closed branch is a parabola about ``w = 0``.
"""

from __future__ import annotations

from typing import Any

from biplan._compile.setup import jnp

Array = Any
Coefficients = tuple[Array, Array, Array, Array, Array]

#: Below this elongation difference [mm] a field that straddles a breakpoint is integrated with
#: the midpoint rule (error O(δ³ Δk)); above it the breakpoint split is exact.
SPLIT_TOLERANCE = 1e-6


def _consts(c: Coefficients) -> tuple[Array, ...]:
    k1, k2, _k3, w1, w2 = c
    d = w2 - w1
    f1 = k1 * w1
    f2 = f1 + k2 * d
    psi1 = 0.5 * k1 * w1**2
    psi2 = psi1 + f1 * d + 0.5 * k2 * d**2
    p1 = k1 * w1**3 / 6.0
    p2 = p1 + psi1 * d + 0.5 * f1 * d**2 + k2 * d**3 / 6.0
    return f1, f2, psi1, psi2, p1, p2


def branch(w: Array, c: Coefficients) -> Array:
    """Branch index of ``w``: 0 closed (w < w1), 1 spinodal, 2 open (w ≥ w2)."""
    _, _, _, w1, w2 = c
    return jnp.where(w < w1, 0, jnp.where(w < w2, 1, 2))


def stiffness(w: Array, c: Coefficients) -> Array:
    """Differential stiffness k_bi(w) [N/mm²] (main Eq. stiffness)."""
    k1, k2, k3, w1, w2 = c
    return jnp.where(w < w1, k1, jnp.where(w < w2, k2, k3))


def force(w: Array, c: Coefficients) -> Array:
    """Line force F(w) = ∫_0^w k_bi [N/mm] (main Eq. field_constitutive_energy)."""
    k1, k2, k3, w1, w2 = c
    f1, f2, *_ = _consts(c)
    return jnp.where(w < w1, k1 * w, jnp.where(w < w2, f1 + k2 * (w - w1), f2 + k3 * (w - w2)))


def _psi_on(j: int, w: Array, c: Coefficients, consts: tuple[Array, ...]) -> Array:
    """Ψ on branch ``j`` (its quadratic continued beyond the branch), given ``_consts(c)``."""
    k1, k2, k3, w1, w2 = c
    f1, f2, psi1, psi2, _, _ = consts
    if j == 0:
        return 0.5 * k1 * w**2
    if j == 1:
        d1 = w - w1
        return psi1 + f1 * d1 + 0.5 * k2 * d1**2
    d2 = w - w2
    return psi2 + f2 * d2 + 0.5 * k3 * d2**2


def _psi(w: Array, c: Coefficients, consts: tuple[Array, ...]) -> Array:
    """Ψ(w) on its own branch, given ``_consts(c)``."""
    _, _, _, w1, w2 = c
    p0, p1, p2 = (_psi_on(j, w, c, consts) for j in range(3))
    return jnp.where(w < w1, p0, jnp.where(w < w2, p1, p2))


def energy_density(w: Array, c: Coefficients) -> Array:
    """Energy per unit fold length Ψ(w) = ∫_0^w F [N] (main Eq. field_constitutive_energy)."""
    return _psi(w, c, _consts(c))


def antiderivative(w: Array, c: Coefficients) -> Array:
    """P(w) = ∫_0^w Ψ [N·mm], the C² piecewise cubic used by the exact field energy."""
    k1, k2, k3, w1, w2 = c
    f1, f2, psi1, psi2, p1, p2 = _consts(c)
    d1 = w - w1
    d2 = w - w2
    return jnp.where(
        w < w1,
        k1 * w**3 / 6.0,
        jnp.where(
            w < w2,
            p1 + psi1 * d1 + 0.5 * f1 * d1**2 + k2 * d1**3 / 6.0,
            p2 + psi2 * d2 + 0.5 * f2 * d2**2 + k3 * d2**3 / 6.0,
        ),
    )


def _pieces(w0: Array, wl: Array, c: Coefficients) -> tuple[Array, ...]:
    """Widths and midpoints of the parts of [min(w0,wL), max(w0,wL)] on each branch."""
    _, _, _, w1, w2 = c
    lo = jnp.minimum(w0, wl)
    hi = jnp.maximum(w0, wl)
    b1 = jnp.clip(w1, lo, hi)
    b2 = jnp.clip(w2, lo, hi)
    b1 = jnp.minimum(b1, b2)
    return lo, hi, (b1 - lo, b2 - b1, hi - b2), (0.5 * (lo + b1), 0.5 * (b1 + b2), 0.5 * (b2 + hi))


def field_energy(w0: Array, wl: Array, length: Array, c: Coefficients) -> Array:
    """Exact ∫_0^L Ψ(w(x)) dx [N·mm] for w linear from ``w0`` to ``wl``.

    Main Eq. (field_strain_energy) with SI Eq. (17).

    On each branch Ψ is quadratic, so its mean over a sub-interval of width h centred at m is
    exactly ``Ψ(m) + h² k / 24``. The interval [w0, wL] is split at the breakpoints it contains;
    without a breakpoint inside (or when |wL − w0| < ``SPLIT_TOLERANCE``) the one-piece form is
    used, which is exact, smooth and free of cancellation as wL → w0.
    """
    k1, k2, k3, w1, w2 = c
    consts = _consts(c)  # once: the graph of a kernel that integrates many fields stays small
    lo, hi, widths, mids = _pieces(w0, wl, c)
    d = hi - lo
    straddles = ((w1 > lo) & (w1 < hi)) | ((w2 > lo) & (w2 < hi))
    one_piece = (~straddles) | (d < SPLIT_TOLERANCE)
    m = 0.5 * (w0 + wl)
    psi_m = _psi(m, c, consts)
    whole = psi_m + (wl - w0) ** 2 * stiffness(m, c) / 24.0  # smooth at wl = w0
    ks = (k1, k2, k3)
    total = 0.0
    for j in range(3):
        h = widths[j]
        total = total + h * (_psi_on(j, mids[j], c, consts) + h**2 * ks[j] / 24.0)
    d_safe = jnp.where(one_piece, 1.0, d)
    split = total / d_safe
    return length * jnp.where(one_piece, whole, split)


def phase_fractions(w0: Array, wl: Array, c: Coefficients) -> Array:
    """Fractions of a linear field's length on the closed, spinodal and open branch.

    Returns an array of shape ``(..., 3)`` that sums to one along the last axis.
    """
    lo, hi, widths, _ = _pieces(w0, wl, c)
    d = hi - lo
    tiny = d < 1e-14
    d_safe = jnp.where(tiny, 1.0, d)
    frac = jnp.stack([h / d_safe for h in widths], axis=-1)
    single = jnp.stack(
        [(branch(0.5 * (w0 + wl), c) == j).astype(frac.dtype) for j in range(3)], axis=-1
    )
    return jnp.where(tiny[..., None], single, frac)
