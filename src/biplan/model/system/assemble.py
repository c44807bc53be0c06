"""The KKT system of a tube assembled from its compiled elements (Numba; MODEL §11).

One Lagrangian, as :mod:`biplan.model.lagrangian` states it::

    L = Π(q) − F z_p(q) + λᵀ g(q) − λ_∂ᵀ w_∂(q) + μ d (z_p(q) − U) [+ ½κ‖q − q_a‖²]

    r = [∇_q L,  g,  φ_ε(w_∂ + c λ_∂, λ_∂),  d (z_p − U) + (1 − d) μ]

:func:`terms` evaluates every module and connector element (and the chain term when the load
needs it) and adds their blocks into the global arrays; :func:`residual` and :func:`evaluate`
(:func:`evaluate_into`) build r and ∂r/∂z from them, the element blocks added into ∂r/∂z in
place (its non-zero entries only: no n_q × n_q array of their own, which at N = 400 cost more
than the rest of a Newton step). ``load`` is the array (F [N], U [mm], d ∈ {0, 1}).

Numba compiles a function once per argument types, and a literal ``True``/``False`` written at
a call site is a type of its own: :func:`evaluate`, :func:`terms` and :func:`.chainterm.load_point`
pass ``bool(second)`` (a run-time flag) on to their implementations (``_evaluate``, …), and this
module calls those with the run-time flags ``_FIRST``/``_SECOND``, so that they compile once
whatever the callers write (the three are inlined into compiled callers: no specialisation of
their own per literal either). The element loops fill scratch arrays allocated once per evaluation
and call the kernels of :mod:`.elements` (no SystemData, no array view, nothing allocated per
element).
"""

from __future__ import annotations

import math
from typing import cast

import numpy as np

from biplan._compile.numba_cache import inlined_kernel, kernel
from biplan.model.system.chainterm import _gather, _load_point
from biplan.model.system.elements import pivots, points_into, rows_into
from biplan.model.system.fields import field_energy, law_of
from biplan.model.system.tables import SystemData

__all__ = ["evaluate", "evaluate_into", "observe", "residual", "terms"]

#: ``second`` = False, True as run-time values (NumPy booleans: not literals, module docstring)
_FIRST, _SECOND = cast(bool, np.False_), cast(bool, np.True_)


@inlined_kernel
def _add_field(
    e: tuple,  # type: ignore[type-arg]
    g: np.ndarray,
    h: np.ndarray,
    a: int,
    b: int,
    grad: np.ndarray,
    hess: np.ndarray,
    second: bool,
) -> None:
    """Chain rule of one field energy E(w_a(x), w_b(x)) into a local gradient and Hessian
    (``g``, ``h``: the gradients and diagonal Hessians of the w, by rows)."""
    _, ea, eb, eaa, eab, ebb = e
    n = grad.shape[0]
    for i in range(n):
        grad[i] += ea * g[a, i] + eb * g[b, i]
    if not second:
        return
    for i in range(n):
        hess[i, i] += ea * h[a, i] + eb * h[b, i]
        for j in range(n):
            hess[i, j] += (
                eaa * g[a, i] * g[a, j]
                + eab * (g[a, i] * g[b, j] + g[b, i] * g[a, j])
                + ebb * g[b, i] * g[b, j]
            )


@inlined_kernel
def _modules(
    d: SystemData,
    q: np.ndarray,
    lam: np.ndarray,
    lam_c: np.ndarray,
    second: bool,
    grad: np.ndarray,
    hess: np.ndarray,
    guides: np.ndarray,
    gaps: np.ndarray,
    g_mat: np.ndarray,
    c_mat: np.ndarray,
    g_row: int,
    c_row: int,
    e_hel: np.ndarray,
    vals: np.ndarray,
    work: np.ndarray,
) -> None:
    """Adds the module elements (helical fields, guides and helical boundary rows) into the
    arrays of :func:`terms` (∂g/∂q and ∂w_∂/∂q from the rows ``g_row`` of ``g_mat`` and
    ``c_row`` of ``c_mat`` on; scratch: ``vals`` (4,), ``work`` (12, 3))."""
    a_len = d.scalars[2]
    gr, hd, lh, lg = work[0:4], work[4:8], work[8:11], work[11]  # rows' ∇, ∇² diag; local
    for i in range(d.ref.shape[0]):
        rows_into(q, i, d.ref, d.n_c, d.n_sp, vals, gr, hd)
        e = field_energy(vals[2], vals[3], a_len, law_of(d.helical, i))
        e_hel[i] = e[0]
        lg[:] = 0.0
        lh[:, :] = 0.0
        _add_field(e, gr, hd, 2, 3, lg, lh, second)
        for r in range(4):  # λ·g − λ_∂·w_∂ over the rows (g_C, g_F, w0, wa)
            mult = lam[2 * i + r] if r < 2 else -lam_c[2 * i + r - 2]
            for k in range(3):
                lg[k] += mult * gr[r, k]
                if second:
                    lh[k, k] += mult * hd[r, k]
        for r in range(2):
            guides[2 * i + r] = vals[r]
            gaps[2 * i + r] = vals[2 + r]
        for k in range(3):
            grad[3 * i + k] += lg[k]
            if second:
                for j in range(3):
                    hess[3 * i + k, 3 * i + j] += lh[k, j]
                for r in range(2):
                    g_mat[g_row + 2 * i + r, 3 * i + k] = gr[r, k]
                    c_mat[c_row + 2 * i + r, 3 * i + k] = gr[2 + r, k]


