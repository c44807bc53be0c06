"""The load point's axial displacement z_p(q) with its exact gradient and Hessian (Numba;
MODEL W1, the chain of :mod:`biplan.geometry.frames`).

Each connector c contributes a planar frame increment y_c = (α_c, t_c) that depends only on
its own coordinates x_c; the frames compose by angle sums, θ_c = Σ_{c' < c} α_c', and the top
module's nodes are rotated by θ = Σ α_c::

    Z(q) = Σ_c [R(θ_c) t_c]_z + [R(θ) X̄(x_top)]_z,   X̄ = Σ_i ω_i X_i,   z_p = Z(q) − Z(0)

with ω the load point's weights on the top module's nodes (:func:`.tables._load_weights`).
The derivatives follow by the chain rule through y_c (local Jacobians J_c, 3 × 7, and local
Hessians) and the closed-form derivatives of Z in (α, t, x_top): ∂²Z/∂α_a∂α_b =
−Σ_{c > max(a, b)} [R(θ_c) t_c]_z − [R(θ) X̄]_z, ∂²Z/∂α_a∂t_c = ∂R(θ_c)/∂θ row z (c > a),
∂²Z/∂t² = 0. O(N_c²) work, the size of the dense result.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from biplan.model.system.elements import _edge, node
from biplan.model.system.tables import SystemData

__all__ = ["load_point"]


@njit(cache=True)
def _increment(x: np.ndarray, d: SystemData, c: int, want: bool) -> tuple:  # type: ignore[type-arg]
    """(α, t_z, t_s), J (3, 7), Hessians (3, 7, 7) of connector c's frame increment."""
    ref, pitch = d.ref, d.scalars[0]
    lo, up, e = d.conn_lower[c], d.conn_upper[c], d.conn_element[c]
    seam = d.conn_first_point[c]
    jac = np.zeros((3, 7))
    hess = np.zeros((3, 7, 7))
    # δ = γ + z_L(0) − z_U(0): its gradient and (diagonal) Hessian in x_c
    gd = np.zeros(7)
    hd = np.zeros(7)
    eu = d.point_upper_element[seam]
    h, h1, h2 = _edge(x, ref[up], 3, eu, 0.0, 0.0)
    delta = x[6] - h
    gd[3] -= 1.0
    gd[4 + eu] -= h1
    hd[4 + eu] -= h2
    gd[6] = 1.0
    if d.point_rigid[seam]:
        delta += d.point_height[seam]
    else:
        el = d.point_lower_element[seam]
        h, h1, h2 = _edge(x, ref[lo], 0, el, pitch, 0.0)
        delta += h
        gd[0] += 1.0
        gd[1 + el] += h1
        hd[1 + el] += h2
    if e < 0 or lo < 0:
        jac[1] = gd
        if want:
            for k in range(7):
                hess[1, k, k] = hd[k]
        return 0.0, delta, 0.0, jac, hess
    ia = 1 + e
    alpha = x[ia]
    pivot = 0 if e == 0 else 6
    pz, ps = ref[lo, pivot, 0], ref[lo, pivot, 1]
    ca, sa = math.cos(alpha), math.sin(alpha)
    tz = pz - (ca * pz - sa * ps) + x[0] + ca * delta
    ts = ps - (sa * pz + ca * ps) + sa * delta
    jac[0, ia] = 1.0
    for k in range(7):
        jac[1, k] = ca * gd[k]
        jac[2, k] = sa * gd[k]
    jac[1, 0] += 1.0
    jac[1, ia] += sa * pz + ca * ps - sa * delta
    jac[2, ia] += -ca * pz + sa * ps + ca * delta
    if want:
        for k in range(7):
            hess[1, k, k] += ca * hd[k]
            hess[2, k, k] += sa * hd[k]
            hess[1, ia, k] -= sa * gd[k]
            hess[1, k, ia] -= sa * gd[k]
            hess[2, ia, k] += ca * gd[k]
            hess[2, k, ia] += ca * gd[k]
        hess[1, ia, ia] += ca * pz - sa * ps - ca * delta
        hess[2, ia, ia] += sa * pz + ca * ps - sa * delta
    return alpha, tz, ts, jac, hess


