"""The quadrature of a tube's inertia as data (Numba; MODEL §13): points, weights and bodies.

The compiled counterpart of the quadrature of :mod:`biplan.model.inertia`: the edge midpoints
p_k of the triangles ABC, ACD and EFG of every module, weights w_k = μ A_tri / 3. Module m's
nodes sit at R(θ_m) X(x_m) + P_m in the global plane, the frame (θ_m, P_m) composed from the
increments y_c = (α_c, t_c) of the connectors below m::

    θ_up = θ_lo + α_c,   P_up = P_lo + R(θ_lo) t_c

(module 0's frame is the identity without a base connector). :func:`quadrature` gives the
points, their Jacobians (with J = [[0, −1], [1, 0]], ∂R/∂θ = J R: ∂p/∂x_c = ∇α_c J (p − P_up)
+ R(θ_lo) ∂t_c, ∂p/∂X = R(θ_m)) and their velocity-quadratic terms (∂²p)[v, v] (along q + s v:
d²/ds² [R(θ) t] = −θ̇² R t + θ̈ J R t + 2 θ̇ J R ṫ + R ẗ, summed up the chain, with θ̈ =
Σ vᵀ∂²α v; α_c is linear in q on the default chain, not under R3 ``EDGE_FIT``).
:func:`bodies` lumps the points of every element into a rigid body (mass, centre, polar
moment), the form in which :mod:`.inertia` sums them.
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.chainterm import _dofs
from biplan.model.system.elements import node
from biplan.model.system.increments import increment3
from biplan.model.system.tables import SystemData

__all__ = ["EDGES", "TRIANGLES", "bodies", "quadrature", "quadrature_weights"]

#: Quadrature points of a module: the edges (node, node) of the triangles ABC, ACD (element 0)
#: and EFG (element 1), in the order of :data:`biplan.model.inertia.TRIANGLES`.
EDGES = np.array(
    [[0, 1], [1, 2], [2, 0], [0, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 4]], dtype=np.int64
)
#: Triangles of a module by node index.
TRIANGLES = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]], dtype=np.int64)


@kernel
def quadrature_weights(d: SystemData, surface_density: float) -> np.ndarray:  # type: ignore[type-arg]
    """w_k = μ A_tri / 3 [t] of each quadrature point (N·9,) (reference areas: the frames
    are rigid, so the module frame's areas are the global ones)."""
    n = d.ref.shape[0]
    w = np.zeros(9 * n)
    for m in range(n):
        ref = d.ref[m]
        for t in range(3):
            a, b, c = TRIANGLES[t, 0], TRIANGLES[t, 1], TRIANGLES[t, 2]
            uz, us = ref[b, 0] - ref[a, 0], ref[b, 1] - ref[a, 1]
            vz, vs = ref[c, 0] - ref[a, 0], ref[c, 1] - ref[a, 1]
            area = 0.5 * abs(uz * vs - us * vz)
            for j in range(3):
                w[9 * m + 3 * t + j] = surface_density * area / 3.0
    return w


@kernel
def _parents(d: SystemData) -> np.ndarray:  # type: ignore[type-arg]
    """The connector below each module (−1: the module's frame is the identity)."""
    parent = np.full(d.ref.shape[0], -1, dtype=np.int64)
    for c in range(d.conn_upper.shape[0]):
        parent[d.conn_upper[c]] = c
    return parent


@kernel
def quadrature(d: SystemData, q: np.ndarray, v: np.ndarray, jacobian: bool) -> tuple:  # type: ignore[type-arg]
    """(p (K, 2), ∂p/∂q (K, 2, n_q) or (0, 2, n_q), (∂²p)[v, v] (K, 2)) of the quadrature
    points p_k(q) [mm] (module docstring; K = 9 N, module-major as :data:`EDGES`)."""
    n, nc, n_q = d.ref.shape[0], d.conn_upper.shape[0], d.sizes[0]
    # module frames, their rates along v and the frames' second derivatives along v
    theta = np.zeros(n)
    pos = np.zeros((n, 2))
    th_dot = np.zeros(n)
    th_dd = np.zeros(n)
    pos_dd = np.zeros((n, 2))
    jacs = np.zeros((nc, 3, 7))
    dofs = np.zeros((nc, 7), dtype=np.int64)
    th_lo = np.zeros(nc)
    x = np.zeros(7)
    vx = np.zeros(7)
    ha = np.zeros((7, 7))
    avv, tvv, work = np.zeros(7), np.zeros((2, 7)), np.zeros((3, 7))
    t = np.zeros(2)
    hess = np.zeros((2, 7, 7))
    for c in range(nc):  # connectors run up the chain: the lower frame is already known
        dofs[c] = _dofs(d, c)
        for k in range(7):
            x[k] = 0.0 if dofs[c, k] < 0 else q[dofs[c, k]]
            vx[k] = 0.0 if dofs[c, k] < 0 else v[dofs[c, k]]
        jac = jacs[c]
        jac[:, :] = 0.0
        ha[:, :] = 0.0
        hess[:, :, :] = 0.0
        t[:] = 0.0
        avv[:] = 0.0
        tvv[:, :] = 0.0
        alpha = increment3(x, vx, d, c, jac[0], ha, avv, t, jac[1:], hess, tvv, work)
        tz, ts = t[0], t[1]
        lo, up = d.conn_lower[c], d.conn_upper[c]
        t0, pz, ps = 0.0, 0.0, 0.0
        w0, b0, az, as_ = 0.0, 0.0, 0.0, 0.0
        if lo >= 0:
            t0, pz, ps = theta[lo], pos[lo, 0], pos[lo, 1]
            w0, b0, az, as_ = th_dot[lo], th_dd[lo], pos_dd[lo, 0], pos_dd[lo, 1]
        th_lo[c] = t0
        ct, st = math.cos(t0), math.sin(t0)
        a_dot, a_dd = 0.0, 0.0
        tz_dot, ts_dot, tz_dd, ts_dd = 0.0, 0.0, 0.0, 0.0
        for i in range(7):
            a_dot += jac[0, i] * vx[i]
            tz_dot += jac[1, i] * vx[i]
            ts_dot += jac[2, i] * vx[i]
            for j in range(7):
                a_dd += ha[i, j] * vx[i] * vx[j]
                tz_dd += hess[0, i, j] * vx[i] * vx[j]
                ts_dd += hess[1, i, j] * vx[i] * vx[j]
        theta[up] = t0 + alpha
        th_dot[up] = w0 + a_dot
        th_dd[up] = b0 + a_dd
        rz, rs = ct * tz - st * ts, st * tz + ct * ts  # R t
        rdz, rds = ct * tz_dot - st * ts_dot, st * tz_dot + ct * ts_dot  # R ṫ
        pos[up, 0], pos[up, 1] = pz + rz, ps + rs
        # −θ̇² R t + θ̈ J R t + 2 θ̇ J R ṫ + R ẗ  (J (a, b) = (−b, a))
        pos_dd[up, 0] = az - w0 * w0 * rz - b0 * rs - 2.0 * w0 * rds + ct * tz_dd - st * ts_dd
        pos_dd[up, 1] = as_ - w0 * w0 * rs + b0 * rz + 2.0 * w0 * rdz + st * tz_dd + ct * ts_dd
    parent = _parents(d)
    k_all = 9 * n
    pts = np.zeros((k_all, 2))
    jac_out = np.zeros((k_all if jacobian else 0, 2, n_q))
    acc = np.zeros((k_all, 2))
    for m in range(n):
        xm = q[3 * m : 3 * m + 3]
        vm = v[3 * m : 3 * m + 3]
        ct, st = math.cos(theta[m]), math.sin(theta[m])
        w, wd = th_dot[m], th_dd[m]
        for e in range(9):
            i0, i1 = EDGES[e, 0], EDGES[e, 1]
            el = 0 if i0 < 4 else 1
            z0, s0, dz0, ds0, ddz0, dds0 = node(xm, d.ref[m], i0, el)
            z1, s1, dz1, ds1, ddz1, dds1 = node(xm, d.ref[m], i1, el)
            xz, xs = 0.5 * (z0 + z1), 0.5 * (s0 + s1)  # X (module frame)
            gz, gs = 0.5 * (dz0 + dz1), 0.5 * (ds0 + ds1)  # ∂X/∂φ_e
            hz, hs = 0.5 * (ddz0 + ddz1), 0.5 * (dds0 + dds1)  # ∂²X/∂φ_e²
            vphi = vm[1 + el]
            xdz, xds = vm[0] + gz * vphi, gs * vphi  # Ẋ
            xddz, xdds = hz * vphi * vphi, hs * vphi * vphi  # Ẍ
            rz, rs = ct * xz - st * xs, st * xz + ct * xs
            rdz, rds = ct * xdz - st * xds, st * xdz + ct * xds
            k = 9 * m + e
            pz, ps = pos[m, 0] + rz, pos[m, 1] + rs
            pts[k, 0], pts[k, 1] = pz, ps
            acc[k, 0] = pos_dd[m, 0] - w * w * rz - wd * rs - 2.0 * w * rds + ct * xddz - st * xdds
            acc[k, 1] = pos_dd[m, 1] - w * w * rs + wd * rz + 2.0 * w * rdz + st * xddz + ct * xdds
            if not jacobian:
                continue
            jk = jac_out[k]
            jk[0, 3 * m] += ct
            jk[1, 3 * m] += st
            jk[0, 3 * m + 1 + el] += ct * gz - st * gs
            jk[1, 3 * m + 1 + el] += st * gz + ct * gs
            c = parent[m]
            while c >= 0:
                up, lo = d.conn_upper[c], d.conn_lower[c]
                # ∂p/∂α_c = J (p − P_up), ∂p/∂t_c = R(θ_lo)
                gaz, gas = -(ps - pos[up, 1]), pz - pos[up, 0]
                cl, sl = math.cos(th_lo[c]), math.sin(th_lo[c])
                for i in range(7):
                    col = dofs[c, i]
                    if col < 0:
                        continue
                    a_i, tz_i, ts_i = jacs[c, 0, i], jacs[c, 1, i], jacs[c, 2, i]
                    jk[0, col] += a_i * gaz + cl * tz_i - sl * ts_i
                    jk[1, col] += a_i * gas + sl * tz_i + cl * ts_i
                c = parent[lo] if lo >= 0 else -1
    return pts, jac_out, acc


@kernel
def bodies(d: SystemData, surface_density: float) -> tuple:  # type: ignore[type-arg]
    """(m (2N,) [t], centre (2N, 2) [mm] in the module frame, I (2N,) [t·mm²] about the
    centre) of the rigid elements (body 2m + e: element e of module m), the moments of the
    quadrature points: m = Σ w_k, centre = Σ w_k X_k / m, I = Σ w_k |X_k − centre|²."""
    n = d.ref.shape[0]
    w = quadrature_weights(d, surface_density)
    mass = np.zeros(2 * n)
    centre = np.zeros((2 * n, 2))
    moment = np.zeros(2 * n)
    for m in range(n):
        for e in range(2):
            b = 2 * m + e
            first, last = (0, 6) if e == 0 else (6, 9)
            for k in range(first, last):
                i0, i1 = EDGES[k, 0], EDGES[k, 1]
                wk = w[9 * m + k]
                mass[b] += wk
                centre[b, 0] += wk * 0.5 * (d.ref[m, i0, 0] + d.ref[m, i1, 0])
                centre[b, 1] += wk * 0.5 * (d.ref[m, i0, 1] + d.ref[m, i1, 1])
            if mass[b] > 0.0:  # massless (μ = 0): no centre, every inertia term vanishes
                centre[b] /= mass[b]
            for k in range(first, last):
                i0, i1 = EDGES[k, 0], EDGES[k, 1]
                xz = 0.5 * (d.ref[m, i0, 0] + d.ref[m, i1, 0]) - centre[b, 0]
                xs = 0.5 * (d.ref[m, i0, 1] + d.ref[m, i1, 1]) - centre[b, 1]
                moment[b] += w[9 * m + k] * (xz * xz + xs * xs)
    return mass, centre, moment
