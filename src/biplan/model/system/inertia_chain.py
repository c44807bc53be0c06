"""The chain terms of the body centres (Numba; :mod:`.inertia`, MODEL §13).

A body's centre is c_b = Σ_j R(θ_j) t_j over the terms of its chain (the connectors below its
module, then the centre's offset in the module frame), θ_j the sum of the increments' angles
α below term j (:func:`terms`, :func:`path`). Its Hessian contracted with a fixed vector λ
(:func:`centre_hessian`, :func:`curved_rows`) is, with S_j = Σ_{j' ≥ j} R(θ_j') t_j' and
J = [[0, −1], [1, 0]]::

    ∇²(λ·c_b) = Σ_j λ·R_j ∇²t_j + Σ_{i < j} (∇α_i ⊗ λ·J R_j ∂t_j + sym.)
                − Σ_{i, i'} λ·S_{max(i, i') + 1} ∇α_i ⊗ ∇α_i' + Σ_i λ·J S_{i+1} ∇²α_i
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.increments import increment3
from biplan.model.system.tables import SystemData

__all__ = ["centre_hessian", "curved_rows", "path", "terms"]


@kernel
def terms(d: SystemData, q: np.ndarray, v: np.ndarray, centre: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """The chain terms of every body centre c_b = Σ_j R(θ_j) t_j: the connectors' increments
    (terms 0 … Nc − 1) and each body's translation in its module frame (term Nc + b),
    t_b = R(φ_e)(X_b − P_e) + P_e + [u, 0]. Returns (dofs (n_t, 7), ∇α (n_t, 7), ∇²α
    (n_t, 7, 7), ∂/∂x vᵀ(∂²α)v (n_t, 7), t (n_t, 2), ∂t/∂x (n_t, 2, 7), ∂²t/∂x² (n_t, 2, 7, 7),
    ∂/∂x vᵀ(∂²t)v (n_t, 2, 7), the angle of the frame each term is rotated by, θ_j (n_t,), and
    the parent connector of every module (N,)); the α entries of the body terms are zero (a
    body's own angle φ_e enters its centre through t_b)."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    n_t = nc + 2 * n
    dofs = np.full((n_t, 7), -1, dtype=np.int64)
    g = np.zeros((n_t, 7))
    ha = np.zeros((n_t, 7, 7))
    avv = np.zeros((n_t, 7))
    t = np.zeros((n_t, 2))
    jt = np.zeros((n_t, 2, 7))
    ht = np.zeros((n_t, 2, 7, 7))
    tvv = np.zeros((n_t, 2, 7))
    th = np.zeros(n_t)
    theta = np.zeros(n)
    parent = np.full(n, -1, dtype=np.int64)
    x = np.zeros(7)
    vx = np.zeros(7)
    work = np.zeros((3, 7))
    for c in range(nc):  # connectors run up the chain: the lower frame is already known
        lo, up = d.conn_lower[c], d.conn_upper[c]
        parent[up] = c
        for k in range(3):
            dofs[c, k] = -1 if lo < 0 else 3 * lo + k
            dofs[c, 3 + k] = 3 * up + k
        dofs[c, 6] = 3 * n + c
        for k in range(7):
            x[k] = 0.0 if dofs[c, k] < 0 else q[dofs[c, k]]
            vx[k] = 0.0 if dofs[c, k] < 0 else v[dofs[c, k]]
        alpha = increment3(x, vx, d, c, g[c], ha[c], avv[c], t[c], jt[c], ht[c], tvv[c], work)
        th[c] = 0.0 if lo < 0 else theta[lo]
        theta[up] = th[c] + alpha
    for b in range(2 * n):
        m, e = b // 2, b % 2
        j = nc + b
        for k in range(3):
            dofs[j, k] = 3 * m + k
        pivot = 0 if e == 0 else 6
        pz, ps = d.ref[m, pivot, 0], d.ref[m, pivot, 1]
        dz, ds = centre[b, 0] - pz, centre[b, 1] - ps
        phi = q[3 * m + 1 + e]
        cp, sp = math.cos(phi), math.sin(phi)
        rz, rs = cp * dz - sp * ds, sp * dz + cp * ds
        t[j, 0], t[j, 1] = rz + pz + q[3 * m], rs + ps
        jt[j, 0, 0] = 1.0
        jt[j, 0, 1 + e], jt[j, 1, 1 + e] = -rs, rz
        ht[j, 0, 1 + e, 1 + e], ht[j, 1, 1 + e, 1 + e] = -rz, -rs
        vp = v[3 * m + 1 + e]
        tvv[j, 0, 1 + e], tvv[j, 1, 1 + e] = vp * vp * rs, -vp * vp * rz
        th[j] = theta[m]
    return dofs, g, ha, avv, t, jt, ht, tvv, th, parent


@kernel
def path(parent: np.ndarray, d: SystemData, m: int, nc: int, b: int, out: np.ndarray) -> int:  # type: ignore[type-arg]
    """The terms of body b of module m, bottom to top, into ``out``: the connectors below m,
    then Nc + b; returns their number."""
    count = 0
    c = parent[m]
    while c >= 0:
        count += 1
        lo = d.conn_lower[c]
        c = parent[lo] if lo >= 0 else -1
    out[count] = nc + b
    size = count + 1
    c = parent[m]
    while c >= 0:
        count -= 1
        out[count] = c
        lo = d.conn_lower[c]
        c = parent[lo] if lo >= 0 else -1
    return size


@kernel
def curved_rows(
    chain: np.ndarray,
    size: int,
    dofs: np.ndarray,
    ha: np.ndarray,
    bend: np.ndarray,
    curved: np.ndarray,
    g_body: np.ndarray,
    body: tuple[float, float, float, float],
    suf: np.ndarray,
    mat: np.ndarray,
) -> None:
    """Adds the terms of the curved connector angles (∇²α ≠ 0) below a body to the step's
    dF/dq: (λ·J S_{i+1}) ∇²α_i in ∇²(λ·c_b), and I_b [Θ̈_b ∇²α_i + g_b ⊗ ∂θ̈/∂x_i];
    ``body`` = (I_b, Θ̈_b, λ_z, λ_s)."""
    ib, theta_dd, lam_z, lam_s = body
    for p in range(size - 1):
        j = chain[p]
        if not curved[j]:
            continue
        coef = -lam_z * suf[p + 1, 1] + lam_s * suf[p + 1, 0] + ib * theta_dd
        for k in range(7):
            ck = dofs[j, k]
            if ck < 0:
                continue
            for i in range(g_body.shape[0]):
                mat[i, ck] += ib * g_body[i] * bend[j, k]
            for l in range(7):
                cl = dofs[j, l]
                if cl >= 0:
                    mat[ck, cl] += coef * ha[j, k, l]


@kernel
def centre_hessian(
    chain: np.ndarray,
    size: int,
    dofs: np.ndarray,
    g: np.ndarray,
    jt: np.ndarray,
    ht: np.ndarray,
    th: np.ndarray,
    lam_z: float,
    lam_s: float,
    suf: np.ndarray,
    mat: np.ndarray,
) -> None:
    """Adds ∇²(λ·c_b) of a body's centre to ``mat`` through the terms' local Hessians and the
    frame angles (λ = m_b c̈_b; the angles' own curvature: :func:`curved_rows`)."""
    for p in range(size):
        j = chain[p]
        cs, sn = math.cos(th[j]), math.sin(th[j])
        # local: λ·R_j ∂²t_j
        lr0 = cs * lam_z + sn * lam_s  # (R_jᵀ λ)
        lr1 = -sn * lam_z + cs * lam_s
        for k in range(7):
            ck = dofs[j, k]
            if ck < 0:
                continue
            for l in range(7):
                cl = dofs[j, l]
                if cl >= 0:
                    mat[ck, cl] += lr0 * ht[j, 0, k, l] + lr1 * ht[j, 1, k, l]
        # α_i (i below j) with x_j: λ·J R_j ∂t_j ;  J R_j ∂t = R_j J ∂t
        for pi in range(p):
            i = chain[pi]
            for ki in range(7):
                gi = g[i, ki]
                if gi == 0.0 or dofs[i, ki] < 0:
                    continue
                ci = dofs[i, ki]
                for k in range(7):
                    ck = dofs[j, k]
                    if ck < 0:
                        continue
                    val = gi * (lr0 * -jt[j, 1, k] + lr1 * jt[j, 0, k])
                    mat[ci, ck] += val
                    mat[ck, ci] += val
        # α_i α_j: −λ·S_{max}
        for ki in range(7):
            gj = g[j, ki]
            if gj == 0.0 or dofs[j, ki] < 0:
                continue
            cj = dofs[j, ki]
            for pi in range(p + 1):
                i = chain[pi]
                for k2 in range(7):
                    gi = g[i, k2]
                    if gi == 0.0 or dofs[i, k2] < 0:
                        continue
                    ci = dofs[i, k2]
                    val = -gi * gj * (lam_z * suf[p + 1, 0] + lam_s * suf[p + 1, 1])
                    mat[ci, cj] += val
                    if pi != p:
                        mat[cj, ci] += val
