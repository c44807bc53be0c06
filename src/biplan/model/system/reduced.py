"""Reduced coordinates on the compiled system: the guides solved in closed form (MODEL §16).

Each guide of a module involves one element: with v = P − A the reference offset of the
guided node (C of element 1 about node 0, F of element 2 about node 6), a = v·n_c,
b = (Jv)·n_c (J the quarter turn), ρ = √(a² + b²) and δ = atan2(b, a), the guide reads
ρ cos(φ − δ) = a − u n_c,z, so

    φ(u) = δ − sgn(δ) arccos(t),   t = (a − u n_c,z) / ρ

is the branch through φ(0) = 0 (:mod:`biplan.model.elements.reduced`, the JAX reading). Its
derivatives are φ' = −sgn(δ) n_c,z / (ρ √(1 − t²)) and
φ'' = sgn(δ) n_c,z² t / (ρ² (1 − t²)^{3/2}). Beyond |t| ≤ 1 the module is kinematically
locked (MODEL §16) and φ is NaN.

The reduced coordinates x = (u_1 … u_N, γ_1 … γ_Nc) map to q = Q(x) with ∂Q/∂x = T sparse
(a module's three coordinates depend on its own u; γ is copied), so a function f(q) has

    ∇_x f = Tᵀ ∇_q f,   ∇²_x f = Tᵀ ∇²_q f T + diag_m(∂f/∂φ1 φ1'' + ∂f/∂φ2 φ2'')

(:func:`reduce_derivatives`). :func:`penalized_value` and :func:`penalized_derivatives` give the
penalised energy of the state search's descent, Π(q(x)) + ½ k_p ‖min(w_∂(q(x)), 0)‖², from the
element terms of :func:`.assemble.terms` (the penalty's gradient and the curvature of the gaps
enter as contact multipliers λ_∂ = k_p max(−w_∂, 0), the Gauss–Newton part
k_p Σ_{w<0} ∇w ∇wᵀ is added). :func:`fold_openings` gives the length-mean elongation of every
fold and its Jacobian in x (the kinematic seed; :func:`biplan.model.potential.fold_openings`).
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.assemble import _FIRST, _SECOND, _terms
from biplan.model.system.elements import connector_points, module_rows
from biplan.model.system.tables import SystemData

__all__ = [
    "fold_openings",
    "full_coordinates",
    "penalized_derivatives",
    "penalized_value",
    "reduce_derivatives",
]

#: Guided node and pivot of each element (C about node 0, F about node 6).
_GUIDED = ((2, 0), (5, 6))


@kernel
def _angle(ref: np.ndarray, node: int, pivot: int, nz: float, ns: float, u: float) -> tuple:  # type: ignore[type-arg]
    """(φ, φ', φ'') [rad, rad/mm, rad/mm²] of the guided node ``node`` about ``pivot`` of one
    module (reference nodes ``ref`` (7, 2), crease tangent (nz, ns)) at axial displacement u."""
    vz, vs = ref[node, 0] - ref[pivot, 0], ref[node, 1] - ref[pivot, 1]
    a = vz * nz + vs * ns
    b = -vs * nz + vz * ns
    rho = math.hypot(a, b)
    delta = math.atan2(b, a)
    sgn = float(np.sign(delta))
    t = (a - u * nz) / rho
    if not abs(t) <= 1.0:  # locked (or NaN)
        return math.nan, math.nan, math.nan
    root = math.sqrt(1.0 - t * t)
    phi = delta - sgn * math.acos(t)
    if root == 0.0:
        return phi, math.nan, math.nan
    return phi, -sgn * nz / (rho * root), sgn * nz * nz * t / (rho * rho * root**3)


@kernel
def full_coordinates(d: SystemData, x: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """(q (n_q,), φ' (N, 2), φ'' (N, 2)) of reduced coordinates x (N + Nc,) (module
    docstring); NaN angles in a locked module."""
    n = d.ref.shape[0]
    q = np.empty(d.sizes[0])
    d1 = np.empty((n, 2))
    d2 = np.empty((n, 2))
    for m in range(n):
        u = x[m]
        q[3 * m] = u
        for e in range(2):
            node, pivot = _GUIDED[e]
            phi, p1, p2 = _angle(d.ref[m], node, pivot, d.n_c[m, 0], d.n_c[m, 1], u)
            q[3 * m + 1 + e] = phi
            d1[m, e] = p1
            d2[m, e] = p2
    for c in range(x.shape[0] - n):
        q[3 * n + c] = x[n + c]
    return q, d1, d2


@kernel
def _column(i: int, n: int, d1: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """(first row, rows, weights) of column i of T = ∂Q/∂x."""
    if i < n:
        return 3 * i, 3, (1.0, d1[i, 0], d1[i, 1])
    return 2 * n + i, 1, (1.0, 0.0, 0.0)


@kernel
def reduce_derivatives(
    grad: np.ndarray, hess: np.ndarray, d1: np.ndarray, d2: np.ndarray, second: bool
) -> tuple[np.ndarray, np.ndarray]:
    """(∇_x f, ∇²_x f or (0, 0)) of ∇_q f (n_q,) and ∇²_q f (n_q, n_q) (module docstring)."""
    n = d1.shape[0]
    nx = grad.shape[0] - 2 * n
    gx = np.zeros(nx)
    for i in range(nx):
        r0, k, w = _column(i, n, d1)
        for a in range(k):
            gx[i] += w[a] * grad[r0 + a]
    if not second:
        return gx, np.zeros((0, 0))
    hx = np.zeros((nx, nx))
    for i in range(nx):
        r0, k, w = _column(i, n, d1)
        for j in range(nx):
            s0, kk, v = _column(j, n, d1)
            acc = 0.0
            for a in range(k):
                for b in range(kk):
                    acc += w[a] * hess[r0 + a, s0 + b] * v[b]
            hx[i, j] = acc
    for m in range(n):
        hx[m, m] += grad[3 * m + 1] * d2[m, 0] + grad[3 * m + 2] * d2[m, 1]
    return gx, hx


@kernel
def penalized_value(d: SystemData, x: np.ndarray, stiffness: float) -> tuple:  # type: ignore[type-arg]
    """(Π(q(x)) + ½ k_p ‖min(w_∂, 0)‖² [N·mm], w_∂ (n_c,)) at reduced coordinates x; NaN
    where a module is locked."""
    q = full_coordinates(d, x)[0]
    t = _terms(d, q, np.zeros(d.sizes[1]), np.zeros(d.sizes[2]), _FIRST)
    gaps = t[3]
    value = t[6].sum() + t[7].sum()
    for w in gaps:
        if w < 0.0:
            value += 0.5 * stiffness * w * w
    return value, gaps


@kernel
def penalized_derivatives(
    d: SystemData, x: np.ndarray, gaps: np.ndarray, stiffness: float
) -> tuple[np.ndarray, np.ndarray]:
    """(gradient (N + Nc,), Hessian (N + Nc, N + Nc)) of :func:`penalized_value` at x, whose
    gaps are ``gaps`` (module docstring)."""
    q, d1, d2 = full_coordinates(d, x)
    lam_c = np.empty(gaps.shape[0])
    for i in range(gaps.shape[0]):
        lam_c[i] = stiffness * max(-gaps[i], 0.0)
    t = _terms(d, q, np.zeros(d.sizes[1]), lam_c, _SECOND)
    hess, c_mat = t[1], t[5]
    for i in range(gaps.shape[0]):
        if gaps[i] < 0.0:
            row = c_mat[i]
            nz = np.flatnonzero(row)
            for a in nz:
                for b in nz:
                    hess[a, b] += stiffness * row[a] * row[b]
    return reduce_derivatives(t[0], hess, d1, d2, _SECOND)


@kernel
def fold_openings(d: SystemData, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(w̄ (N + Nc,), ∂w̄/∂x (N + Nc, N + Nc)): the length-mean elongation [mm] of every fold,
    helical then circular (length-weighted over a connector's fields), at reduced coordinates
    x (:func:`biplan.model.potential.fold_openings`)."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    q, d1, _ = full_coordinates(d, x)
    out = np.zeros(n + nc)
    jac = np.zeros((n + nc, n + nc))
    for m in range(n):
        vals, grad, _ = module_rows(q[3 * m : 3 * m + 3], d.ref[m], d.n_c[m], d.n_sp[m])
        out[m] = 0.5 * (vals[2] + vals[3])
        for k in range(3):
            g = 0.5 * (grad[2, k] + grad[3, k])
            jac[m, m] += g * (1.0 if k == 0 else d1[m, k - 1])
    xc = np.zeros(7)
    for c in range(nc):
        lo, up = d.conn_lower[c], d.conn_upper[c]
        for k in range(3):
            xc[k] = 0.0 if lo < 0 else q[3 * lo + k]
            xc[3 + k] = q[3 * up + k]
        xc[6] = q[3 * n + c]
        first, last = d.conn_first_point[c], d.conn_first_point[c + 1]
        w, grad, _ = connector_points(
            xc,
            d.ref[max(lo, 0)],
            d.ref[up],
            d.scalars[0],
            first,
            last,
            d.point_s,
            d.point_upper_element,
            d.point_lower_element,
            d.point_rigid,
            d.point_height,
            d.point_flip,
        )
        local = np.zeros(7)
        total = 0.0
        for f in range(d.conn_first_field[c], d.conn_first_field[c + 1]):
            i0, i1 = d.field_start[f] - first, d.field_end[f] - first
            length = d.point_s[i1 + first] - d.point_s[i0 + first]
            out[n + c] += 0.5 * (w[i0] + w[i1]) * length
            for k in range(7):
                local[k] += 0.5 * (grad[i0, k] + grad[i1, k]) * length
            total += length
        out[n + c] /= total
        for k in range(7):
            local[k] /= total
        row = n + c
        if lo >= 0:
            jac[row, lo] += local[0] + local[1] * d1[lo, 0] + local[2] * d1[lo, 1]
        jac[row, up] += local[3] + local[4] * d1[up, 0] + local[5] * d1[up, 1]
        jac[row, n + c] += local[6]
    return out, jac