@inlined_kernel
def _connectors(
    d: SystemData,
    q: np.ndarray,
    lam_c: np.ndarray,
    second: bool,
    grad: np.ndarray,
    hess: np.ndarray,
    gaps: np.ndarray,
    c_mat: np.ndarray,
    c_row: int,
    e_circ: np.ndarray,
    w: np.ndarray,
    pts: np.ndarray,
    local: np.ndarray,
    soft: np.ndarray,
) -> None:
    """Adds the connector elements (circular fields and contact rows) into the arrays of
    :func:`terms` (∂w_∂/∂q from the row ``c_row`` of ``c_mat`` on; scratch: ``w`` (K,) and
    ``pts`` (2, K, 7) for w, ∂w/∂x_c and diag ∂²w/∂x_c² at every connector point, ``local``
    (10, 7), ``soft`` (n_cc,) for the smooth-minimum weights)."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    pitch, tau = d.scalars[0], d.scalars[5]
    minimum = d.flags[0] == 1
    dofs = d.conn_dofs
    gw, hw = pts[0], pts[1]
    x, cg, gg, ch = local[0], local[1], local[2], local[3:10]  # x_c, ∇, smooth-min ∇, ∇²
    points = (
        d.point_s,
        d.point_upper_element,
        d.point_lower_element,
        d.point_rigid,
        d.point_height,
        d.point_flip,
    )
    for c in range(nc):
        _gather(q, dofs, c, x)
        lo, up = max(d.conn_lower[c], 0), d.conn_upper[c]
        first, last = d.conn_first_point[c], d.conn_first_point[c + 1]
        p_lo, p_up = pivots(d.ref, lo), pivots(d.ref, up)
        points_into(x, p_lo, p_up, pitch, first, last, points, w, gw, hw)
        cg[:] = 0.0
        ch[:, :] = 0.0
        law = law_of(d.circular, c)
        for f in range(d.conn_first_field[c], d.conn_first_field[c + 1]):
            i0, i1 = d.field_start[f], d.field_end[f]
            e = field_energy(w[i0], w[i1], d.point_s[i1] - d.point_s[i0], law)
            e_circ[c] += e[0]
            _add_field(e, gw, hw, i0, i1, cg, ch, second)
        c0, c1 = d.conn_first_contact[c], d.conn_first_contact[c + 1]
        if minimum:  # MODEL C1 MINIMUM: −τ log Σ exp(−w/τ) over the connector's points
            row = 2 * n + c
            wmin = 1e300
            for r in range(c0, c1):
                wmin = min(wmin, w[d.contact_point[r]])
            total = 0.0
            for r in range(c0, c1):
                total += math.exp(-(w[d.contact_point[r]] - wmin) / tau)
            gaps[row] = wmin - tau * math.log(total)
            gg[:] = 0.0
            for r in range(c0, c1):
                p = d.contact_point[r]
                soft[r] = math.exp(-(w[p] - wmin) / tau) / total
                for k in range(7):
                    gg[k] += soft[r] * gw[p, k]
            for k in range(7):
                cg[k] -= lam_c[row] * gg[k]
            if second:
                for r in range(c0, c1):
                    p = d.contact_point[r]
                    for i in range(7):
                        ch[i, i] -= lam_c[row] * soft[r] * hw[p, i]
                        for j in range(7):
                            ch[i, j] += lam_c[row] / tau * soft[r] * gw[p, i] * gw[p, j]
                for i in range(7):
                    for j in range(7):
                        ch[i, j] -= lam_c[row] / tau * gg[i] * gg[j]
                for k in range(7):
                    if dofs[c, k] >= 0:
                        c_mat[c_row + row, dofs[c, k]] += gg[k]
        else:
            for r in range(c0, c1):
                row = 2 * n + r
                p = d.contact_point[r]
                gaps[row] = w[p]
                for k in range(7):
                    cg[k] -= lam_c[row] * gw[p, k]
                    if second:
                        ch[k, k] -= lam_c[row] * hw[p, k]
                        if dofs[c, k] >= 0:
                            c_mat[c_row + row, dofs[c, k]] += gw[p, k]
        for i in range(7):
            if dofs[c, i] < 0:
                continue
            grad[dofs[c, i]] += cg[i]
            if second:
                for j in range(7):
                    if dofs[c, j] >= 0:
                        hess[dofs[c, i], dofs[c, j]] += ch[i, j]


@kernel(inline="always")
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
    return _terms(d, q, lam, lam_c, bool(second))  # a run-time flag: one compilation


@kernel
def _terms(
    d: SystemData,
    q: np.ndarray,
    lam: np.ndarray,
    lam_c: np.ndarray,
    second: bool,
) -> tuple:
    """:func:`terms`."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    m = n_q if second else 0
    hess = np.zeros((m, m))
    g_mat, c_mat = np.zeros((n_g if second else 0, m)), np.zeros((n_c if second else 0, m))
    grad, guides, gaps, e_hel, e_circ = _fill(d, q, lam, lam_c, second, hess, g_mat, c_mat, 0, 0)
    return grad, hess, guides, gaps, g_mat, c_mat, e_hel, e_circ


