"""Compiled element formulas with their exact first and second derivatives (Numba).

Written by hand from the element energies, each checked against the JAX autodiff oracle
(``tests/test_system_oracle.py``):

* :func:`field_energy` — main Eq. (field_strain_energy): ∫_0^L Ψ(w(x)) dx for w linear from
  w0 to wL, with its gradient and Hessian in (w0, wL), integrated exactly piece by piece
  between the law's breakpoints (Simpson's rule is exact on each piece: Ψ is quadratic, F
  linear and k constant there; MODEL §2);
* :func:`line_height` — the axial position of a rotated element edge at fixed s (MODEL §7),
  with its derivatives in the element angle;
* :func:`module_rows` — the guides (SI Eq. 11) and helical boundary elongations (SI Eq.
  bound) of one module in its coordinates x = (u, φ1, φ2);
* :func:`connector_points` — the elongation of a connector at its field ends (SI Eq. VC_w)
  in its 7 coordinates x_c = (x_lower, x_upper, γ).

The kinematic quantities are affine in u and γ and each angle enters one rigid element, so
their Hessians are diagonal (entries at the angles): they are returned as diagonals.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["connector_points", "field_energy", "line_height", "module_rows"]

#: Below this elongation difference [mm] a field that straddles a breakpoint is integrated on
#: the branch of its midpoint (as :data:`biplan.laws._kernels.SPLIT_TOLERANCE`).
SPLIT_TOLERANCE = 1e-6


@njit(cache=True)
def branch(w: float, law: np.ndarray) -> int:
    """0 closed (w < w1), 1 spinodal, 2 open (w ≥ w2) for law = (k1, k2, k3, w1, w2)."""
    if w < law[3]:
        return 0
    if w < law[4]:
        return 1
    return 2


@njit(cache=True)
def on_branch(j: int, w: float, law: np.ndarray) -> tuple[float, float, float]:
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


@njit(cache=True)
def field_energy(w0: float, wl: float, length: float, law: np.ndarray) -> tuple:
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
    cuts = np.empty(4)
    cuts[0] = 0.0
    n = 1
    for wb in (w1, w2):
        if lo < wb < hi:
            cuts[n] = (wb - w0) / dw
            n += 1
    cuts[n] = 1.0
    if n == 3 and cuts[1] > cuts[2]:
        cuts[1], cuts[2] = cuts[2], cuts[1]
    e = ea = eb = eaa = eab = ebb = 0.0
    for p in range(n):
        t0, t1 = cuts[p], cuts[p + 1]
        j = branch(w0 + 0.5 * (t0 + t1) * dw, law)
        h = (t1 - t0) / 6.0
        for t, wt in ((t0, h), (0.5 * (t0 + t1), 4.0 * h), (t1, h)):
            psi, f, k = on_branch(j, w0 + t * dw, law)
            e += wt * psi
            ea += wt * (1.0 - t) * f
            eb += wt * t * f
            eaa += wt * (1.0 - t) * (1.0 - t) * k
            eab += wt * t * (1.0 - t) * k
            ebb += wt * t * t * k
    return length * e, length * ea, length * eb, length * eaa, length * eab, length * ebb


@njit(cache=True)
def line_height(
    u: float, phi: float, pz: float, ps: float, z_edge: float, s: float
) -> tuple[float, float, float]:
    """(h, ∂h/∂φ, ∂²h/∂φ²): z [mm] at circumferential position s of the element edge line
    z = z_edge rotated by φ about the pivot (pz, ps) and translated by u (∂h/∂u = 1;
    :func:`biplan.geometry.chain.line_height`)."""
    c, sn = math.cos(phi), math.sin(phi)
    tn = sn / c
    sec2 = 1.0 / (c * c)
    dz, ds = z_edge - pz, -ps
    p_z = c * dz - sn * ds + pz + u
    p_s = sn * dz + c * ds + ps
    dpz, d2pz = -sn * dz - c * ds, -c * dz + sn * ds
    dps, d2ps = c * dz - sn * ds, -sn * dz - c * ds
    r = s - p_s
    h = p_z - r * tn
    h1 = dpz + dps * tn - r * sec2
    h2 = d2pz + d2ps * tn + 2.0 * dps * sec2 - 2.0 * r * sec2 * tn
    return h, h1, h2


@njit(cache=True)
def node(x: np.ndarray, ref: np.ndarray, i: int, element: int) -> tuple:
    """(z, s, ∂z/∂φ, ∂s/∂φ, ∂²z/∂φ², ∂²s/∂φ²) of node i of a module (MODEL §4, SI Eq. 10):
    r = R(φ_e)(r0 − P_e) + P_e + [u, 0], φ_e = x[1 + element]."""
    pivot = 0 if element == 0 else 6
    phi = x[1 + element]
    c, sn = math.cos(phi), math.sin(phi)
    dz = ref[i, 0] - ref[pivot, 0]
    ds = ref[i, 1] - ref[pivot, 1]
    rz, rs = c * dz - sn * ds, sn * dz + c * ds
    return (
        rz + ref[pivot, 0] + x[0],
        rs + ref[pivot, 1],
        -sn * dz - c * ds,
        c * dz - sn * ds,
        -rz,
        -rs,
    )


#: (node, element, coefficient, direction 0 = n_c | 1 = n_sp) of the four module rows
#: g_C = (r_C − r0_C)·n_c, g_F = (r_F − r0_F)·n_c, w0 = (r_E − r_D)·n_sp, wa = (r_F − r_C)·n_sp.
_ROWS = (
    ((2, 0, 1.0), (2, 0, 0.0)),
    ((5, 1, 1.0), (5, 1, 0.0)),
    ((4, 1, 1.0), (3, 0, -1.0)),
    ((5, 1, 1.0), (2, 0, -1.0)),
)


@njit(cache=True)
def module_rows(
    x: np.ndarray, ref: np.ndarray, n_c: np.ndarray, n_sp: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(values (4,), gradients (4, 3), Hessian diagonals (4, 3)) of (g_C, g_F, w0, wa) [mm]
    of one module in x = (u, φ1, φ2) (SI Eqs. 11 and bound, MODEL K2)."""
    vals = np.zeros(4)
    grad = np.zeros((4, 3))
    hdiag = np.zeros((4, 3))
    for row in range(4):
        v = n_c if row < 2 else n_sp
        for term in range(2):
            i, e, coef = _ROWS[row][term]
            if coef == 0.0:
                continue
            z, s, dz, ds, d2z, d2s = node(x, ref, i, e)
            vals[row] += coef * (z * v[0] + s * v[1])
            grad[row, 0] += coef * v[0]
            grad[row, 1 + e] += coef * (dz * v[0] + ds * v[1])
            hdiag[row, 1 + e] += coef * (d2z * v[0] + d2s * v[1])
        if row < 2:  # guides measure from the reference node
            i = _ROWS[row][0][0]
            vals[row] -= ref[i, 0] * v[0] + ref[i, 1] * v[1]
    return vals, grad, hdiag


