"""The Newton direction's linear solve: dense LU, or a bordered banded LU for long tubes
(Numba; the band factored by LAPACK's ``dgbtrf`` through :mod:`scipy.linalg.cython_lapack`,
its substitutions for all right-hand sides at once in Numba).

The KKT Jacobian of a long tube is block-banded but for a border of k dense rows and columns:
the frame angles α_c, which the chain term −F ∇²z_p couples all to all (∂²Z/∂α_a∂α_b and
∂²Z/∂α_a∂x_c, c > a: :mod:`biplan.model.system.chainterm`), the end constraint's multiplier μ
(its row and column ∇z_p) and, on a path, the load parameter Λ. Every other entry of the
chain term is local. With the inner unknowns I in reverse Cuthill–McKee order (bandwidths kl,
ku) and the border K (:func:`biplan.model.system.ordering.solve_layout`, data of the
:class:`~biplan.model.system.SystemData`), J x = b is solved by block elimination::

    B = J[I, I] (banded LU),  B W = J[I, K],  B y = b_I,
    S = J[K, K] − J[K, I] W,  S x_K = b_K − J[K, I] y,  x_I = y − W x_K

in O(n (kl + ku)(kl + k) + k³) instead of the n³/3 of dense LU: at N = 48 (n = 505, k = 25,
kl = ku = 6) ≈ 10× less time (docs/performance.md, "Linear solves"). The result is checked:
a singular band or Schur complement, or a normwise backward error
‖J x − b‖∞ / (‖J‖∞ ‖x‖∞ + ‖b‖∞) above :data:`BACKWARD_TOL`, falls back to dense LU, which
reports a singular J as NaN (:func:`dense_solve`). Small tubes (below
:data:`biplan.model.system.ordering.MIN_UNKNOWNS`) carry no layout and always use dense LU.
"""

from __future__ import annotations

from typing import Any

import llvmlite.binding as llvm
import numpy as np
from numba import types
from numba.extending import get_cython_function_address

from biplan._compile.numba_cache import kernel

__all__ = [
    "BACKWARD_TOL",
    "banded_solve",
    "dense_solve",
    "direction",
    "fits",
    "lm_solve",
]

#: Largest normwise backward error of an accepted bordered banded solve (else dense LU; dense
#: LU with partial pivoting reaches ~1e-16 on these matrices, the bordered solve 1e-16–1e-15).
BACKWARD_TOL = 1e-13

# LAPACK through SciPy's Cython exports, bound by symbol name (not as a ctypes pointer), so that
# the kernels calling it stay cacheable: the symbol is registered before any kernel loads.
llvm.add_symbol(
    "biplan_dgbtrf", get_cython_function_address("scipy.linalg.cython_lapack", "dgbtrf")
)
#: dgbtrf(m, n, kl, ku, ab, ldab, ipiv, info)
_dgbtrf: Any = types.ExternalFunction("biplan_dgbtrf", types.void(*([types.voidptr] * 8)))