@njit(cache=True)
def _top(x: np.ndarray, ref: np.ndarray, weights: np.ndarray) -> tuple:
    """X̄ = Σ ω_i X_i of the top module (z, s), its gradient (2, 3) and Hessian diagonal."""
    xbar = np.zeros(2)
    g = np.zeros((2, 3))
    hdiag = np.zeros((2, 3))
    for i in range(7):
        wi = weights[i]
        if wi == 0.0:
            continue
        e = 0 if i < 4 else 1
        z, s, dz, ds, d2z, d2s = node(x, ref, i, e)
        xbar[0] += wi * z
        xbar[1] += wi * s
        g[0, 0] += wi
        g[0, 1 + e] += wi * dz
        g[1, 1 + e] += wi * ds
        hdiag[0, 1 + e] += wi * d2z
        hdiag[1, 1 + e] += wi * d2s
    return xbar, g, hdiag


@njit(cache=True)
def _dofs(d: SystemData, c: int) -> np.ndarray:  # type: ignore[type-arg]
    """Global coordinate of each of connector c's 7 local coordinates (−1: the clamp's)."""
    n = d.ref.shape[0]
    out = np.empty(7, dtype=np.int64)
    lo, up = d.conn_lower[c], d.conn_upper[c]
    for k in range(3):
        out[k] = -1 if lo < 0 else 3 * lo + k
        out[3 + k] = 3 * up + k
    out[6] = 3 * n + c
    return out