@njit(cache=True)
def _edge(
    x: np.ndarray, ref: np.ndarray, offset: int, element: int, z_edge: float, s: float
) -> tuple[float, float, float]:
    """:func:`line_height` of element ``element`` of the module whose coordinates are
    x[offset : offset + 3]."""
    pivot = 0 if element == 0 else 6
    return line_height(x[offset], x[offset + 1 + element], ref[pivot, 0], ref[pivot, 1], z_edge, s)


@njit(cache=True)
def connector_points(
    x: np.ndarray,
    ref_lower: np.ndarray,
    ref_upper: np.ndarray,
    pitch: float,
    first: int,
    last: int,
    point_s: np.ndarray,
    upper_element: np.ndarray,
    lower_element: np.ndarray,
    rigid: np.ndarray,
    height: np.ndarray,
    flip: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(w (P,), ∂w/∂x_c (P, 7), diagonal of ∂²w/∂x_c² (P, 7)) at the connector's points
    ``first`` … ``last − 1`` (the first is the seam; MODEL §7)::

        w(s) = z_U(s) + Δ − z_L(s),   Δ = γ + z_L(0) − z_U(0)

    and 2γ − w at the points marked by ``flip`` (``TpcSign.AS_PRINTED``).
    """
    n = last - first
    w = np.zeros(n)
    grad = np.zeros((n, 7))
    hdiag = np.zeros((n, 7))
    for k in range(n):
        for side, p in ((1.0, first + k), (-1.0, first)):
            # + z_U(s_k) − z_L(s_k), then − z_U(0) + z_L(0)
            eu = upper_element[p]
            h, h1, h2 = _edge(x, ref_upper, 3, eu, 0.0, point_s[p])
            w[k] += side * h
            grad[k, 3] += side
            grad[k, 4 + eu] += side * h1
            hdiag[k, 4 + eu] += side * h2
            if rigid[p]:
                w[k] -= side * height[p]
            else:
                el = lower_element[p]
                h, h1, h2 = _edge(x, ref_lower, 0, el, pitch, point_s[p])
                w[k] -= side * h
                grad[k, 0] -= side
                grad[k, 1 + el] -= side * h1
                hdiag[k, 1 + el] -= side * h2
        w[k] += x[6]
        grad[k, 6] += 1.0
        if flip[first + k]:
            w[k] = 2.0 * x[6] - w[k]
            for j in range(7):
                grad[k, j] = -grad[k, j]
                hdiag[k, j] = -hdiag[k, j]
            grad[k, 6] += 2.0
    return w, grad, hdiag
