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

The increment is t_c = P + R(α_c)(−P) + [u_L, 0] + R(α_c)[δ_c, 0] (P the pivot of the lower
element carrying the module above, α_c its angle, δ_c = γ + z_L(0) − z_U(0) the seam offset),
so its local Hessians have a closed form in ∇δ_c and the diagonal ∇²δ_c: they enter the
Hessian of Z directly (:func:`load_point`), never as 3 × 7 × 7 arrays.
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import inlined_kernel, kernel
from biplan.model.system import readings
from biplan.model.system.elements import Quad, angles, edge, pair, pivots, rotated
from biplan.model.system.tables import SystemData

__all__ = [
    "load_height",
    "load_point",
    "reference_height",
]


@inlined_kernel
def _gather(q: np.ndarray, dofs: np.ndarray, c: int, x: np.ndarray) -> None:
    """Fills ``x`` (7,) with connector c's coordinates x_c (0 at the clamp's), ``dofs``: the
    table ``conn_dofs``."""
    for k in range(7):
        x[k] = 0.0 if dofs[c, k] < 0 else q[dofs[c, k]]


@inlined_kernel
def _frame(
    x: np.ndarray,
    c: int,
    p_lo: Quad,
    p_up: Quad,
    pitch: float,
    seam: np.ndarray,
    height: float,
    gd: np.ndarray,
    hd: np.ndarray,
    jacs: np.ndarray,
    row: int,
) -> tuple[float, float, float, float]:
    """(α, t_z, t_s, δ) of connector c's frame increment at x_c = ``x``; fills ``gd`` and
    ``hd`` (7,) with ∇δ and the diagonal of ∇²δ and ``jacs[row]`` (3, 7) with J_c =
    ∂y_c/∂x_c. The connector: row c of the table ``seam`` (:class:`~.tables.SystemData`
    ``conn_seam``), its seam ``height`` and the :func:`~.elements.pivots` of its lower and
    upper module (:mod:`.elements`: no view, no SystemData per connector)."""
    for k in range(7):
        gd[k] = 0.0
        hd[k] = 0.0
    e, eu, el, rigid = seam[c, 0], seam[c, 1], seam[c, 2], seam[c, 3]
    t_lo, t_up = angles(x[1], x[2]), angles(x[4], x[5])
    # δ = γ + z_L(0) − z_U(0): its gradient and (diagonal) Hessian in x_c
    h, h1, h2 = edge(x[3], t_up, p_up, eu, 0.0, 0.0)
    delta = x[6] - h
    gd[3] -= 1.0
    gd[4 + eu] -= h1
    hd[4 + eu] -= h2
    gd[6] = 1.0
    if rigid:
        delta += height
    else:
        h, h1, h2 = edge(x[0], t_lo, p_lo, el, pitch, 0.0)
        delta += h
        gd[0] += 1.0
        gd[1 + el] += h1
        hd[1 + el] += h2
    if e < 0:  # no frame angle: y_c = (0, δ, 0)
        for k in range(7):
            jacs[row, 0, k] = 0.0
            jacs[row, 1, k] = gd[k]
            jacs[row, 2, k] = 0.0
        return 0.0, delta, 0.0, delta
    ia = 1 + e
    alpha = x[ia]
    pz, ps = pair(p_lo, e)
    ca, sa = pair(t_lo, e)  # cos, sin α
    tz = pz - (ca * pz - sa * ps) + x[0] + ca * delta
    ts = ps - (sa * pz + ca * ps) + sa * delta
    for k in range(7):
        jacs[row, 0, k] = 0.0
        jacs[row, 1, k] = ca * gd[k]
        jacs[row, 2, k] = sa * gd[k]
    jacs[row, 0, ia] = 1.0
    jacs[row, 1, 0] += 1.0
    jacs[row, 1, ia] += sa * pz + ca * ps - sa * delta
    jacs[row, 2, ia] += -ca * pz + sa * ps + ca * delta
    return alpha, tz, ts, delta