@kernel
def dense_solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a⁻¹ b by LU; NaN where a is singular (as JAX's solve reports it)."""
    try:
        return np.linalg.solve(a, b)
    except Exception:
        return np.full(b.shape[0], np.nan)


@kernel
def _backward_ok(
    a: np.ndarray,
    ax: np.ndarray,
    x: np.ndarray,
    b: np.ndarray,
    order: np.ndarray,
    n_inner: int,
    w: int,
) -> bool:
    """Whether ‖a x − b‖∞ ≤ :data:`BACKWARD_TOL` (‖a‖∞ ‖x‖∞ + ‖b‖∞) (finite x), with ``ax``
    the dense product a x (it sees every entry of a); ‖a‖∞ is summed over the layout's band
    (half-width ``w``) and border, a lower bound should an entry lie outside (a stricter
    test)."""
    n = a.shape[0]
    res = np.max(np.abs(ax - b))
    norm_x, norm_b = np.max(np.abs(x)), np.max(np.abs(b))
    if not (np.isfinite(res) and np.isfinite(norm_x)):
        return False
    if res <= BACKWARD_TOL * norm_b:
        return True
    norm_a = 0.0
    for p in range(n):
        i = order[p]
        row = 0.0
        if p < n_inner:
            for q in range(max(0, p - w), min(n_inner, p + w + 1)):
                row += abs(a[i, order[q]])
            for q in range(n_inner, n):
                row += abs(a[i, order[q]])
        else:
            for j in range(n):
                row += abs(a[i, j])
        norm_a = max(norm_a, row)
    return res <= BACKWARD_TOL * (norm_a * norm_x + norm_b)


@kernel
def _factor_solve(ab: np.ndarray, kl: int, ku: int, rhs: np.ndarray) -> bool:
    """Banded LU of the band ``ab`` (LAPACK column-major AB(2 kl + ku + 1, m) as a C array
    (m, 2 kl + ku + 1), overwritten by its factors) and solve for the columns of ``rhs``
    ((m, nrhs), overwritten); False where the band is singular. The factors are LAPACK's
    (``dgbtrf``); the substitutions are :func:`_substitute`."""
    m, ldab = ab.shape[0], ab.shape[1]
    ints = np.array([m, kl, ku, ldab, 0], dtype=np.int32)
    piv = np.empty(m, dtype=np.int32)
    _dgbtrf(
        ints[0:].ctypes,
        ints[0:].ctypes,
        ints[1:].ctypes,
        ints[2:].ctypes,
        ab.ctypes,
        ints[3:].ctypes,
        piv.ctypes,
        ints[4:].ctypes,
    )
    if ints[4] != 0:
        return False
    _substitute(ab, piv, kl, ku, rhs)
    return True


@kernel
def _substitute(ab: np.ndarray, piv: np.ndarray, kl: int, ku: int, b: np.ndarray) -> None:
    """B ← U⁻¹ L⁻¹ P B in place for the band factors of ``dgbtrf`` (``ab`` as in
    :func:`_factor_solve`, 1-based pivots ``piv``), B (m, nrhs): ``dgbtrs``'s
    operations in its order, each applied to every right-hand side at once (a row of B is
    contiguous). LAPACK's ``dgbtrs`` takes the right-hand sides one at a time through
    level-2 BLAS: 2.2× the time for the 51 of a 48-module tube's Levenberg–Marquardt
    system, 4.3× for the 202 of a 400-module tube's direction (docs/performance.md)."""
    m, nrhs = b.shape
    kd = kl + ku  # the diagonal's row in AB
    for j in range(m - 1):  # L: the row interchanges and multipliers of column j
        p = piv[j] - 1
        if p != j:
            for c in range(nrhs):
                b[p, c], b[j, c] = b[j, c], b[p, c]
        for i in range(1, min(kl, m - 1 - j) + 1):
            f = ab[j, kd + i]
            if f != 0.0:
                for c in range(nrhs):
                    b[j + i, c] -= f * b[j, c]
    for j in range(m - 1, -1, -1):  # U: kl + ku superdiagonals, by columns
        d = ab[j, kd]
        for c in range(nrhs):
            b[j, c] /= d
        for i in range(max(0, j - kd), j):
            u = ab[j, kd + i - j]
            if u != 0.0:
                for c in range(nrhs):
                    b[i, c] -= u * b[j, c]


@kernel
def _eliminate(
    rhs: np.ndarray,
    border_rows: np.ndarray,
    where: np.ndarray,
    count: np.ndarray,
    g: np.ndarray,
    b_border: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """(x_inner, x_border, ok) of the bordered system from the banded solves ``rhs`` (m,
    k + 1) = [W, y] (B W = E, B y = b_I): S = G − F W, S x_K = b_K − F y, x_I = y − W x_K, with
    the rows of F = J[K, I] given sparse (``border_rows`` (k, m) values at the positions
    ``where`` (k, m), ``count`` (k,) of them each) and ``g`` = G (k, k)."""
    m, k = rhs.shape[0], rhs.shape[1] - 1
    s = np.empty((k, k))
    t = np.empty(k)
    for r in range(k):
        for c in range(k + 1):
            acc = 0.0
            for p in range(count[r]):
                acc += border_rows[r, p] * rhs[where[r, p], c]
            if c < k:
                s[r, c] = g[r, c] - acc
            else:
                t[r] = b_border[r] - acc
    x_border = dense_solve(s, t) if k else np.zeros(0)
    x_inner = np.empty(m)
    for i in range(m):
        acc = rhs[i, k]
        for c in range(k):
            acc -= rhs[i, c] * x_border[c]
        x_inner[i] = acc
    return x_inner, x_border, bool(np.all(np.isfinite(x_border)))


@kernel
def banded_solve(
    a: np.ndarray, b: np.ndarray, order: np.ndarray, n_inner: int, kl: int, ku: int
) -> tuple[np.ndarray, bool]:
    """(x, ok): a x = b by the bordered block elimination of the module docstring, unchecked.

    Parameters
    ----------
    a : ndarray (n, n)
    b : ndarray (n,)
    order : ndarray (n,) of int
        The inner unknowns in band order, then the border.
    n_inner : int
        Number of inner unknowns, whose block of ``a`` (rows and columns ``order[:n_inner]``)
        has ``kl`` subdiagonals and ``ku`` superdiagonals (entries outside are ignored).

    Returns
    -------
    x : ndarray (n,)
    ok : bool
        False when the band or the Schur complement is singular.
    """
    n = a.shape[0]
    m, k = n_inner, n - n_inner
    # band storage: ab[j, kl + ku + i − j] = B[i, j]
    ab = np.zeros((m, 2 * kl + ku + 1))
    for j in range(m):
        col = order[j]
        for i in range(max(0, j - ku), min(m, j + kl + 1)):
            ab[j, kl + ku + i - j] = a[order[i], col]
    # right-hand sides (m, k + 1): the border columns E = J[I, K], then b_I
    rhs = np.empty((m, k + 1))
    for i in range(m):  # by the rows of a: a column of a strides over its rows
        row = order[i]
        for c in range(k):
            rhs[i, c] = a[row, order[m + c]]
        rhs[i, k] = b[row]
    if not _factor_solve(ab, kl, ku, rhs):
        return np.full(n, np.nan), False
    # the border rows F = J[K, I] by their non-zeros (a frame angle couples ≈ 1/4 of the
    # inner unknowns), G = J[K, K] and b_K
    rows, where, count = np.empty((k, m)), np.empty((k, m), dtype=np.int64), np.zeros(k, np.int64)
    g, b_border = np.empty((k, k)), np.empty(k)
    for r in range(k):
        i_row = order[m + r]
        for i in range(m):
            v = a[i_row, order[i]]
            if v != 0.0:
                rows[r, count[r]] = v
                where[r, count[r]] = i
                count[r] += 1
        for c in range(k):
            g[r, c] = a[i_row, order[m + c]]
        b_border[r] = b[i_row]
    x_inner, x_border, ok = _eliminate(rhs, rows, where, count, g, b_border)
    x = np.empty(n)
    for c in range(k):
        x[order[m + c]] = x_border[c]
    for i in range(m):
        x[order[i]] = x_inner[i]
    return x, ok


@kernel
def lm_solve(
    a: np.ndarray, r: np.ndarray, damping: float, order: np.ndarray, n_inner: int, kl: int, ku: int
) -> tuple[np.ndarray, bool]:
    """(dz, ok): the Levenberg–Marquardt step (aᵀa + ν D) dz = −aᵀr, D = diag(aᵀa) + 1e-12,
    by the augmented system ``[[I, a], [aᵀ, −ν D]] (y, dz) = (−r, 0)`` (y = −r − a dz) in the
    bordered banded solve, unchecked: inner unknowns interleaved (y_i, dz_i) in band order
    (bandwidth 2 max(kl, ku) + 1), border y_K, dz_K. Never forms aᵀa (and is the more
    accurate: the augmented system's condition is that of a, the normal equations' its
    square). ``ok`` is False when the band or the Schur complement is singular."""
    n = a.shape[0]
    m, k = n_inner, n - n_inner
    w = max(kl, ku)
    band = 2 * w + 1
    nu_d = np.full(n, 1e-12)  # ν D
    for i in range(n):
        for j in range(n):
            nu_d[j] += a[i, j] * a[i, j]
    for j in range(n):
        nu_d[j] *= damping
    mm = 2 * m
    ab = np.zeros((mm, 3 * band + 1))
    off = 2 * band  # ab[col, off + row − col] = A[row, col]
    for p in range(m):
        i = order[p]
        ab[2 * p, off] = 1.0  # (y_i, y_i)
        ab[2 * p + 1, off] = -nu_d[i]  # (dz_i, dz_i)
        for q in range(max(0, p - w), min(m, p + w + 1)):
            j = order[q]
            ab[2 * q + 1, off + 2 * p - 2 * q - 1] = a[i, j]  # (y_i, dz_j) = a[i, j]
            ab[2 * q, off + 2 * p + 1 - 2 * q] = a[j, i]  # (dz_i, y_j) = a[j, i]
    # border unknowns: y_K (c < k), dz_K (k + c); right-hand sides (2m, 2k + 1)
    rhs = np.zeros((mm, 2 * k + 1))
    for p in range(m):
        i = order[p]
        for c in range(k):
            kc = order[m + c]
            rhs[2 * p + 1, c] = a[kc, i]  # (dz_i, y_K) = a[K, i]
            rhs[2 * p, k + c] = a[i, kc]  # (y_i, dz_K) = a[i, K]
        rhs[2 * p, 2 * k] = -r[i]
    # the border rows are the transposed border columns (the system is symmetric)
    kk = 2 * k
    rows, where, count = np.empty((kk, mm)), np.empty((kk, mm), np.int64), np.zeros(kk, np.int64)
    for c in range(kk):
        for p in range(mm):
            v = rhs[p, c]
            if v != 0.0:
                rows[c, count[c]] = v
                where[c, count[c]] = p
                count[c] += 1
    g, b_border = np.zeros((kk, kk)), np.zeros(kk)
    for c in range(k):
        kc = order[m + c]
        g[c, c] = 1.0
        g[k + c, k + c] = -nu_d[kc]
        for e in range(k):
            ke = order[m + e]
            g[c, k + e] = a[kc, ke]  # (y_Kc, dz_Ke)
            g[k + c, e] = a[ke, kc]  # (dz_Kc, y_Ke)
        b_border[c] = -r[kc]
    if not _factor_solve(ab, band, band, rhs):
        return np.full(n, np.nan), False
    x_inner, x_border, ok = _eliminate(rhs, rows, where, count, g, b_border)
    dz = np.empty(n)
    for c in range(k):
        dz[order[m + c]] = x_border[k + c]
    for p in range(m):
        dz[order[p]] = x_inner[2 * p + 1]
    return dz, ok


@kernel
def _full_order(order: np.ndarray, n: int) -> np.ndarray:
    """The layout's order for a system of n unknowns: a path's bordered system (one more
    unknown than the layout) takes its last unknown into the border."""
    if n == order.shape[0]:
        return order
    full = np.empty(n, dtype=order.dtype)
    full[: order.shape[0]] = order
    full[n - 1] = n - 1
    return full


@kernel
def fits(n: int, order: np.ndarray, band: np.ndarray) -> bool:
    """Whether the layout (``order``, ``band``) serves a system of n unknowns."""
    return band.shape[0] == 3 and order.shape[0] <= n <= order.shape[0] + 1


@kernel
def direction(
    a: np.ndarray, b: np.ndarray, order: np.ndarray, band: np.ndarray, structured: bool
) -> tuple[np.ndarray, np.ndarray]:
    """(x = a⁻¹ b, a x): the bordered banded solve where ``structured`` and the layout
    (``order``, ``band`` = (n_inner, kl, ku) of :class:`~biplan.model.system.SystemData`) fits
    (:func:`fits`), checked (module docstring); else, or when it fails, dense LU. NaN where a
    is singular. The product a x is the check's (a Newton's slope rᵀ a x takes it: one dense
    pass over a fewer a step, 8 ms at N = 400)."""
    n = a.shape[0]
    if structured and fits(n, order, band):
        full = _full_order(order, n)
        x, ok = banded_solve(a, b, full, band[0], band[1], band[2])
        if ok:
            ax = a @ x
            if _backward_ok(a, ax, x, b, full, band[0], max(band[1], band[2])):
                return x, ax
    x = dense_solve(a, b)
    return x, a @ x
