"""The KKT system of a tube assembled from its compiled elements (Numba; MODEL §11).

One Lagrangian, as :mod:`biplan.model.lagrangian` states it::

    L = Π(q) − F z_p(q) + λᵀ g(q) − λ_∂ᵀ w_∂(q) + μ d (z_p(q) − U) [+ ½κ‖q − q_a‖²]

    r = [∇_q L,  g,  φ_ε(w_∂ + c λ_∂, λ_∂),  d (z_p − U) + (1 − d) μ]

:func:`terms` evaluates every module and connector element (and the chain term when the load
needs it) and adds their blocks into the global arrays; :func:`residual`, :func:`jacobian` and
:func:`evaluate` build r and ∂r/∂z from them. ``load`` is the array (F [N], U [mm], d ∈ {0, 1}).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from biplan.model.system.chainterm import load_point
from biplan.model.system.elements import connector_points, field_energy, module_rows
from biplan.model.system.tables import SystemData

__all__ = ["evaluate", "jacobian", "observe", "residual", "terms"]


@njit(cache=True)
def _add_field(
    e: tuple,  # type: ignore[type-arg]
    ga: np.ndarray,
    gb: np.ndarray,
    ha: np.ndarray,
    hb: np.ndarray,
    grad: np.ndarray,
    hess: np.ndarray,
    second: bool,
) -> None:
    """Chain rule of one field energy E(a(x), b(x)) into a local gradient and Hessian
    (``ha``, ``hb``: the diagonal Hessians of a and b)."""
    _, ea, eb, eaa, eab, ebb = e
    n = grad.shape[0]
    for i in range(n):
        grad[i] += ea * ga[i] + eb * gb[i]
    if not second:
        return
    for i in range(n):
        hess[i, i] += ea * ha[i] + eb * hb[i]
        for j in range(n):
            hess[i, j] += (
                eaa * ga[i] * ga[j] + eab * (ga[i] * gb[j] + gb[i] * ga[j]) + ebb * gb[i] * gb[j]
            )


@njit(cache=True)
def terms(
    d: SystemData,
    q: np.ndarray,
    lam: np.ndarray,
    lam_c: np.ndarray,
    second: bool,
) -> tuple:
    """The element part of the system at (q, λ, λ_∂): (∇_q of Π + λ·g − λ_∂·w_∂ (n_q,),
    its Hessian (n_q, n_q), g (2N,), w_∂ (n_c,), ∂g/∂q (2N, n_q), ∂w_∂/∂q (n_c, n_q),
    helical energies (N,), circular energies (Nc,)). Second-order arrays are zeros unless
    ``second``."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    pitch, a_len, tau = d.scalars[0], d.scalars[2], d.scalars[5]
    minimum = d.flags[0] == 1
    m = n_q if second else 0
    grad = np.zeros(n_q)
    hess = np.zeros((m, m))
    guides = np.zeros(n_g)
    gaps = np.zeros(n_c)
    g_mat = np.zeros((n_g if second else 0, m))
    c_mat = np.zeros((n_c if second else 0, m))
    e_hel = np.zeros(n)
    e_circ = np.zeros(nc)
    lg = np.zeros(3)
    lh = np.zeros((3, 3))
    for i in range(n):
        x = q[3 * i : 3 * i + 3]
        vals, gr, hd = module_rows(x, d.ref[i], d.n_c[i], d.n_sp[i])
        e = field_energy(vals[2], vals[3], a_len, d.helical[i])
        e_hel[i] = e[0]
        lg[:] = 0.0
        lh[:, :] = 0.0
        _add_field(e, gr[2], gr[3], hd[2], hd[3], lg, lh, second)
        mult = (lam[2 * i], lam[2 * i + 1], -lam_c[2 * i], -lam_c[2 * i + 1])
        for r in range(4):
            for k in range(3):
                lg[k] += mult[r] * gr[r, k]
                if second:
                    lh[k, k] += mult[r] * hd[r, k]
        guides[2 * i : 2 * i + 2] = vals[:2]
        gaps[2 * i : 2 * i + 2] = vals[2:]
        for k in range(3):
            grad[3 * i + k] += lg[k]
            if second:
                for j in range(3):
                    hess[3 * i + k, 3 * i + j] += lh[k, j]
                for r in range(2):
                    g_mat[2 * i + r, 3 * i + k] = gr[r, k]
                    c_mat[2 * i + r, 3 * i + k] = gr[2 + r, k]
    cg = np.zeros(7)
    ch = np.zeros((7, 7))
    x = np.zeros(7)
    dofs = np.zeros(7, dtype=np.int64)
    for c in range(nc):
        lo, up = d.conn_lower[c], d.conn_upper[c]
        for k in range(3):
            dofs[k] = -1 if lo < 0 else 3 * lo + k
            dofs[3 + k] = 3 * up + k
        dofs[6] = 3 * n + c
        for k in range(7):
            x[k] = 0.0 if dofs[k] < 0 else q[dofs[k]]
        first, last = d.conn_first_point[c], d.conn_first_point[c + 1]
        w, gw, hw = connector_points(
            x,
            d.ref[max(lo, 0)],
            d.ref[up],
            pitch,
            first,
            last,
            d.point_s,
            d.point_upper_element,
            d.point_lower_element,
            d.point_rigid,
            d.point_height,
            d.point_flip,
        )
        cg[:] = 0.0
        ch[:, :] = 0.0
        for f in range(d.conn_first_field[c], d.conn_first_field[c + 1]):
            i0, i1 = d.field_start[f] - first, d.field_end[f] - first
            length = d.point_s[d.field_end[f]] - d.point_s[d.field_start[f]]
            e = field_energy(w[i0], w[i1], length, d.circular[c])
            e_circ[c] += e[0]
            _add_field(e, gw[i0], gw[i1], hw[i0], hw[i1], cg, ch, second)
        c0, c1 = d.conn_first_contact[c], d.conn_first_contact[c + 1]
        if minimum:  # MODEL C1 MINIMUM: −τ log Σ exp(−w/τ) over the connector's points
            row = 2 * n + c
            wmin = 1e300
            for r in range(c0, c1):
                wmin = min(wmin, w[d.contact_point[r] - first])
            total = 0.0
            for r in range(c0, c1):
                total += math.exp(-(w[d.contact_point[r] - first] - wmin) / tau)
            gaps[row] = wmin - tau * math.log(total)
            gg = np.zeros(7)
            soft = np.zeros(c1 - c0)
            for r in range(c0, c1):
                p = d.contact_point[r] - first
                soft[r - c0] = math.exp(-(w[p] - wmin) / tau) / total
                gg += soft[r - c0] * gw[p]
            cg -= lam_c[row] * gg
            if second:
                for r in range(c0, c1):
                    p = d.contact_point[r] - first
                    for i in range(7):
                        ch[i, i] -= lam_c[row] * soft[r - c0] * hw[p, i]
                        for j in range(7):
                            ch[i, j] += lam_c[row] / tau * soft[r - c0] * gw[p, i] * gw[p, j]
                for i in range(7):
                    for j in range(7):
                        ch[i, j] -= lam_c[row] / tau * gg[i] * gg[j]
                for k in range(7):
                    if dofs[k] >= 0:
                        c_mat[row, dofs[k]] += gg[k]
        else:
            for r in range(c0, c1):
                row = 2 * n + r
                p = d.contact_point[r] - first
                gaps[row] = w[p]
                for k in range(7):
                    cg[k] -= lam_c[row] * gw[p, k]
                    if second:
                        ch[k, k] -= lam_c[row] * hw[p, k]
                        if dofs[k] >= 0:
                            c_mat[row, dofs[k]] += gw[p, k]
        for i in range(7):
            if dofs[i] < 0:
                continue
            grad[dofs[i]] += cg[i]
            if second:
                for j in range(7):
                    if dofs[j] >= 0:
                        hess[dofs[i], dofs[j]] += ch[i, j]
    return grad, hess, guides, gaps, g_mat, c_mat, e_hel, e_circ