@inlined_kernel
def _local_hessian(
    c: int,
    dofs: np.ndarray,
    e: int,
    p_lo: Quad,
    alpha: float,
    ct: float,
    st: float,
    delta: float,
    gd: np.ndarray,
    hd: np.ndarray,
    hessian: np.ndarray,
    coef: float,
) -> None:
    """Adds ``coef`` Σ_k ∂Z/∂y_k ∇²y_k of connector c (α is linear in x_c) to ``hessian``:
    with ∂Z/∂t = (cos θ_c, −sin θ_c) and C, S = cos, sin(θ_c + α_c), it is C ∇²δ on the
    diagonal, −S ∇δ in the row and column of α_c and C (P_z − δ) − S P_s at (α_c, α_c)
    (e: the frame element, ``conn_seam[c, 0]``; the rest as :func:`_frame` takes and leaves
    it)."""
    if e < 0:  # t_z = δ
        for k in range(7):
            if dofs[c, k] >= 0:
                hessian[dofs[c, k], dofs[c, k]] += coef * ct * hd[k]
        return
    pz, ps = pair(p_lo, e)
    ca, sa = math.cos(alpha), math.sin(alpha)
    cc, ss = ct * ca - st * sa, st * ca + ct * sa
    g = dofs[c, 1 + e]
    for k in range(7):
        dof = dofs[c, k]
        if dof < 0:
            continue
        hessian[dof, dof] += coef * cc * hd[k]
        hessian[g, dof] -= coef * ss * gd[k]
        hessian[dof, g] -= coef * ss * gd[k]
    hessian[g, g] += coef * (cc * (pz - delta) - ss * ps)


@inlined_kernel
def _connector(
    d: SystemData,  # type: ignore[type-arg]
    x: np.ndarray,
    c: int,
    local: np.ndarray,
    jacs: np.ndarray,
    row: int,
) -> tuple[float, float, float, float]:
    """:func:`_frame` of connector c of ``d`` at x_c = ``x`` (``local`` (2, 7): scratch for
    ∇δ and diag ∇²δ), for the paths off the element loops."""
    lo, up = max(d.conn_lower[c], 0), d.conn_upper[c]
    p_lo, p_up = pivots(d.ref, lo), pivots(d.ref, up)
    height = d.conn_seam_height[c]
    return _frame(
        x, c, p_lo, p_up, d.scalars[0], d.conn_seam, height, local[0], local[1], jacs, row
    )


@kernel
def _dofs(d: SystemData, c: int) -> np.ndarray:  # type: ignore[type-arg]
    """Global coordinate of each of connector c's 7 local coordinates (−1: the clamp's)."""
    return d.conn_dofs[c].copy()


@kernel
def _increment(x: np.ndarray, d: SystemData, c: int, want: bool) -> tuple:  # type: ignore[type-arg]
    """(α, t_z, t_s), J (3, 7), Hessians (3, 7, 7) (zeros unless ``want``) of connector c's
    frame increment at x_c = ``x``: :func:`_frame` with its local Hessians as dense arrays
    (for :mod:`.inertia`; the load point adds them to ∇²Z directly, :func:`_local_hessian`)."""
    local = np.empty((2, 7))
    jac = np.empty((1, 3, 7))
    hess = np.zeros((3, 7, 7))
    alpha, tz, ts, delta = _connector(d, x, c, local, jac, 0)
    gd, hd = local[0], local[1]
    e = d.conn_seam[c, 0]
    if want and e < 0:
        for k in range(7):
            hess[1, k, k] = hd[k]
    elif want:
        ia, lo = 1 + e, d.conn_lower[c]
        pz, ps = pair(pivots(d.ref, lo), e)
        ca, sa = math.cos(alpha), math.sin(alpha)
        for k in range(7):
            hess[1, k, k] += ca * hd[k]
            hess[2, k, k] += sa * hd[k]
            hess[1, ia, k] -= sa * gd[k]
            hess[1, k, ia] -= sa * gd[k]
            hess[2, ia, k] += ca * gd[k]
            hess[2, k, ia] += ca * gd[k]
        hess[1, ia, ia] += ca * pz - sa * ps - ca * delta
        hess[2, ia, ia] += sa * pz + ca * ps - sa * delta
    return alpha, tz, ts, jac[0].copy(), hess


