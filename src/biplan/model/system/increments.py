"""The connectors' frame increments with their third derivatives along a velocity (Numba;
the inertia of :mod:`.inertia`, MODEL §13).

The exact derivative of the inertia rows of a step (:func:`.inertia.add_inertia`) needs each
increment y_c = (α_c, t_c) of connector c to its third derivative along the velocity v: the
value, ∇, ∇² and ∂/∂x (vᵀ ∂² v) of α_c and of t_c in its seven local coordinates x_c
(:func:`increment3`).

* Default chain (R1 ``EXACT``, R3 ``ELEMENT``): α_c is one element angle (linear in x_c, its
  ∇² zero) and t_c = P + [u_L, 0] + R(α)(Δ − P_z, −P_s) with Δ the seam offset
  (:func:`_increment3`, by hand through :func:`line_height3`).
* R3 ``EDGE_FIT`` and R1 ``PAPER``: the increments of :func:`.readings.increment` evaluated in
  :mod:`.jets` (forward mode, exact): the edge fit a = arg(C + i S) with
  C + i S = Σ w_i conj(P_i) q_i linear in the edge nodes q_i, t = q̄ − e^{ia} p̄, and
  y_c = (a_lo − a_up, t_lo + e^{i a_lo}(l + γ) − e^{i(a_lo − a_up)} t_up); the paper offset
  t = Δ (1 + i tan θ) + P − e^{iθ} P, Δ = γ − u_up + l, α = θ (linear).
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system import jets
from biplan.model.system.tables import SystemData

__all__ = ["increment3", "line_height3"]


@kernel
def line_height3(
    u: float, phi: float, pz: float, ps: float, z_edge: float, s: float
) -> tuple[float, float, float, float]:
    """:func:`biplan.model.system.elements.line_height` with its third derivative in φ:
    (h, ∂h/∂φ, ∂²h/∂φ², ∂³h/∂φ³)."""
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
    h3 = (
        -dpz
        - dps * tn
        + 3.0 * d2ps * sec2
        + 6.0 * dps * sec2 * tn
        - 2.0 * r * sec2 * (2.0 * tn * tn + sec2)
    )
    return h, h1, h2, h3


@kernel
def _delta(
    x: np.ndarray, d: SystemData, c: int, gd: np.ndarray, hd: np.ndarray, td: np.ndarray
) -> float:
    """Δ of connector c, the seam offset Δ = γ + z_L(0) − z_U(0) of
    :func:`biplan.model.system.chainterm._increment`; fills ∇Δ (7,) and the diagonals of ∂²Δ
    and ∂³Δ (7,)."""
    ref, pitch = d.ref, d.scalars[0]
    lo, up = d.conn_lower[c], d.conn_upper[c]
    seam = d.conn_first_point[c]
    gd[:] = 0.0
    hd[:] = 0.0
    td[:] = 0.0
    eu = d.point_upper_element[seam]
    pu = 0 if eu == 0 else 6
    h, h1, h2, h3 = line_height3(x[3], x[4 + eu], ref[up, pu, 0], ref[up, pu, 1], 0.0, 0.0)
    delta = x[6] - h
    gd[3] -= 1.0
    gd[4 + eu] -= h1
    hd[4 + eu] -= h2
    td[4 + eu] -= h3
    gd[6] = 1.0
    if d.point_rigid[seam]:
        delta += d.point_height[seam]
    else:
        el = d.point_lower_element[seam]
        pl = 0 if el == 0 else 6
        h, h1, h2, h3 = line_height3(x[0], x[1 + el], ref[lo, pl, 0], ref[lo, pl, 1], pitch, 0.0)
        delta += h
        gd[0] += 1.0
        gd[1 + el] += h1
        hd[1 + el] += h2
        td[1 + el] += h3
    return delta


@kernel
def _increment3(
    x: np.ndarray,
    v: np.ndarray,
    d: SystemData,
    c: int,
    g: np.ndarray,
    t: np.ndarray,
    jt: np.ndarray,
    ht: np.ndarray,
    tvv: np.ndarray,
    work: np.ndarray,
) -> float:
    """:func:`increment3` on the default chain (α_c linear: its ∇² and ∂/∂x (vᵀ∂²α v)
    vanish), into zeroed arrays (``work``: (3, 7) scratch); returns α. t = P + [x_0, 0] +
    R(α)(Δ − P_z, −P_s) for a module carried by the lower element (pivot P), t = (Δ, 0)
    otherwise."""
    gd, hd, td = work[0], work[1], work[2]
    delta = _delta(x, d, c, gd, hd, td)
    lo, e = d.conn_lower[c], d.conn_element[c]
    if e < 0 or lo < 0:
        t[0] = delta
        for k in range(7):
            jt[0, k] = gd[k]
            ht[0, k, k] = hd[k]
            tvv[0, k] = td[k] * v[k] * v[k]
        return 0.0
    ia = 1 + e
    alpha = x[ia]
    g[ia] = 1.0
    pivot = 0 if e == 0 else 6
    pz, ps = d.ref[lo, pivot, 0], d.ref[lo, pivot, 1]
    ca, sa = math.cos(alpha), math.sin(alpha)
    wz, ws = delta - pz, -ps
    rwz, rws = ca * wz - sa * ws, sa * wz + ca * ws  # R w; J R w = (−rws, rwz)
    t[0], t[1] = pz + x[0] + rwz, ps + rws
    va = v[ia]
    dot1, dot2 = 0.0, 0.0  # Δ̇ = ∇Δ·v, Δ̈ = vᵀ ∂²Δ v
    for k in range(7):
        dot1 += gd[k] * v[k]
        dot2 += hd[k] * v[k] * v[k]
    for k in range(7):
        jt[0, k] = ca * gd[k]
        jt[1, k] = sa * gd[k]
        ht[0, k, k] += ca * hd[k]
        ht[1, k, k] += sa * hd[k]
        # J R (∂_k Δ, 0) in the mixed α rows
        ht[0, ia, k] -= sa * gd[k]
        ht[1, ia, k] += ca * gd[k]
        ht[0, k, ia] -= sa * gd[k]
        ht[1, k, ia] += ca * gd[k]
        # −v_α² R (Δ_k, 0) + 2 v_α J R (Δ_kk v_k, 0) + R (Δ_kkk v_k², 0)
        s1 = -va * va * gd[k] + td[k] * v[k] * v[k]
        s2 = 2.0 * va * hd[k] * v[k]
        tvv[0, k] = ca * s1 - sa * s2
        tvv[1, k] = sa * s1 + ca * s2
    jt[0, 0] += 1.0
    jt[0, ia] -= rws
    jt[1, ia] += rwz
    ht[0, ia, ia] -= rwz
    ht[1, ia, ia] -= rws
    # α row: −v_α² J R w − 2 v_α R (Δ̇, 0) + J R (Δ̈, 0)
    tvv[0, ia] += va * va * rws - 2.0 * va * ca * dot1 - sa * dot2
    tvv[1, ia] += -va * va * rwz - 2.0 * va * sa * dot1 + ca * dot2
    return alpha


@kernel
def _add_node(
    jet: np.ndarray,  # type: ignore[type-arg]
    coef: complex,
    base: complex,
    r: complex,
    iu: int,
    k: int,
    vk: float,
) -> None:
    """Adds ``coef`` times the jet of a node q = u + P + e^{iφ}(X − P) (``base`` = u + P,
    r = e^{iφ}(X − P), u = x_iu, φ = x_k, v_k = ``vk``) to ``jet``: ∇ in u and φ, ∇² and
    ∇ψ in φ only."""
    jet[0] += coef * (base + r)
    jet[jets.GRAD + iu] += coef
    jet[jets.GRAD + k] += coef * 1j * r
    jet[jets.HESS + 8 * k] -= coef * r
    jet[jets.THIRD + k] -= coef * 1j * r * vk * vk


@kernel
def _fit(
    d: SystemData,
    x: np.ndarray,
    v: np.ndarray,
    m: int,
    segs: np.ndarray,
    offset: int,  # type: ignore[type-arg]
) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[type-arg]
    """The jets (a, t_z + i t_s) of module m's edge fit (:func:`.readings.fit`), the module's
    (u, φ1, φ2) at x[offset : offset + 3]; ``segs`` (2, 2): the segments' end nodes, -1
    none."""
    ref = d.ref
    total = 0.0
    pc = 0j
    for j in range(2):
        if segs[j, 0] < 0:
            continue
        i0, i1 = segs[j, 0], segs[j, 1]
        w = math.hypot(ref[m, i1, 0] - ref[m, i0, 0], ref[m, i1, 1] - ref[m, i0, 1])
        for i in (i0, i1):
            total += w
            pc += w * complex(ref[m, i, 0], ref[m, i, 1])
    pc /= total
    qbar = jets.constant(0j)  # Σ ω_i q_i, ω_i = w_i / Σ w
    wfit = jets.constant(0j)  # C + i S = Σ w_i conj(P_i − p̄) q_i
    u = x[offset]
    for j in range(2):
        if segs[j, 0] < 0:
            continue
        i0, i1 = segs[j, 0], segs[j, 1]
        w = math.hypot(ref[m, i1, 0] - ref[m, i0, 0], ref[m, i1, 1] - ref[m, i0, 1])
        for i in (i0, i1):
            e = 0 if i < 4 else 1
            pivot = 0 if e == 0 else 6
            k = offset + 1 + e
            p0 = complex(ref[m, pivot, 0], ref[m, pivot, 1])
            r = cmath.exp(1j * x[k]) * (complex(ref[m, i, 0], ref[m, i, 1]) - p0)
            # node q_i = u + P + e^{iφ}(X − P): ∇ in u and φ, ∇² and ∇ψ in φ only
            pos = complex(ref[m, i, 0], ref[m, i, 1]) - pc
            _add_node(qbar, w / total + 0j, u + p0, r, offset, k, v[k])
            _add_node(wfit, w * pos.conjugate(), u + p0, r, offset, k, v[k])
    a = jets.log(wfit, v)
    for k in range(jets.SIZE):
        a[k] = a[k].imag
    t = qbar - pc * jets.exp_i(a, v)
    return a, t


@kernel
def _fit_increment3(
    x: np.ndarray,
    v: np.ndarray,
    d: SystemData,
    c: int,  # type: ignore[type-arg]
) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[type-arg]
    """The jets (α, t_z + i t_s) of connector c's increment under R3 ``EDGE_FIT``."""
    lo, up, pitch = d.conn_lower[c], d.conn_upper[c], d.scalars[0]
    length = jets.variable(x[6], 6)
    length[0] += pitch
    a_up, t_up = _fit(d, x, v, up, d.conn_edges[c, 1], 3)
    if lo < 0:  # the clamp line: a_lo = 0, t_lo = (h − l, 0)
        alpha = -a_up
        t = length - jets.product(jets.exp_i(alpha, v), t_up, v)
        t[0] += d.conn_seam_height[c] - pitch
        return alpha, t
    a_lo, t_lo = _fit(d, x, v, lo, d.conn_edges[c, 0], 0)
    alpha = a_lo - a_up
    t = t_lo + jets.product(jets.exp_i(a_lo, v), length, v)
    t -= jets.product(jets.exp_i(alpha, v), t_up, v)
    return alpha, t


