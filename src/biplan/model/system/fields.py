"""Fold-field energies of the compiled element kernels (Numba; MODEL §1–2).

* :func:`field_energy` — main Eq. (field_strain_energy): ∫_0^L Ψ(w(x)) dx for w linear from
  w0 to wL, with its gradient and Hessian in (w0, wL), integrated exactly piece by piece
  between the law's breakpoints (Simpson's rule is exact on each piece: Ψ is quadratic, F
  linear and k constant there; MODEL §2), checked against the JAX law integral
  (``tests/test_system_oracle.py``);
* :func:`law_of`, :func:`branch`, :func:`on_branch` — a law row of the tables and its
  piecewise-quadratic energy (MODEL §1).
"""

from __future__ import annotations

import numpy as np

from biplan._compile.numba_cache import inlined_kernel, kernel

__all__ = ["SPLIT_TOLERANCE", "Law", "branch", "field_energy", "law_of", "on_branch"]

#: A law row (k1, k2, k3, w1, w2): an array, or a tuple in the kernels (:func:`law_of`).
Law = np.ndarray | tuple[float, float, float, float, float]

#: Below this elongation difference [mm] a field that straddles a breakpoint is integrated on
#: the branch of its midpoint (as :data:`biplan.laws._jax.SPLIT_TOLERANCE`).
SPLIT_TOLERANCE = 1e-6


@inlined_kernel
def law_of(table: np.ndarray, i: int) -> tuple[float, float, float, float, float]:
    """Row i of a law table (``helical``, ``circular``): (k1, k2, k3, w1, w2), no view."""
    return table[i, 0], table[i, 1], table[i, 2], table[i, 3], table[i, 4]


@inlined_kernel
def branch(w: float, law: Law) -> int:
    """0 closed (w < w1), 1 spinodal, 2 open (w ≥ w2) for law = (k1, k2, k3, w1, w2)."""
    if w < law[3]:
        return 0
    if w < law[4]:
        return 1
    return 2


@inlined_kernel
def on_branch(j: int, w: float, law: Law) -> tuple[float, float, float]:
    """(Ψ [N], F [N/mm], k [N/mm²]) of branch j's quadratic at w (MODEL §1)."""
    k1, k2, k3, w1, w2 = law[0], law[1], law[2], law[3], law[4]
    f1 = k1 * w1
    psi1 = 0.5 * k1 * w1 * w1
    if j == 0:
        return 0.5 * k1 * w * w, k1 * w, k1
    d1 = w - w1
    if j == 1:
        return psi1 + f1 * d1 + 0.5 * k2 * d1 * d1, f1 + k2 * d1, k2
    d = w2 - w1
    f2 = f1 + k2 * d
    psi2 = psi1 + f1 * d + 0.5 * k2 * d * d
    d2 = w - w2
    return psi2 + f2 * d2 + 0.5 * k3 * d2 * d2, f2 + k3 * d2, k3


@inlined_kernel
def _piece(t0: float, t1: float, w0: float, dw: float, law: Law) -> tuple:
    """The integrals of :func:`field_energy` over t ∈ [t0, t1] (per unit length), by Simpson's
    rule on the branch of the piece's midpoint (exact: one quadratic branch)."""
    j = branch(w0 + 0.5 * (t0 + t1) * dw, law)
    h = (t1 - t0) / 6.0
    e = ea = eb = eaa = eab = ebb = 0.0
    for t, wt in ((t0, h), (0.5 * (t0 + t1), 4.0 * h), (t1, h)):
        psi, f, k = on_branch(j, w0 + t * dw, law)
        e += wt * psi
        ea += wt * (1.0 - t) * f
        eb += wt * t * f
        eaa += wt * (1.0 - t) * (1.0 - t) * k
        eab += wt * t * (1.0 - t) * k
        ebb += wt * t * t * k
    return e, ea, eb, eaa, eab, ebb


@kernel(forceinline=True, error_model="numpy")
def field_energy(w0: float, wl: float, length: float, law: Law) -> tuple:
    """(E, E_a, E_b, E_aa, E_ab, E_bb): the field energy [N·mm] of a linear field from
    a = w0 to b = wL over ``length`` [mm] and its derivatives in (a, b).

    E = L ∫_0^1 Ψ(a + t (b − a)) dt, E_a = L ∫ (1 − t) F, E_b = L ∫ t F, E_aa = L ∫ (1 − t)² k,
    E_ab = L ∫ t (1 − t) k, E_bb = L ∫ t² k, split at the breakpoints inside (a, b).
    """
    lo = min(w0, wl)
    hi = max(w0, wl)
    w1, w2 = law[3], law[4]
    straddles = (lo < w1 < hi) or (lo < w2 < hi)
    dw = wl - w0
    if (not straddles) or hi - lo < SPLIT_TOLERANCE:
        m = 0.5 * (w0 + wl)
        psi, f, k = on_branch(branch(m, law), m, law)
        return (
            length * (psi + dw * dw * k / 24.0),
            length * (0.5 * f - dw * k / 12.0),
            length * (0.5 * f + dw * k / 12.0),
            length * k / 3.0,
            length * k / 6.0,
            length * k / 3.0,
        )
    # the breakpoints inside (a, b) as fractions of the field, in order (2.0: none)
    ta = (w1 - w0) / dw if lo < w1 < hi else 2.0
    tb = (w2 - w0) / dw if lo < w2 < hi else 2.0
    if ta > tb:
        ta, tb = tb, ta
    e = ea = eb = eaa = eab = ebb = 0.0
    t0 = 0.0
    for t1 in (ta, tb, 1.0):
        if t1 > 1.0:
            continue
        p = _piece(t0, t1, w0, dw, law)
        e += p[0]
        ea += p[1]
        eb += p[2]
        eaa += p[3]
        eab += p[4]
        ebb += p[5]
        t0 = t1
    return length * e, length * ea, length * eb, length * eaa, length * eab, length * ebb