@inlined_kernel
def _top(
    q: np.ndarray, m: int, ref: np.ndarray, weights: np.ndarray, g: np.ndarray, hd: np.ndarray
) -> tuple[float, float]:
    """X̄ = Σ ω_i X_i of the top module m (z, s); fills ``g`` (2, 3) with its gradient and
    ``hd`` (2, 3) with its Hessian diagonal in x_top = q[3m : 3m + 3]."""
    u = q[3 * m]
    trig = angles(q[3 * m + 1], q[3 * m + 2])
    zbar = sbar = 0.0
    for r in range(2):
        for k in range(3):
            g[r, k] = 0.0
            hd[r, k] = 0.0
    for i in range(7):
        wi = weights[i]
        if wi == 0.0:
            continue
        e = 0 if i < 4 else 1
        z, s, dz, ds, d2z, d2s = rotated(u, trig, ref, m, i, e)
        zbar += wi * z
        sbar += wi * s
        g[0, 0] += wi
        g[0, 1 + e] += wi * dz
        g[1, 1 + e] += wi * ds
        hd[0, 1 + e] += wi * d2z
        hd[1, 1 + e] += wi * d2s
    return zbar, sbar


@kernel
def _chain_end(d: SystemData, q: np.ndarray) -> tuple[float, float, float]:  # type: ignore[type-arg]
    """(θ, p_z, p_s): the top module's frame at q, composed up the chain (value only)."""
    if d.flags[2] == 1 or d.flags[3] == 1:
        return readings.chain_end(d, q)
    nc = d.conn_upper.shape[0]
    x, local, jacs = np.empty(7), np.empty((2, 7)), np.empty((1, 3, 7))
    theta, pz, ps = 0.0, 0.0, 0.0
    for c in range(nc):
        _gather(q, d.conn_dofs, c, x)
        alpha, tz, ts, _ = _connector(d, x, c, local, jacs, 0)
        ct, st = math.cos(theta), math.sin(theta)
        pz += ct * tz - st * ts
        ps += st * tz + ct * ts
        theta += alpha
    return theta, pz, ps


@kernel(inline="always")
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
    # a run-time flag: one compilation (:mod:`.assemble`)
    return _load_point(d, q, gradient, hessian, coef, bool(second))


