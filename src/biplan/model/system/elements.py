"""Compiled element formulas with their exact first and second derivatives (Numba).

Written by hand from the element energies, each checked against the JAX autodiff oracle
(``tests/test_system_oracle.py``):

* :func:`line_height` — the axial position of a rotated element edge at fixed s (MODEL §7),
  with its derivatives in the element angle;
* :func:`module_rows` — the guides (SI Eq. 11) and helical boundary elongations (SI Eq.
  bound) of one module in its coordinates x = (u, φ1, φ2);
* :func:`connector_points` — the elongation of a connector at its field ends (SI Eq. VC_w)
  in its 7 coordinates x_c = (x_lower, x_upper, γ).

The kinematic quantities are affine in u and γ and each angle enters one rigid element, so
their Hessians are diagonal (entries at the angles): they are returned as diagonals.

The fold-field energies are in :mod:`.fields`. The element loops (:mod:`.assemble`,
:mod:`.chainterm`) call the ``*_into`` kernels: they fill
scratch arrays, take the tables of :class:`~.tables.SystemData` whole with an element index
and the angles as (cos, sin), one cos and sin an angle (:func:`angles`). The kernels are
inlined by LLVM with NumPy's error model (:data:`~biplan._compile.numba_cache.inlined_kernel`),
so that an element costs no call and Numba prunes the reference counting of their arrays,
which it cannot where a loop holds an exception path (a raising division, a run-time tuple
index, a call not inlined) or builds views (``d.ref[i]``).
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import inlined_kernel, kernel

__all__ = [
    "angles",
    "connector_points",
    "edge",
    "line_height",
    "module_rows",
    "node",
    "pair",
    "pivots",
    "points_into",
    "rotated",
    "rows_into",
]

#: (cos φ1, sin φ1, cos φ2, sin φ2) of a module (:func:`angles`) or (z, s, z, s) of its pivots
#: (:func:`pivots`): a pair per element.
Quad = tuple[float, float, float, float]


@inlined_kernel
def angles(phi1: float, phi2: float) -> Quad:
    """(cos φ1, sin φ1, cos φ2, sin φ2) of a module's element angles: the kernels below take
    an element's angle through these, so each angle costs one cos and one sin."""
    return math.cos(phi1), math.sin(phi1), math.cos(phi2), math.sin(phi2)


@inlined_kernel
def _line(
    u: float, c: float, sn: float, pz: float, ps: float, z_edge: float, s: float
) -> tuple[float, float, float]:
    """:func:`line_height` with (c, sn) = (cos φ, sin φ)."""
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


@kernel
def line_height(
    u: float, phi: float, pz: float, ps: float, z_edge: float, s: float
) -> tuple[float, float, float]:
    """(h, ∂h/∂φ, ∂²h/∂φ²): z [mm] at circumferential position s of the element edge line
    z = z_edge rotated by φ about the pivot (pz, ps) and translated by u (∂h/∂u = 1;
    :func:`biplan.geometry.chain.line_height`)."""
    return _line(u, math.cos(phi), math.sin(phi), pz, ps, z_edge, s)


@inlined_kernel
def pair(t: Quad, element: int) -> tuple[float, float]:
    """Element ``element``'s pair of a :data:`Quad` (not t[2 e]: a run-time tuple index
    raises IndexError out of range, an exception path)."""
    if element == 0:
        return t[0], t[1]
    return t[2], t[3]


@inlined_kernel
def pivots(ref: np.ndarray, m: int) -> Quad:
    """(z, s, z, s) [mm] of module m's pivots in the reference table ``ref`` (N, 7, 2): node 0,
    about which element 1 turns, and node 6, about which element 2 turns."""
    return ref[m, 0, 0], ref[m, 0, 1], ref[m, 6, 0], ref[m, 6, 1]


@inlined_kernel
def edge(
    u: float, trig: Quad, piv: Quad, element: int, z_edge: float, s: float
) -> tuple[float, float, float]:
    """:func:`line_height` of element ``element`` (0 or 1) of a module at u with
    :func:`angles` ``trig`` and :func:`pivots` ``piv``."""
    c, sn = pair(trig, element)
    pz, ps = pair(piv, element)
    return _line(u, c, sn, pz, ps, z_edge, s)


@inlined_kernel
def _turn(
    u: float, c: float, sn: float, z0: float, s0: float, pz: float, ps: float
) -> tuple[float, float, float, float, float, float]:
    """:func:`node` of reference (z0, s0) turned by (c, sn) = (cos φ, sin φ) about (pz, ps)."""
    dz, ds = z0 - pz, s0 - ps
    rz, rs = c * dz - sn * ds, sn * dz + c * ds
    return rz + pz + u, rs + ps, -sn * dz - c * ds, c * dz - sn * ds, -rz, -rs