@njit(cache=True)
def _height(d: SystemData, q: np.ndarray) -> float:  # type: ignore[type-arg]
    """Z(q) (module docstring), value only."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    theta = 0.0
    z = 0.0
    x = np.zeros(7)
    for c in range(nc):
        dofs = _dofs(d, c)
        for k in range(7):
            x[k] = 0.0 if dofs[k] < 0 else q[dofs[k]]
        alpha, tz, ts, _, _ = _increment(x, d, c, False)
        z += math.cos(theta) * tz - math.sin(theta) * ts
        theta += alpha
    xbar, _, _ = _top(q[3 * n - 3 : 3 * n], d.ref[n - 1], d.load_weights)
    return z + math.cos(theta) * xbar[0] - math.sin(theta) * xbar[1]


@njit(cache=True)
def load_point(
    d: SystemData,
    q: np.ndarray,
    gradient: np.ndarray,
    hessian: np.ndarray,
    coef: float,
    second: bool,
) -> float:
    """z_p(q) [mm]; fills ``gradient`` (n_q,) with ∇z_p and, if ``second``, adds
    ``coef`` ∇²z_p to ``hessian`` (n_q, n_q)."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    alphas = np.zeros(nc)
    before = np.zeros(nc)  # θ_c
    v_z = np.zeros(nc)  # [R(θ_c) t_c]_z
    v_s = np.zeros(nc)
    jacs = np.zeros((nc, 3, 7))
    dofs = np.zeros((nc, 7), dtype=np.int64)
    x = np.zeros(7)
    theta = 0.0
    for c in range(nc):
        dofs[c] = _dofs(d, c)
        for k in range(7):
            x[k] = 0.0 if dofs[c, k] < 0 else q[dofs[c, k]]
        alpha, tz, ts, jac, hy = _increment(x, d, c, second)
        ct, st = math.cos(theta), math.sin(theta)
        alphas[c], before[c], jacs[c] = alpha, theta, jac
        v_z[c] = ct * tz - st * ts
        v_s[c] = st * tz + ct * ts
        theta += alpha
        if second:  # local part: Σ_k ∂Z/∂y_k ∇²y_k (α is linear in x_c)
            for i in range(7):
                if dofs[c, i] < 0:
                    continue
                for j in range(7):
                    if dofs[c, j] >= 0:
                        hessian[dofs[c, i], dofs[c, j]] += coef * (
                            ct * hy[1, i, j] - st * hy[2, i, j]
                        )
    top = np.arange(3 * n - 3, 3 * n)
    xbar, gx, hx = _top(q[3 * n - 3 : 3 * n], d.ref[n - 1], d.load_weights)
    ct, st = math.cos(theta), math.sin(theta)
    t_z = ct * xbar[0] - st * xbar[1]  # [R(θ) X̄]_z
    t_theta = -st * xbar[0] - ct * xbar[1]
    value = v_z.sum() + t_z
    # ∂Z/∂α_a = −Σ_{c > a} [R(θ_c) t_c]_s + ∂[R(θ) X̄]_z/∂θ (suffix sums)
    suffix_s = np.zeros(nc + 1)
    suffix_z = np.zeros(nc + 1)
    for c in range(nc - 1, -1, -1):
        suffix_s[c] = suffix_s[c + 1] + v_s[c]
        suffix_z[c] = suffix_z[c + 1] + v_z[c]
    gradient[:] = 0.0
    for c in range(nc):
        g_alpha = -suffix_s[c + 1] + t_theta
        g_tz, g_ts = math.cos(before[c]), -math.sin(before[c])
        for k in range(7):
            if dofs[c, k] >= 0:
                gradient[dofs[c, k]] += (
                    jacs[c, 0, k] * g_alpha + jacs[c, 1, k] * g_tz + jacs[c, 2, k] * g_ts
                )
    for k in range(3):
        gradient[top[k]] += ct * gx[0, k] - st * gx[1, k]
    if not second:
        return value
    # chain part: Jᵀ ∇²Z J
    m_top = np.zeros(3)  # ∂²Z/∂θ∂x_top
    for k in range(3):
        m_top[k] = -st * gx[0, k] - ct * gx[1, k]
        hessian[top[k], top[k]] += coef * (ct * hx[0, k] - st * hx[1, k])
    for a in range(nc):
        if d.conn_element[a] < 0 or d.conn_lower[a] < 0:
            continue
        ia = dofs[a, 1 + d.conn_element[a]]
        for b in range(nc):
            if d.conn_element[b] < 0 or d.conn_lower[b] < 0:
                continue
            ib = dofs[b, 1 + d.conn_element[b]]
            hessian[ia, ib] += coef * (-suffix_z[max(a, b) + 1] - t_z)
        for k in range(3):
            hessian[ia, top[k]] += coef * m_top[k]
            hessian[top[k], ia] += coef * m_top[k]
        for c in range(a + 1, nc):
            sb, cb = math.sin(before[c]), math.cos(before[c])
            for k in range(7):
                if dofs[c, k] >= 0:
                    u = -sb * jacs[c, 1, k] - cb * jacs[c, 2, k]
                    hessian[ia, dofs[c, k]] += coef * u
                    hessian[dofs[c, k], ia] += coef * u
    return value


@njit(cache=True)
def reference_height(d: SystemData) -> float:
    """Z(0): the load point at q = 0 (depends on the geometry only)."""
    return _height(d, np.zeros(d.sizes[0]))


@njit(cache=True)
def edge_points(d: SystemData, q: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """Global (z, s) [mm] of the free-end edge's segment ends, (S, 2, 2) (the top module's
    nodes in the frame composed up the chain; :func:`biplan.geometry.chain.end_edge_points`)."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    theta, pz, ps = 0.0, 0.0, 0.0
    x = np.zeros(7)
    for c in range(nc):
        dofs = _dofs(d, c)
        for k in range(7):
            x[k] = 0.0 if dofs[k] < 0 else q[dofs[k]]
        alpha, tz, ts, _, _ = _increment(x, d, c, False)
        ct, st = math.cos(theta), math.sin(theta)
        pz += ct * tz - st * ts
        ps += st * tz + ct * ts
        theta += alpha
    ct, st = math.cos(theta), math.sin(theta)
    segs = d.end_segments
    out = np.zeros((segs.shape[0], 2, 2))
    x_top = q[3 * n - 3 : 3 * n]
    for j in range(segs.shape[0]):
        for end in range(2):
            i = segs[j, end]
            z, s, _, _, _, _ = node(x_top, d.ref[n - 1], i, 0 if i < 4 else 1)
            out[j, end, 0] = pz + ct * z - st * s
            out[j, end, 1] = ps + st * z + ct * s
    return out