@kernel
def _fill(
    d: SystemData,
    q: np.ndarray,
    lam: np.ndarray,
    lam_c: np.ndarray,
    second: bool,
    hess: np.ndarray,
    g_mat: np.ndarray,
    c_mat: np.ndarray,
    g_row: int,
    c_row: int,
) -> tuple:
    """The first-order arrays of :func:`terms` (∇_q, g, w_∂, helical and circular energies);
    where ``second``, adds the Hessian into ``hess`` and writes ∂g/∂q and ∂w_∂/∂q into the
    rows of ``g_mat`` from ``g_row`` on and of ``c_mat`` from ``c_row`` on (separate arrays
    for :func:`terms`, the KKT Jacobian itself for :func:`evaluate`)."""
    grad, guides, gaps = np.zeros(d.sizes[0]), np.zeros(d.sizes[1]), np.zeros(d.sizes[2])
    e_hel, e_circ = np.zeros(d.ref.shape[0]), np.zeros(d.conn_upper.shape[0])
    vals, work = np.empty(4), np.empty((12, 3))
    _modules(
        d, q, lam, lam_c, second, grad, hess, guides, gaps, g_mat, c_mat, g_row, c_row, e_hel,
        vals, work,
    )  # fmt: skip
    n_pts = d.point_s.shape[0]
    w, pts, local = np.empty(n_pts), np.empty((2, n_pts, 7)), np.empty((10, 7))
    soft = np.empty(d.contact_point.shape[0])
    _connectors(d, q, lam_c, second, grad, hess, gaps, c_mat, c_row, e_circ, w, pts, local, soft)
    return grad, guides, gaps, e_hel, e_circ


@kernel(inline="always")
def evaluate(
    d: SystemData,
    z: np.ndarray,
    load: np.ndarray,
    second: bool,
) -> tuple:
    """(r (n_z,), ∂r/∂z (n_z, n_z) or (0, 0), z_p [mm], ∇z_p (n_q,), element terms) at z
    for load = (F, U, d) (module docstring). The element terms are those of :func:`terms`
    but for the second-order arrays (its Hessian, ∂g/∂q and ∂w_∂/∂q: (0, 0) here; they are
    the blocks of ∂r/∂z)."""
    n = z.shape[0] if second else 0
    return _evaluate(d, z, load, bool(second), np.zeros((n, n)))  # a run-time flag


@kernel(inline="always")
def evaluate_into(
    d: SystemData,
    z: np.ndarray,
    load: np.ndarray,
    second: bool,
    jac: np.ndarray,
) -> tuple:
    """:func:`evaluate` with ∂r/∂z written into ``jac``: zeros (m, m), m ≥ n_z, where
    ``second`` (∂r/∂z its leading n_z × n_z block, nothing written outside it), (0, 0) where
    not. A Newton reuses its arrays (:func:`biplan.solvers.iteration.solve`), and Python
    passes NumPy's zeros, whose pages the system allocates as the entries are written: at
    N = 400 allocating and zeroing the 4201² array in compiled code cost more than the rest
    of a Newton step."""
    return _evaluate(d, z, load, bool(second), jac)