@kernel(inline="always")
def rotated(
    u: float, trig: Quad, ref: np.ndarray, m: int, i: int, element: int
) -> tuple[float, float, float, float, float, float]:
    """:func:`node` i of element ``element`` of module m (reference table ``ref`` (N, 7, 2))
    at u with :func:`angles` ``trig`` (inlined by Numba: callers pass literal node numbers,
    on which a compiled call would specialise)."""
    pivot = 0 if element == 0 else 6
    c, sn = pair(trig, element)
    return _turn(u, c, sn, ref[m, i, 0], ref[m, i, 1], ref[m, pivot, 0], ref[m, pivot, 1])


@kernel
def node(x: np.ndarray, ref: np.ndarray, i: int, element: int) -> tuple:
    """(z, s, ∂z/∂φ, ∂s/∂φ, ∂²z/∂φ², ∂²s/∂φ²) of node i of a module (MODEL §4, SI Eq. 10):
    r = R(φ_e)(r0 − P_e) + P_e + [u, 0], φ_e = x[1 + element]."""
    pivot = 0 if element == 0 else 6
    phi = x[1 + element]
    return _turn(
        x[0], math.cos(phi), math.sin(phi), ref[i, 0], ref[i, 1], ref[pivot, 0], ref[pivot, 1]
    )


@kernel(inline="always")
def _project(
    r: tuple,  # type: ignore[type-arg]
    element: int,
    sign: float,
    v0: float,
    v1: float,
    row: int,
    vals: np.ndarray,
    grad: np.ndarray,
    hdiag: np.ndarray,
) -> None:
    """Adds ± r·v of a :func:`node` r of element ``element`` (with its derivatives in
    x = (u, φ1, φ2)) to row ``row`` (inlined, as :func:`rotated`)."""
    z, s, dz, ds, d2z, d2s = r
    vals[row] += sign * (z * v0 + s * v1)
    grad[row, 0] += sign * v0
    grad[row, 1 + element] += sign * (dz * v0 + ds * v1)
    hdiag[row, 1 + element] += sign * (d2z * v0 + d2s * v1)


@inlined_kernel
def rows_into(
    q: np.ndarray,
    m: int,
    ref: np.ndarray,
    n_c: np.ndarray,
    n_sp: np.ndarray,
    vals: np.ndarray,
    grad: np.ndarray,
    hdiag: np.ndarray,
) -> None:
    """:func:`module_rows` of module m (coordinates q[3m : 3m + 3], tables ``ref`` (N, 7, 2),
    ``n_c`` and ``n_sp`` (N, 2)) written into ``vals`` (4,), ``grad`` (4, 3) and ``hdiag``
    (4, 3)::

        g_C = (r_C − r0_C)·n_c,  g_F = (r_F − r0_F)·n_c,  w0 = (r_E − r_D)·n_sp,
        wa = (r_F − r_C)·n_sp

    with C = node 2 and D = node 3 on element 1, E = node 4 and F = node 5 on element 2.
    """
    vals[:] = 0.0
    grad[:, :] = 0.0
    hdiag[:, :] = 0.0
    u = q[3 * m]
    trig = angles(q[3 * m + 1], q[3 * m + 2])
    r_c = rotated(u, trig, ref, m, 2, 0)
    r_d = rotated(u, trig, ref, m, 3, 0)
    r_e = rotated(u, trig, ref, m, 4, 1)
    r_f = rotated(u, trig, ref, m, 5, 1)
    c0, c1, s0, s1 = n_c[m, 0], n_c[m, 1], n_sp[m, 0], n_sp[m, 1]
    _project(r_c, 0, 1.0, c0, c1, 0, vals, grad, hdiag)
    vals[0] -= ref[m, 2, 0] * c0 + ref[m, 2, 1] * c1  # guides measure from the reference
    _project(r_f, 1, 1.0, c0, c1, 1, vals, grad, hdiag)
    vals[1] -= ref[m, 5, 0] * c0 + ref[m, 5, 1] * c1
    _project(r_e, 1, 1.0, s0, s1, 2, vals, grad, hdiag)
    _project(r_d, 0, -1.0, s0, s1, 2, vals, grad, hdiag)
    _project(r_f, 1, 1.0, s0, s1, 3, vals, grad, hdiag)
    _project(r_c, 0, -1.0, s0, s1, 3, vals, grad, hdiag)