@njit(cache=True)
def evaluate(
    d: SystemData,
    z: np.ndarray,
    load: np.ndarray,
    second: bool,
) -> tuple:
    """(r (n_z,), ∂r/∂z (n_z, n_z) or (0, 0), z_p [mm], ∇z_p (n_q,), element terms) at z
    for load = (F, U, d) (module docstring)."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    n_z = n_q + n_g + n_c + 1
    q = z[:n_q]
    lam = z[n_q : n_q + n_g]
    lam_c = z[n_q + n_g : n_q + n_g + n_c]
    mu = z[n_z - 1]
    force, disp, ctrl = load[0], load[1], load[2]
    eps, comp, kappa = d.scalars[3], d.scalars[4], d.bias_stiffness[0]
    t = terms(d, q, lam, lam_c, second)
    grad, hess = t[0], t[1]
    coef = mu * ctrl - force
    a = np.zeros(n_q)
    zp = 0.0
    if force != 0.0 or ctrl != 0.0:  # at rest the load point's terms vanish
        zp = load_point(d, q, a, hess, coef, second) - d.load_reference[0]
    r = np.empty(n_z)
    for i in range(n_q):
        r[i] = grad[i] + coef * a[i] + kappa * (q[i] - d.bias_anchor[i])
    r[n_q : n_q + n_g] = t[2]
    w = t[3] + comp * lam_c
    rho = np.sqrt(w * w + lam_c * lam_c + eps * eps)
    r[n_q + n_g : n_q + n_g + n_c] = rho - (w + lam_c)
    r[n_z - 1] = ctrl * (zp - disp) + (1.0 - ctrl) * mu
    if not second:
        return r, np.zeros((0, 0)), zp, a, t
    jac = np.zeros((n_z, n_z))
    jac[:n_q, :n_q] = hess
    for i in range(n_q):
        jac[i, i] += kappa
        jac[i, n_z - 1] = ctrl * a[i]
        jac[n_z - 1, i] = ctrl * a[i]
    g_mat, c_mat = t[4], t[5]
    jac[n_q : n_q + n_g, :n_q] = g_mat
    jac[:n_q, n_q : n_q + n_g] = g_mat.T
    jac[:n_q, n_q + n_g : n_q + n_g + n_c] = -c_mat.T
    dw = w / rho - 1.0
    for i in range(n_c):
        row = n_q + n_g + i
        jac[row, :n_q] = dw[i] * c_mat[i]
        jac[row, row] = comp * dw[i] + lam_c[i] / rho[i] - 1.0
    jac[n_z - 1, n_z - 1] = 1.0 - ctrl
    return r, jac, zp, a, t


@njit(cache=True)
def residual(d: SystemData, z: np.ndarray, load: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The KKT residual r(z) (module docstring)."""
    return evaluate(d, z, load, False)[0]


@njit(cache=True)
def jacobian(d: SystemData, z: np.ndarray, load: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The KKT Jacobian ∂r/∂z (:func:`biplan.model.lagrangian.kkt_jacobian`)."""
    return evaluate(d, z, load, True)[1]


@njit(cache=True)
def observe(d: SystemData, z: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """(z_p [mm], ∇z_p (n_q,), helical energies (N,), circular energies (Nc,), gaps (n_c,))
    at z, whatever the load (the first-order data of a state)."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    q = z[:n_q]
    t = terms(d, q, z[n_q : n_q + n_g], z[n_q + n_g : n_q + n_g + n_c], False)
    a = np.zeros(n_q)
    zp = load_point(d, q, a, np.zeros((0, 0)), 0.0, False) - d.load_reference[0]
    return zp, a, t[6], t[7], t[3]