@kernel
def _evaluate(
    d: SystemData,
    z: np.ndarray,
    load: np.ndarray,
    second: bool,
    jac: np.ndarray,
) -> tuple:
    """:func:`evaluate_into`. The elements add their Hessian blocks and write ∂g/∂q and ∂w_∂/∂q
    into the Jacobian itself (:func:`_fill`): the Jacobian is the one n_z × n_z array, and
    only its non-zero entries are written (the terms it returns carry no second-order
    arrays)."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    n_z = n_q + n_g + n_c + 1
    c0 = n_q + n_g  # the first contact row
    q = z[:n_q]
    lam = z[n_q:c0]
    lam_c = z[c0 : c0 + n_c]
    mu = z[n_z - 1]
    force, disp, ctrl = load[0], load[1], load[2]
    eps, comp, kappa = d.scalars[3], d.scalars[4], d.bias_stiffness[0]
    grad, guides, gaps, e_hel, e_circ = _fill(d, q, lam, lam_c, second, jac, jac, jac, n_q, c0)
    none = np.zeros((0, 0))
    t = (grad, none, guides, gaps, none, none, e_hel, e_circ)
    coef = mu * ctrl - force
    a = np.zeros(n_q)
    zp = 0.0
    if force != 0.0 or ctrl != 0.0:  # at rest the load point's terms vanish
        zp = _load_point(d, q, a, jac, coef, second) - d.load_reference[0]
    r = np.empty(n_z)
    for i in range(n_q):
        r[i] = grad[i] + coef * a[i] + kappa * (q[i] - d.bias_anchor[i])
    r[n_q:c0] = guides
    for i in range(n_c):  # φ_ε(w + c λ_∂, λ_∂)
        w = gaps[i] + comp * lam_c[i]
        r[c0 + i] = math.sqrt(w * w + lam_c[i] * lam_c[i] + eps * eps) - (w + lam_c[i])
    r[n_z - 1] = ctrl * (zp - disp) + (1.0 - ctrl) * mu
    if not second:
        return r, jac, zp, a, t
    for i in range(n_q):
        jac[i, i] += kappa
        jac[i, n_z - 1] = ctrl * a[i]
        jac[n_z - 1, i] = ctrl * a[i]
    dphi = np.empty(n_c)  # ∂φ/∂w of each contact row
    for i in range(n_c):
        w = gaps[i] + comp * lam_c[i]
        rho = math.sqrt(w * w + lam_c[i] * lam_c[i] + eps * eps)
        dphi[i] = w / rho - 1.0
        jac[c0 + i, c0 + i] = comp * dphi[i] + lam_c[i] / rho - 1.0
    # the constraint rows hold ∂g/∂q and ∂w_∂/∂q (_fill): the transposes, and the contact
    # rows scaled by ∂φ/∂w, entry by entry over each row's coordinates (3 of a module, 7 of a
    # connector)
    for i in range(n_g):  # module i // 2: its guide row i and helical boundary row i (n_g = 2N)
        for k in range(3):
            j = 3 * (i // 2) + k
            jac[j, n_q + i] = jac[n_q + i, j]
            raw = jac[c0 + i, j]
            jac[c0 + i, j] = dphi[i] * raw
            jac[j, c0 + i] = -raw
    minimum = d.flags[0] == 1
    raws = np.empty(7)
    for c in range(d.conn_upper.shape[0]):  # the contact rows of connector c
        r0, r1 = d.conn_first_contact[c], d.conn_first_contact[c + 1]
        if minimum:  # one row a connector
            r0, r1 = c, c + 1
        for i in range(n_g + r0, n_g + r1):
            for k in range(7):  # read first: a coordinate may repeat
                j = d.conn_dofs[c, k]
                raws[k] = jac[c0 + i, j] if j >= 0 else 0.0
            for k in range(7):
                j = d.conn_dofs[c, k]
                if j >= 0:
                    jac[c0 + i, j] = dphi[i] * raws[k]
                    jac[j, c0 + i] = -raws[k]
    jac[n_z - 1, n_z - 1] = 1.0 - ctrl
    return r, jac, zp, a, t


@kernel
def residual(d: SystemData, z: np.ndarray, load: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The KKT residual r(z) (module docstring)."""
    return _evaluate(d, z, load, _FIRST, np.zeros((0, 0)))[0]


@kernel
def observe(d: SystemData, z: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """(z_p [mm], ∇z_p (n_q,), helical energies (N,), circular energies (Nc,), gaps (n_c,))
    at z, whatever the load (the first-order data of a state)."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    q = z[:n_q]
    t = _terms(d, q, z[n_q : n_q + n_g], z[n_q + n_g : n_q + n_g + n_c], _FIRST)
    a = np.zeros(n_q)
    zp = _load_point(d, q, a, np.zeros((0, 0)), 0.0, _FIRST) - d.load_reference[0]
    return zp, a, t[6], t[7], t[3]