@kernel
def _load_point(
    d: SystemData,
    q: np.ndarray,
    gradient: np.ndarray,
    hessian: np.ndarray,
    coef: float,
    second: bool,
) -> float:
    """:func:`load_point`."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    if d.flags[2] == 1 or d.flags[3] == 1:  # R3 EDGE_FIT or R1 PAPER: dense increments
        top = np.empty((2, 2, 3))
        zbar, sbar = _top(q, n - 1, d.ref, d.load_weights, top[0], top[1])
        data = (zbar, sbar, top[0], top[1])
        return readings.load_point(d, q, data, gradient, hessian, coef, second)
    dofs = d.conn_dofs
    jacs = np.empty((nc, 3, 7))
    # per connector: cos θ_c, sin θ_c, [R(θ_c) t_c]_z, [R(θ_c) t_c]_s, and the suffix sums
    # Σ_{c' ≥ c} of the last two
    chain = np.empty((6, nc + 1))
    cos_b, sin_b, v_z, v_s = chain[0], chain[1], chain[2], chain[3]
    suffix_z, suffix_s = chain[4], chain[5]
    local = np.empty((3, 7))  # x_c, ∇δ_c, diag ∇²δ_c
    x, gd, hd = local[0], local[1], local[2]
    theta = 0.0
    ref, pitch, seam = d.ref, d.scalars[0], d.conn_seam
    for c in range(nc):  # (:func:`_connector` written out: no SystemData per connector)
        p_lo = pivots(ref, max(d.conn_lower[c], 0))
        p_up = pivots(ref, d.conn_upper[c])
        _gather(q, dofs, c, x)
        height = d.conn_seam_height[c]
        alpha, tz, ts, delta = _frame(x, c, p_lo, p_up, pitch, seam, height, gd, hd, jacs, c)
        ct, st = math.cos(theta), math.sin(theta)
        cos_b[c], sin_b[c] = ct, st
        v_z[c] = ct * tz - st * ts
        v_s[c] = st * tz + ct * ts
        theta += alpha
        if second:  # local part: Σ_k ∂Z/∂y_k ∇²y_k
            _local_hessian(c, dofs, seam[c, 0], p_lo, alpha, ct, st, delta, gd, hd, hessian, coef)
    top = np.empty((2, 2, 3))  # ∇X̄ and the diagonal of ∇²X̄ in x_top
    gx, hx = top[0], top[1]
    t0 = 3 * n - 3  # x_top = q[t0 : t0 + 3]
    zbar, sbar = _top(q, n - 1, d.ref, d.load_weights, gx, hx)
    ct, st = math.cos(theta), math.sin(theta)
    t_z = ct * zbar - st * sbar  # [R(θ) X̄]_z
    t_theta = -st * zbar - ct * sbar
    # ∂Z/∂α_a = −Σ_{c > a} [R(θ_c) t_c]_s + ∂[R(θ) X̄]_z/∂θ (suffix sums)
    suffix_s[nc] = suffix_z[nc] = 0.0
    for c in range(nc - 1, -1, -1):
        suffix_s[c] = suffix_s[c + 1] + v_s[c]
        suffix_z[c] = suffix_z[c + 1] + v_z[c]
    value = suffix_z[0] + t_z
    gradient[:] = 0.0
    for c in range(nc):
        g_alpha = -suffix_s[c + 1] + t_theta
        for k in range(7):
            if dofs[c, k] >= 0:
                gradient[dofs[c, k]] += (
                    jacs[c, 0, k] * g_alpha + jacs[c, 1, k] * cos_b[c] - jacs[c, 2, k] * sin_b[c]
                )
    for k in range(3):
        gradient[t0 + k] += ct * gx[0, k] - st * gx[1, k]
    if not second:
        return value
    # chain part: Jᵀ ∇²Z J
    for c in range(nc):  # ∂²Z/∂θ∂t_c J_c, kept in J_c's first row (α_c's, now used)
        for k in range(7):
            jacs[c, 0, k] = -sin_b[c] * jacs[c, 1, k] - cos_b[c] * jacs[c, 2, k]
    for k in range(3):
        hessian[t0 + k, t0 + k] += coef * (ct * hx[0, k] - st * hx[1, k])
    frame = d.conn_seam[:, 0]  # the element carrying each frame angle, -1 none
    for a in range(nc):
        if frame[a] < 0:
            continue
        ia = dofs[a, 1 + frame[a]]
        for b in range(nc):
            if frame[b] < 0:
                continue
            ib = dofs[b, 1 + frame[b]]
            hessian[ia, ib] += coef * (-suffix_z[max(a, b) + 1] - t_z)
        for k in range(3):  # ∂²Z/∂θ∂x_top
            m_top = coef * (-st * gx[0, k] - ct * gx[1, k])
            hessian[ia, t0 + k] += m_top
            hessian[t0 + k, ia] += m_top
        for c in range(a + 1, nc):
            for k in range(7):
                if dofs[c, k] >= 0:
                    u = coef * jacs[c, 0, k]
                    hessian[ia, dofs[c, k]] += u
                    hessian[dofs[c, k], ia] += u
    return value


@kernel
def load_height(d: SystemData, q: np.ndarray) -> float:  # type: ignore[type-arg]
    """Z(q): the load point's height [mm] (value only, under either R3 attachment)."""
    n = d.ref.shape[0]
    theta, pz, _ = _chain_end(d, q)
    top = np.empty((2, 2, 3))
    zbar, sbar = _top(q, n - 1, d.ref, d.load_weights, top[0], top[1])
    return pz + math.cos(theta) * zbar - math.sin(theta) * sbar


@kernel
def reference_height(d: SystemData) -> float:
    """Z(0): the load point at q = 0 (depends on the geometry only)."""
    return load_height(d, np.zeros(d.sizes[0]))
