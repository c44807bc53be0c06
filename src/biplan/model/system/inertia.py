"""Mass matrix, inertia force and kinetic energy of a tube as data (Numba; MODEL §13).

The compiled counterpart of :mod:`biplan.model.inertia`: the same quadrature
(:mod:`.quadrature`: the edge midpoints of every module's triangles, weighted by a third of
their area), with the derivatives written by hand through the chain of module frames
(:mod:`.inertia_chain`, :mod:`.increments`), under every chain reading.

The sums over the points are evaluated in their rigid-body form (an algebraic identity, not an
approximation): the points of element e of module m sit at c_b + R(Θ_b) ρ_k with c_b their
weighted centre, Θ_b = θ_m + φ_e (gradient g_b(q), ∇²Θ_b = Σ_c ∇²α_c), Σ w_k ρ_k = 0 and
J ρ ⊥ ρ, so::

    M(q) = Σ_k w_k J_kᵀ J_k = Σ_b m_b J_cᵀ J_c + I_b g_b g_bᵀ
    M q̈ + c(q, q̇) = Σ_k w_k J_kᵀ (J_k q̈ + (∂²p_k)[q̇, q̇]) = Σ_b m_b J_cᵀ c̈_b + I_b g_b Θ̈_b
    T = ½ q̇ᵀ M q̇

with m_b, I_b the mass and polar moment of the body's points (:func:`.quadrature.bodies`),
c̈_b = J_c q̈ + (∂²c_b)[q̇, q̇] and Θ̈_b = g_b·q̈ + q̇ᵀ ∇²Θ_b q̇. A centre is
c_b = Σ_j R(θ_j) t_j over the terms of its chain (the connectors below the module, then the
centre's own offset in the module frame), so the exact derivative of the inertia rows of a
step (:func:`add_inertia`: q̇ and q̈ affine in q) needs the increments up to their third
derivatives (:func:`.increments.increment3`).
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.inertia_chain import centre_hessian, curved_rows, path, terms
from biplan.model.system.quadrature import bodies
from biplan.model.system.tables import SystemData

__all__ = [
    "add_inertia",
    "inertia_force",
    "kinetic_energy",
    "mass_matrix",
    "step_data",
]


@kernel
def _local(u: np.ndarray, dofs: np.ndarray, out: np.ndarray) -> None:  # type: ignore[type-arg]
    for k in range(7):
        out[k] = u[dofs[k]] if dofs[k] >= 0 else 0.0


@kernel
def _inertia(
    d: SystemData,
    q: np.ndarray,
    v: np.ndarray,
    a: np.ndarray,
    surface_density: float,
    c_v: float,
    c_m: float,
    mode: int,
) -> tuple:  # type: ignore[type-arg]
    """The rigid-body form of the quadrature sums (module docstring): with the body centres
    c_b and the body angles Θ_b = θ_m + φ_e (gradient g_b, ∇²Θ_b = Σ_c ∇²α_c over the
    connectors below), Σ_k w_k J_kᵀ J_k = Σ_b m_b J_cᵀ J_c + I_b g_b g_bᵀ and
    Σ_k w_k J_kᵀ (J_k a + (∂²p_k)[v, v]) = Σ_b m_b J_cᵀ c̈_b + I_b g_b Θ̈_b, c̈_b =
    J_c a + (∂²c_b)[v, v], Θ̈_b = g_b·a + vᵀ∇²Θ_b v (the offsets of the points from the
    centre have zero weighted mean, and J ρ ⊥ ρ).

    ``mode`` 0: (0, M (n_q, n_q)); 1: (F = M a + c(q, v), 0); 3: ([½ vᵀ M v, aᵀ M v], 0);
    2: (F, dF/dq) for v = v(q) and a = a(q) affine in q, ∂v/∂q = c_v I, ∂a/∂q = c_M I: the
    exact derivative of the inertia rows of a step (third derivatives of the chain included)::

        dF/dq = Σ_b m_b [∇²(λ_b·c_b) + J_cᵀ (∂c̈/∂q + c_v ∂c̈/∂q̇ + c_M J_c)]
                + I_b [Θ̈_b ∇²Θ_b + g_b (∂Θ̈/∂q + c_v ∂Θ̈/∂q̇ + c_M g_b)ᵀ]

    with λ_b = m_b c̈_b held fixed in the Hessian. Through a curved angle α_i (∇²α_i ≠ 0,
    R3 ``EDGE_FIT``) c̈_b also moves with the rates of the frames above i: ∂θ̇/∂x_i = ∇²α_i v
    and ∂θ̈/∂x_i = ∇²α_i a + ∂/∂x (vᵀ∇²α_i v) + 2 c_v ∇²α_i v.
    """
    n, nc, n_q = d.ref.shape[0], d.conn_upper.shape[0], d.sizes[0]
    mass, centre, moment = bodies(d, surface_density)
    dofs, g, ha, a_third, t, jt, ht, tvv, th, parent = terms(d, q, v, centre)
    n_t = t.shape[0]
    force = np.zeros(n_q)
    mat = np.zeros((n_q, n_q) if mode in (0, 2) else (0, 0))
    # per term: rates of its frame angle, ṫ, ẗ and, for the Jacobian, ∂ṫ/∂x = (∂²t)[v, ·]
    # and (∂²t)[a, ·]; per curved connector angle: ∇²α v, vᵀ∇²α v and ∂θ̈/∂x (``bend``)
    th_d = np.zeros(n_t)
    th_dd = np.zeros(n_t)
    mod_d = np.zeros(n)
    mod_dd = np.zeros(n)
    t_d = np.zeros((n_t, 2))
    t_dd = np.zeros((n_t, 2))
    hv = np.zeros((n_t, 2, 7))
    hav = np.zeros((n_t, 2, 7))
    curved = np.zeros(n_t, dtype=np.bool_)
    a_vv = np.zeros(n_t)
    a_v = np.zeros((n_t, 7))  # ∇²α v
    bend = np.zeros((n_t, 7))
    vx = np.zeros(7)
    ax = np.zeros(7)
    for j in range(n_t):
        _local(v, dofs[j], vx)
        _local(a, dofs[j], ax)
        if j < nc:
            lo, up = d.conn_lower[j], d.conn_upper[j]
            th_d[j] = 0.0 if lo < 0 else mod_d[lo]
            th_dd[j] = 0.0 if lo < 0 else mod_dd[lo]
            curved[j] = np.any(ha[j] != 0.0)
            if curved[j]:
                for k in range(7):
                    sv, sa = 0.0, 0.0
                    for i in range(7):
                        sv += ha[j, k, i] * vx[i]
                        sa += ha[j, k, i] * ax[i]
                    a_v[j, k] = sv
                    a_vv[j] += sv * vx[k]
                    bend[j, k] = sa + a_third[j, k] + 2.0 * c_v * sv
            mod_d[up] = th_d[j] + g[j] @ vx
            mod_dd[up] = th_dd[j] + g[j] @ ax + a_vv[j]
        else:
            m = (j - nc) // 2
            th_d[j], th_dd[j] = mod_d[m], mod_dd[m]
        for r in range(2):
            t_d[j, r] = jt[j, r] @ vx
            t_dd[j, r] = jt[j, r] @ ax
            for k in range(7):
                sv, sa = 0.0, 0.0
                for i in range(7):
                    sv += ht[j, r, i, k] * vx[i]
                    sa += ht[j, r, i, k] * ax[i]
                hv[j, r, k] = sv
                hav[j, r, k] = sa
                t_dd[j, r] += sv * vx[k]
    jc = np.zeros((2, n_q))
    dc = np.zeros((2, n_q))
    g_body = np.zeros(n_q)
    chain = np.zeros(nc + 1, dtype=np.int64)
    rt = np.zeros((nc + 1, 2))
    tdd = np.zeros((nc + 1, 2))
    uu = np.zeros((nc + 1, 2))
    suf = np.zeros((nc + 2, 2))  # Σ_{p' > p} R t
    suf_dd = np.zeros((nc + 2, 2))
    suf_u = np.zeros((nc + 2, 2))
    for b in range(2 * n):
        m = b // 2
        size = path(parent, d, m, nc, b, chain)
        # per term: R t, its second rate T̈ and ∂T̈/∂θ̇ = −2θ̇ R t + 2 J R ṫ; suffix sums
        for p in range(size):
            j = chain[p]
            cs, sn = math.cos(th[j]), math.sin(th[j])
            w, wd = th_d[j], th_dd[j]
            rtz, rts = cs * t[j, 0] - sn * t[j, 1], sn * t[j, 0] + cs * t[j, 1]
            rdz, rds = cs * t_d[j, 0] - sn * t_d[j, 1], sn * t_d[j, 0] + cs * t_d[j, 1]
            rddz, rdds = cs * t_dd[j, 0] - sn * t_dd[j, 1], sn * t_dd[j, 0] + cs * t_dd[j, 1]
            rt[p, 0], rt[p, 1] = rtz, rts
            tdd[p, 0] = -wd * rts - w * w * rtz - 2.0 * w * rds + rddz
            tdd[p, 1] = wd * rtz - w * w * rts + 2.0 * w * rdz + rdds
            uu[p, 0] = -2.0 * w * rtz - 2.0 * rds
            uu[p, 1] = -2.0 * w * rts + 2.0 * rdz
        suf[size, :] = 0.0
        suf_dd[size, :] = 0.0
        suf_u[size, :] = 0.0
        for p in range(size - 1, -1, -1):
            for r in range(2):
                suf[p, r] = suf[p + 1, r] + rt[p, r]
                suf_dd[p, r] = suf_dd[p + 1, r] + tdd[p, r]
                suf_u[p, r] = suf_u[p + 1, r] + uu[p, r]
        cdd0, cdd1 = suf_dd[0, 0], suf_dd[0, 1]
        # J_c = Σ_j R_j ∂t_j/∂x + Σ_i ∇α_i ⊗ J S_i
        jc[:, :] = 0.0
        g_body[:] = 0.0
        bent = False
        for p in range(size):
            j = chain[p]
            bent = bent or curved[j]
            cs, sn = math.cos(th[j]), math.sin(th[j])
            sz, ss = suf[p + 1, 0], suf[p + 1, 1]
            for k in range(7):
                col = dofs[j, k]
                if col < 0:
                    continue
                jc[0, col] += cs * jt[j, 0, k] - sn * jt[j, 1, k] - g[j, k] * ss
                jc[1, col] += sn * jt[j, 0, k] + cs * jt[j, 1, k] + g[j, k] * sz
                g_body[col] += g[j, k]
        g_body[3 * m + 1 + b % 2] += 1.0
        mb, ib = mass[b], moment[b]
        ga = g_body @ a
        if mode == 3:  # ½ vᵀ M v and aᵀ M v
            gv = g_body @ v
            jv0, jv1, ja0, ja1 = jc[0] @ v, jc[1] @ v, jc[0] @ a, jc[1] @ a
            force[0] += 0.5 * (mb * (jv0 * jv0 + jv1 * jv1) + ib * gv * gv)
            force[1] += mb * (ja0 * jv0 + ja1 * jv1) + ib * ga * gv
            continue
        if mode == 0:
            for i in range(n_q):
                for k in range(n_q):
                    mat[i, k] += mb * (jc[0, i] * jc[0, k] + jc[1, i] * jc[1, k])
                    mat[i, k] += ib * g_body[i] * g_body[k]
            continue
        theta_dd = ga  # Θ̈_b = g_b·a + Σ vᵀ∇²α v
        for p in range(size - 1):
            theta_dd += a_vv[chain[p]]
        for i in range(n_q):
            force[i] += mb * (jc[0, i] * cdd0 + jc[1, i] * cdd1) + ib * g_body[i] * theta_dd
        if mode == 1:
            continue
        # ∂c̈/∂q + c_v ∂c̈/∂v + c_M J_c
        dc[:, :] = 0.0
        for p in range(size):
            j = chain[p]
            cs, sn = math.cos(th[j]), math.sin(th[j])
            w, wd = th_d[j], th_dd[j]
            for k in range(7):
                col = dofs[j, k]
                if col < 0:
                    continue
                # local: θ̈ J ∂t − θ̇² ∂t + 2θ̇ J (∂²t)[v] + (∂²t)[a] + ∂(vᵀ∂²t v)
                #        + c_v (2θ̇ J ∂t + 2 (∂²t)[v]), then rotated by R_j
                lz = (
                    -wd * jt[j, 1, k]
                    - w * w * jt[j, 0, k]
                    - 2.0 * w * hv[j, 1, k]
                    + hav[j, 0, k]
                    + tvv[j, 0, k]
                    + c_v * (-2.0 * w * jt[j, 1, k] + 2.0 * hv[j, 0, k])
                )
                ls = (
                    wd * jt[j, 0, k]
                    - w * w * jt[j, 1, k]
                    + 2.0 * w * hv[j, 0, k]
                    + hav[j, 1, k]
                    + tvv[j, 1, k]
                    + c_v * (2.0 * w * jt[j, 0, k] + 2.0 * hv[j, 1, k])
                )
                # through α_j: J Σ_{p' > p} T̈ + c_v Σ_{p' > p} ∂T̈/∂θ̇
                gz = -suf_dd[p + 1, 1] + c_v * suf_u[p + 1, 0]
                gs = suf_dd[p + 1, 0] + c_v * suf_u[p + 1, 1]
                dc[0, col] += cs * lz - sn * ls + g[j, k] * gz
                dc[1, col] += sn * lz + cs * ls + g[j, k] * gs
                if curved[j]:  # the rates θ̇, θ̈ of the frames above: ∂T̈/∂θ̇ and J R t
                    dc[0, col] += a_v[j, k] * suf_u[p + 1, 0] - bend[j, k] * suf[p + 1, 1]
                    dc[1, col] += a_v[j, k] * suf_u[p + 1, 1] + bend[j, k] * suf[p + 1, 0]
        lam_z, lam_s = mb * cdd0, mb * cdd1
        for i in range(n_q):
            for k in range(n_q):
                mat[i, k] += mb * (
                    jc[0, i] * (dc[0, k] + c_m * jc[0, k]) + jc[1, i] * (dc[1, k] + c_m * jc[1, k])
                )
                mat[i, k] += c_m * ib * g_body[i] * g_body[k]
        if bent:
            args = (ib, theta_dd, lam_z, lam_s)
            curved_rows(chain, size, dofs, ha, bend, curved, g_body, args, suf, mat)
        centre_hessian(chain, size, dofs, g, jt, ht, th, lam_z, lam_s, suf, mat)
    return force, mat


@kernel
def mass_matrix(d: SystemData, q: np.ndarray, surface_density: float) -> np.ndarray:  # type: ignore[type-arg]
    """M(q) = Σ_k w_k J_kᵀ J_k, (n_q, n_q) [t·mm² per unit² of q]."""
    z = np.zeros_like(q)
    return _inertia(d, q, z, z, surface_density, 0.0, 0.0, 0)[1]


@kernel
def inertia_force(
    d: SystemData, q: np.ndarray, v: np.ndarray, a: np.ndarray, surface_density: float
) -> np.ndarray:  # type: ignore[type-arg]
    """M(q) q̈ + c(q, q̇) [N] for q̇ = v, q̈ = a: the generalized inertia force (n_q,)."""
    return _inertia(d, q, v, a, surface_density, 0.0, 0.0, 1)[0]


@kernel
def kinetic_energy(d: SystemData, q: np.ndarray, v: np.ndarray, surface_density: float) -> float:  # type: ignore[type-arg]
    """T = ½ q̇ᵀ M(q) q̇ [N·mm]."""
    return _inertia(d, q, v, v, surface_density, 0.0, 0.0, 3)[0][0]


@kernel
def kinetic_and_work(
    d: SystemData, q: np.ndarray, v: np.ndarray, u: np.ndarray, surface_density: float
) -> tuple[float, float]:
    """(½ vᵀ M(q) v [N·mm], uᵀ M(q) v) in one pass."""
    out = _inertia(d, q, v, u, surface_density, 0.0, 0.0, 3)[0]
    return out[0], out[1]


@kernel
def step_data(
    q_base: np.ndarray,
    v_base: np.ndarray,
    a_base: np.ndarray,
    c_v: float,
    c_m: float,
    surface_density: float,
) -> np.ndarray:  # type: ignore[type-arg]
    """The data of one implicit step for :func:`add_inertia`, [c_v, c_M, μ, q̃, ṽ, Ã]:
    the velocity v(q) = ṽ + c_v (q − q̃) and the acceleration of the inertia force
    A(q) = q̈(q) + α_R v(q) = Ã + c_M (q − q̃) are affine in the step's end point q."""
    n_q = q_base.shape[0]
    out = np.empty(3 + 3 * n_q)
    out[0], out[1], out[2] = c_v, c_m, surface_density
    out[3 : 3 + n_q] = q_base
    out[3 + n_q : 3 + 2 * n_q] = v_base
    out[3 + 2 * n_q :] = a_base
    return out


@kernel
def add_inertia(
    d: SystemData,
    q: np.ndarray,
    data: np.ndarray,
    r: np.ndarray,
    jac: np.ndarray,
    second: bool,
) -> None:
    """Add the inertia force M(q) A(q) + c(q, v(q)) to the q rows of ``r`` and, if
    ``second``, its exact derivative in q to the q block of ``jac``, for the step ``data`` of
    :func:`step_data`."""
    n_q = q.shape[0]
    c_v, c_m, mu = data[0], data[1], data[2]
    dq = q - data[3 : 3 + n_q]
    v = data[3 + n_q : 3 + 2 * n_q] + c_v * dq
    a = data[3 + 2 * n_q :] + c_m * dq
    f, mat = _inertia(d, q, v, a, mu, c_v, c_m, 2 if second else 1)
    for i in range(n_q):
        r[i] += f[i]
    if second:
        for i in range(n_q):
            for j in range(n_q):
                jac[i, j] += mat[i, j]