@kernel
def module_rows(
    x: np.ndarray, ref: np.ndarray, n_c: np.ndarray, n_sp: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(values (4,), gradients (4, 3), Hessian diagonals (4, 3)) of (g_C, g_F, w0, wa) [mm]
    of one module in x = (u, φ1, φ2) (SI Eqs. 11 and bound, MODEL K2)."""
    vals = np.empty(4)
    grad = np.empty((4, 3))
    hdiag = np.empty((4, 3))
    tables = (  # one module's tables of N = 1
        np.ascontiguousarray(ref).reshape((1, 7, 2)),
        np.ascontiguousarray(n_c).reshape((1, 2)),
        np.ascontiguousarray(n_sp).reshape((1, 2)),
    )
    rows_into(x, 0, tables[0], tables[1], tables[2], vals, grad, hdiag)
    return vals, grad, hdiag


@inlined_kernel
def points_into(
    x: np.ndarray,
    p_lo: Quad,
    p_up: Quad,
    pitch: float,
    first: int,
    last: int,
    points: tuple,  # type: ignore[type-arg]
    w: np.ndarray,
    grad: np.ndarray,
    hdiag: np.ndarray,
) -> None:
    """:func:`connector_points` written into rows ``first`` … ``last − 1`` of ``w``, ``grad``
    and ``hdiag`` (one row per connector point; ``p_lo``, ``p_up``: the :func:`pivots` of the
    lower and upper module; ``points``: the tables (point_s, upper_element, lower_element,
    rigid, height, flip)). The seam terms −z_U(0) + z_L(0) are evaluated once."""
    point_s, upper_element, lower_element, rigid, height, flip = points
    t_lo, t_up = angles(x[1], x[2]), angles(x[4], x[5])
    # the seam: z_U(0) and z_L(0) (or the rigid edge's height) with their angle derivatives
    eu0, el0, rigid0 = upper_element[first], lower_element[first], rigid[first]
    hu0, hu1, hu2 = edge(x[3], t_up, p_up, eu0, 0.0, point_s[first])
    hl0 = hl1 = hl2 = 0.0
    if rigid0:
        hl0 = height[first]
    else:
        hl0, hl1, hl2 = edge(x[0], t_lo, p_lo, el0, pitch, point_s[first])
    for p in range(first, last):
        for j in range(7):
            grad[p, j] = 0.0
            hdiag[p, j] = 0.0
        # + z_U(s_k) − z_L(s_k)
        eu = upper_element[p]
        h, h1, h2 = edge(x[3], t_up, p_up, eu, 0.0, point_s[p])
        w[p] = h
        grad[p, 3] += 1.0
        grad[p, 4 + eu] += h1
        hdiag[p, 4 + eu] += h2
        if rigid[p]:
            w[p] -= height[p]
        else:
            el = lower_element[p]
            h, h1, h2 = edge(x[0], t_lo, p_lo, el, pitch, point_s[p])
            w[p] -= h
            grad[p, 0] -= 1.0
            grad[p, 1 + el] -= h1
            hdiag[p, 1 + el] -= h2
        # − z_U(0) + z_L(0)
        w[p] -= hu0
        grad[p, 3] -= 1.0
        grad[p, 4 + eu0] -= hu1
        hdiag[p, 4 + eu0] -= hu2
        w[p] += hl0
        if not rigid0:
            grad[p, 0] += 1.0
            grad[p, 1 + el0] += hl1
            hdiag[p, 1 + el0] += hl2
        w[p] += x[6]
        grad[p, 6] += 1.0
        if flip[p]:
            w[p] = 2.0 * x[6] - w[p]
            for j in range(7):
                grad[p, j] = -grad[p, j]
                hdiag[p, j] = -hdiag[p, j]
            grad[p, 6] += 2.0


@kernel
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
    w = np.empty(last)  # rows first … last − 1 are the connector's
    grad = np.empty((last, 7))
    hdiag = np.empty((last, 7))
    p_lo = (ref_lower[0, 0], ref_lower[0, 1], ref_lower[6, 0], ref_lower[6, 1])  # pivots
    p_up = (ref_upper[0, 0], ref_upper[0, 1], ref_upper[6, 0], ref_upper[6, 1])
    points = (point_s, upper_element, lower_element, rigid, height, flip)
    points_into(x, p_lo, p_up, pitch, first, last, points, w, grad, hdiag)
    return w[first:], grad[first:], hdiag[first:]
