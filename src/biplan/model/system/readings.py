"""The chain under the readings other than the default one, with exact derivatives (Numba;
:mod:`biplan.geometry.chain`).

Under R1 ``EXACT`` with R3 ``ELEMENT`` each connector's frame increment turns by one element
angle, which :mod:`.chainterm` exploits. Under the other readings the increment's angle and
offset are general functions of the connector's coordinates x_c = (x_lower, x_upper, γ):
:func:`increment` gives y_c = (angle, t_z, t_s) with its Jacobian (3, 7) and Hessians
(3, 7, 7), and :func:`load_point` assembles z_p, ∇z_p and ∇²z_p densely from them (the frames
compose as F_up = F_lo ∘ y_c either way).

**R3 EDGE_FIT.** Each module's edge next to a connector is fitted by the least-squares rigid
motion f = (a, t) from its reference to its deformed segment ends, each end weighted by half
its segment's reference length (:func:`biplan.geometry.chain._edge_fit`). With P_i = p_i − p̄
the reference ends about their weighted centroid and q_i the deformed ones,

    S = Σ w_i (P_z q_s − P_s q_z),  C = Σ w_i (P_z q_z + P_s q_s),  a = atan2(S, C),
    t = q̄ − R(a) p̄

(S, C do not depend on u since Σ w P = 0; an edge node moves with one element angle, so
∂²/∂φ1∂φ2 = 0), and connector c stacks the upper module on the lower one by

    y_c = f_lo ∘ Trans(l + γ) ∘ f_up⁻¹
        = (a_lo − a_up,  t_lo + R(a_lo)(l + γ, 0) − R(a_lo − a_up) t_up)

(the clamp line for the base connector: a_lo = 0, t_lo = (h − l, 0), h its height).

**R1 PAPER.** The SI's literal offset a_m = Δ_m [1, tan θ_m], Δ_m = γ − u_up + l, after the
lower element's rotation θ about its pivot P (moved by u_lo):
y_c = (θ, (Δ, Δ tan θ) + P − R(θ) P); (0, Δ, 0) without a full lower element and
(0, γ − u_up, 0) at the clamp.
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.elements import angles, rotated
from biplan.model.system.tables import SystemData

__all__ = ["chain_end", "fit", "increment", "load_point"]


@kernel
def fit(d: SystemData, q: np.ndarray, m: int, segs: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """((a, t_z, t_s), Jacobian (3, 3), Hessians (3, 3, 3)) of module m's edge fit in its
    coordinates (u, φ1, φ2); ``segs`` (2, 2): the segments' end nodes, -1 none (module
    docstring)."""
    u, trig = q[3 * m], angles(q[3 * m + 1], q[3 * m + 2])
    nodes = np.zeros((4, 9))  # weight, P_z, P_s, z, s, dz, ds, d2z, d2s (∂ in the node's φ)
    element = np.zeros(4, dtype=np.int64)
    k = 0
    for j in range(2):
        if segs[j, 0] < 0:
            continue
        i0, i1 = segs[j, 0], segs[j, 1]
        w = math.hypot(d.ref[m, i1, 0] - d.ref[m, i0, 0], d.ref[m, i1, 1] - d.ref[m, i0, 1])
        for i in (i0, i1):
            e = 0 if i < 4 else 1
            z, s, dz, ds, d2z, d2s = rotated(u, trig, d.ref, m, i, e)
            nodes[k, 0], nodes[k, 1], nodes[k, 2] = w, d.ref[m, i, 0], d.ref[m, i, 1]
            nodes[k, 3], nodes[k, 4], nodes[k, 5], nodes[k, 6] = z, s, dz, ds
            nodes[k, 7], nodes[k, 8] = d2z, d2s
            element[k] = e
            k += 1
    total = nodes[:k, 0].sum()
    pc = np.zeros(2)
    qc = np.zeros(2)
    qc1 = np.zeros((2, 2))  # ∂q̄/∂φ_e (component, e)
    qc2 = np.zeros((2, 2))
    for j in range(k):
        w, e = nodes[j, 0] / total, element[j]
        for r in range(2):
            pc[r] += w * nodes[j, 1 + r]
            qc[r] += w * nodes[j, 3 + r]
            qc1[r, e] += w * nodes[j, 5 + r]
            qc2[r, e] += w * nodes[j, 7 + r]
    s_ = c_ = 0.0
    ds_, dc_, d2s_, d2c_ = np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(2)
    for j in range(k):
        w, e = nodes[j, 0], element[j]
        pz, ps = nodes[j, 1] - pc[0], nodes[j, 2] - pc[1]
        s_ += w * (pz * nodes[j, 4] - ps * nodes[j, 3])
        c_ += w * (pz * nodes[j, 3] + ps * nodes[j, 4])
        ds_[e] += w * (pz * nodes[j, 6] - ps * nodes[j, 5])
        dc_[e] += w * (pz * nodes[j, 5] + ps * nodes[j, 6])
        d2s_[e] += w * (pz * nodes[j, 8] - ps * nodes[j, 7])
        d2c_[e] += w * (pz * nodes[j, 7] + ps * nodes[j, 8])
    a = math.atan2(s_, c_)
    rho2 = s_ * s_ + c_ * c_
    # a's derivatives in (φ1, φ2): a_k = (C S_k − S C_k)/ρ², a_kl by the quotient rule
    a1 = np.zeros(3)
    a2 = np.zeros((3, 3))
    for e in range(2):
        a1[1 + e] = (c_ * ds_[e] - s_ * dc_[e]) / rho2
    for e in range(2):
        for f in range(2):
            num_l = dc_[f] * ds_[e] - ds_[f] * dc_[e]
            if e == f:
                num_l += c_ * d2s_[e] - s_ * d2c_[e]
            dr2 = 2.0 * (s_ * ds_[f] + c_ * dc_[f])
            a2[1 + e, 1 + f] = num_l / rho2 - a1[1 + e] * dr2 / rho2
    ca, sa = math.cos(a), math.sin(a)
    r0 = (ca * pc[0] - sa * pc[1], sa * pc[0] + ca * pc[1])  # R(a) p̄
    r1 = (-sa * pc[0] - ca * pc[1], ca * pc[0] - sa * pc[1])  # its a-derivative
    value = np.array([a, qc[0] - r0[0], qc[1] - r0[1]])
    jac = np.zeros((3, 3))
    hess = np.zeros((3, 3, 3))
    for k2 in range(3):
        jac[0, k2] = a1[k2]
        for r in range(2):
            dq = (1.0 if r == 0 else 0.0) if k2 == 0 else qc1[r, k2 - 1]
            jac[1 + r, k2] = dq - (r1[r] * a1[k2])
    for k2 in range(3):
        for l2 in range(3):
            hess[0, k2, l2] = a2[k2, l2]
            for r in range(2):
                dq2 = qc2[r, k2 - 1] if (k2 == l2 and k2 > 0) else 0.0
                hess[1 + r, k2, l2] = dq2 + r0[r] * a1[k2] * a1[l2] - r1[r] * a2[k2, l2]
    return value, jac, hess


@kernel
def increment(d: SystemData, q: np.ndarray, c: int) -> tuple:  # type: ignore[type-arg]
    """(y_c (3,), ∂y_c/∂x_c (3, 7), ∂²y_c/∂x_c² (3, 7, 7)) of connector c: (angle, t_z, t_s),
    x_c = (x_lower, x_upper, γ), under R1 ``PAPER`` or R3 ``EDGE_FIT`` (module docstring)."""
    if d.flags[3] == 1:
        return _paper_increment(d, q, c)
    return _fit_increment(d, q, c)


@kernel
def _paper_increment(d: SystemData, q: np.ndarray, c: int) -> tuple:  # type: ignore[type-arg]
    """:func:`increment` under R1 ``PAPER``."""
    n = d.ref.shape[0]
    lo, up, e = d.conn_lower[c], d.conn_upper[c], d.conn_seam[c, 0]
    gam, u_up = q[3 * n + c], q[3 * up]
    y, jac, hess = np.zeros(3), np.zeros((3, 7)), np.zeros((3, 7, 7))
    jac[1, 6], jac[1, 3] = 1.0, -1.0
    if lo < 0:
        y[1] = gam - u_up
        return y, jac, hess
    dp = gam - u_up + d.scalars[0]
    if e < 0:
        y[1] = dp
        return y, jac, hess
    u_lo, theta = q[3 * lo], q[3 * lo + 1 + e]
    pz = d.ref[lo, 0 if e == 0 else 6, 0] + u_lo
    ps = d.ref[lo, 0 if e == 0 else 6, 1]
    ct, st = math.cos(theta), math.sin(theta)
    tn, sec2 = st / ct, 1.0 / (ct * ct)
    ia = 1 + e
    y[0] = theta
    y[1] = dp + pz - (ct * pz - st * ps)
    y[2] = dp * tn + ps - (st * pz + ct * ps)
    jac[0, ia] = 1.0
    jac[1, 0] = 1.0 - ct
    jac[1, ia] = st * pz + ct * ps
    jac[2, 6], jac[2, 3], jac[2, 0] = tn, -tn, -st
    jac[2, ia] = dp * sec2 - (ct * pz - st * ps)
    hess[1, ia, ia] = ct * pz - st * ps
    hess[1, ia, 0] = hess[1, 0, ia] = st
    hess[2, ia, ia] = 2.0 * dp * sec2 * tn + st * pz + ct * ps
    hess[2, ia, 6] = hess[2, 6, ia] = sec2
    hess[2, ia, 3] = hess[2, 3, ia] = -sec2
    hess[2, ia, 0] = hess[2, 0, ia] = -ct
    return y, jac, hess


@kernel
def _fit_increment(d: SystemData, q: np.ndarray, c: int) -> tuple:  # type: ignore[type-arg]
    """:func:`increment` under R3 ``EDGE_FIT``."""
    n = d.ref.shape[0]
    lo, up, gam = d.conn_lower[c], d.conn_upper[c], q[3 * n + c]
    # the lower fit (a1, t_l) and the upper one (a2, t_u) embedded in x_c's 7 coordinates
    f1, j1, h1 = np.zeros(3), np.zeros((3, 7)), np.zeros((3, 7, 7))
    if lo < 0:
        f1[1] = d.conn_seam_height[c] - d.scalars[0]
    else:
        v, jv, hv = fit(d, q, lo, d.conn_edges[c, 0])
        f1[:] = v
        j1[:, :3] = jv
        h1[:, :3, :3] = hv
    f2, j2, h2 = np.zeros(3), np.zeros((3, 7)), np.zeros((3, 7, 7))
    v, jv, hv = fit(d, q, up, d.conn_edges[c, 1])
    f2[:] = v
    j2[:, 3:6] = jv
    h2[:, 3:6, 3:6] = hv
    length = d.scalars[0] + gam
    b = f1[0] - f2[0]
    c1, s1, cb, sb = math.cos(f1[0]), math.sin(f1[0]), math.cos(b), math.sin(b)
    tu = (f2[1], f2[2])
    rq = (cb * tu[0] - sb * tu[1], sb * tu[0] + cb * tu[1])  # R(B) t_u
    rq1 = (-rq[1], rq[0])  # its B-derivative
    y = np.array([b, f1[1] + length * c1 - rq[0], f1[2] + length * s1 - rq[1]])
    jac = np.zeros((3, 7))
    hess = np.zeros((3, 7, 7))
    bj = j1[0] - j2[0]
    bh = h1[0] - h2[0]
    rot = ((cb, -sb), (sb, cb))
    drot = ((-sb, -cb), (cb, -sb))
    dl = (-s1, c1)  # ∂(cos a1, sin a1)/∂a1
    for k in range(7):
        jac[0, k] = bj[k]
        for r in range(2):
            rt = rot[r][0] * j2[1, k] + rot[r][1] * j2[2, k]  # R(B) ∂t_u
            jac[1 + r, k] = j1[1 + r, k] + length * dl[r] * j1[0, k] - rq1[r] * bj[k] - rt
    jac[1, 6] += c1
    jac[2, 6] += s1
    for k in range(7):
        for m in range(7):
            hess[0, k, m] = bh[k, m]
            for r in range(2):
                lead = (c1, s1)[r]
                term = h1[1 + r, k, m]
                term += length * (-lead * j1[0, k] * j1[0, m] + dl[r] * h1[0, k, m])
                term -= -rq[r] * bj[k] * bj[m] + rq1[r] * bh[k, m]
                dk = drot[r][0] * j2[1, k] + drot[r][1] * j2[2, k]  # R'(B) ∂_k t_u
                dm = drot[r][0] * j2[1, m] + drot[r][1] * j2[2, m]
                term -= dk * bj[m] + dm * bj[k]
                term -= rot[r][0] * h2[1, k, m] + rot[r][1] * h2[2, k, m]
                hess[1 + r, k, m] = term
    for k in range(7):  # the γ cross terms: ∂(l + γ)(cos a1, sin a1)/∂γ∂x_k
        for r in range(2):
            hess[1 + r, 6, k] += dl[r] * j1[0, k]
            hess[1 + r, k, 6] += dl[r] * j1[0, k]
    return y, jac, hess


@kernel
def chain_end(d: SystemData, q: np.ndarray) -> tuple[float, float, float]:  # type: ignore[type-arg]
    """(θ, p_z, p_s): the top module's frame at q, the increments composed up the chain."""
    theta, pz, ps = 0.0, 0.0, 0.0
    for c in range(d.conn_upper.shape[0]):
        y = increment(d, q, c)[0]
        ct, st = math.cos(theta), math.sin(theta)
        pz += ct * y[1] - st * y[2]
        ps += st * y[1] + ct * y[2]
        theta += y[0]
    return theta, pz, ps