@kernel
def _paper_increment3(
    x: np.ndarray,
    v: np.ndarray,
    d: SystemData,
    c: int,  # type: ignore[type-arg]
) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[type-arg]
    """The jets (α, t_z + i t_s) of connector c's increment under R1 ``PAPER``."""
    lo, e = d.conn_lower[c], d.conn_seam[c, 0]
    gap = jets.variable(x[6], 6) - jets.variable(x[3], 3)  # γ − u_up
    if lo < 0:
        return jets.constant(0j), gap
    gap[0] += d.scalars[0]
    if e < 0:
        return jets.constant(0j), gap
    theta = jets.variable(x[1 + e], 1 + e)
    pivot = 0 if e == 0 else 6
    p = jets.variable(x[0], 0)  # P moved by u_lo
    p[0] += complex(d.ref[lo, pivot, 0], d.ref[lo, pivot, 1])
    slope = 1j * jets.tan(theta, v)
    slope[0] += 1.0
    t = jets.product(gap, slope, v) + p - jets.product(jets.exp_i(theta, v), p, v)
    return theta, t


@kernel
def increment3(
    x: np.ndarray,
    v: np.ndarray,
    d: SystemData,
    c: int,
    g: np.ndarray,
    ha: np.ndarray,
    avv: np.ndarray,
    t: np.ndarray,
    jt: np.ndarray,
    ht: np.ndarray,
    tvv: np.ndarray,
    work: np.ndarray,
) -> float:
    """Connector c's frame increment (α, t) at its local coordinates x (7,) and velocity v
    (7,) under the tube's chain readings, into zeroed arrays: ∇α (7,), ∇²α (7, 7),
    ∂/∂x (vᵀ∂²α v) (7,), t (2,), ∂t/∂x (2, 7), ∂²t/∂x² (2, 7, 7), ∂/∂x (vᵀ∂²t v) (2, 7)
    (``work``: (3, 7) scratch); returns α."""
    if d.flags[3] == 1:
        aj, tj = _paper_increment3(x, v, d, c)
    elif d.flags[2] == 1:
        aj, tj = _fit_increment3(x, v, d, c)
    else:
        return _increment3(x, v, d, c, g, t, jt, ht, tvv, work)
    t[0], t[1] = tj[0].real, tj[0].imag
    for i in range(7):
        g[i] = aj[jets.GRAD + i].real
        avv[i] = aj[jets.THIRD + i].real
        jt[0, i], jt[1, i] = tj[jets.GRAD + i].real, tj[jets.GRAD + i].imag
        tvv[0, i], tvv[1, i] = tj[jets.THIRD + i].real, tj[jets.THIRD + i].imag
        for k in range(7):
            h = jets.HESS + 7 * i + k
            ha[i, k] = aj[h].real
            ht[0, i, k], ht[1, i, k] = tj[h].real, tj[h].imag
    return aj[0].real