@kernel
def load_point(
    d: SystemData,
    q: np.ndarray,
    top: tuple,  # type: ignore[type-arg]
    gradient: np.ndarray,
    hessian: np.ndarray,
    coef: float,
    second: bool,
) -> float:
    """Z(q) = Σ_c [R(θ_c) t_c]_z + [R(θ) X̄]_z [mm] (not less Z(0)); fills ``gradient`` with ∇Z
    and, if ``second``, adds ``coef`` ∇²Z to ``hessian``. ``top``: (X̄_z, X̄_s, ∇X̄ (2, 3),
    diag ∇²X̄ (2, 3)) of the top module (:func:`.chainterm._top`)."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    dofs = d.conn_dofs
    jacs = np.empty((nc, 3, 7))
    hs = np.empty((nc, 3, 7, 7))
    cos_b, sin_b, v_z, v_s = np.empty(nc), np.empty(nc), np.empty(nc), np.empty(nc)
    theta = 0.0
    for c in range(nc):
        y, jacs[c], hs[c] = increment(d, q, c)
        ct, st = math.cos(theta), math.sin(theta)
        cos_b[c], sin_b[c] = ct, st
        v_z[c] = ct * y[1] - st * y[2]
        v_s[c] = st * y[1] + ct * y[2]
        theta += y[0]
    zbar, sbar, gx, hx = top
    t0 = 3 * n - 3
    ct, st = math.cos(theta), math.sin(theta)
    t_z = ct * zbar - st * sbar
    t_theta = -st * zbar - ct * sbar
    suffix_z, suffix_s = np.zeros(nc + 1), np.zeros(nc + 1)
    for c in range(nc - 1, -1, -1):
        suffix_s[c] = suffix_s[c + 1] + v_s[c]
        suffix_z[c] = suffix_z[c + 1] + v_z[c]
    dz_dy = np.empty((nc, 3))  # ∂Z/∂y_c
    for c in range(nc):
        dz_dy[c, 0] = -suffix_s[c + 1] + t_theta
        dz_dy[c, 1], dz_dy[c, 2] = cos_b[c], -sin_b[c]
    gradient[:] = 0.0
    for c in range(nc):
        for k in range(7):
            if dofs[c, k] >= 0:
                for r in range(3):
                    gradient[dofs[c, k]] += dz_dy[c, r] * jacs[c, r, k]
    for k in range(3):
        gradient[t0 + k] += ct * gx[0, k] - st * gx[1, k]
    value = suffix_z[0] + t_z
    if not second:
        return value
    for c in range(nc):  # the increments' own curvature
        for k in range(7):
            if dofs[c, k] < 0:
                continue
            for m in range(7):
                if dofs[c, m] >= 0:
                    acc = 0.0
                    for r in range(3):
                        acc += dz_dy[c, r] * hs[c, r, k, m]
                    hessian[dofs[c, k], dofs[c, m]] += coef * acc
    for k in range(3):
        hessian[t0 + k, t0 + k] += coef * (ct * hx[0, k] - st * hx[1, k])
    mix = np.empty(7)
    for a in range(nc):  # the chain's curvature through the angles: Jᵀ ∇²Z J
        ja = jacs[a, 0]
        for b in range(nc):
            h_ab = coef * (-suffix_z[max(a, b) + 1] - t_z)
            _outer(hessian, dofs[a], ja, dofs[b], jacs[b, 0], h_ab)
        for c in range(a + 1, nc):  # ∂²Z/∂α_a∂t_c = (−sin θ_c, −cos θ_c)
            for k in range(7):
                mix[k] = -sin_b[c] * jacs[c, 1, k] - cos_b[c] * jacs[c, 2, k]
            _outer(hessian, dofs[a], ja, dofs[c], mix, coef)
            _outer(hessian, dofs[c], mix, dofs[a], ja, coef)
        for k in range(3):  # ∂²Z/∂α_a∂x_top
            m_top = coef * (-st * gx[0, k] - ct * gx[1, k])
            for j in range(7):
                if dofs[a, j] >= 0:
                    hessian[dofs[a, j], t0 + k] += m_top * ja[j]
                    hessian[t0 + k, dofs[a, j]] += m_top * ja[j]
    return value


@kernel
def _outer(
    hessian: np.ndarray, rows: np.ndarray, u: np.ndarray, cols: np.ndarray, v: np.ndarray, s: float
) -> None:
    """hessian[rows, cols] += s u vᵀ over the valid (≥ 0) indices."""
    for i in range(7):
        if rows[i] < 0 or u[i] == 0.0:
            continue
        for j in range(7):
            if cols[j] >= 0:
                hessian[rows[i], cols[j]] += s * u[i] * v[j]
