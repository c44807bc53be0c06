"""Second-order jets with a third derivative along one direction (Numba; forward-mode
derivatives of the chain readings' frame increments, :mod:`.inertia_chain`).

A jet of f(x), x ∈ ℝ⁷ (a connector's local coordinates), at x with the direction v (its
velocity) is the complex array (:data:`SIZE`,)::

    [f, ∇f (7), ∇²f (7 × 7, row-major), ∇ψ (7)],   ψ(x) = vᵀ ∇²f(x) v

(∇ψ = ∂/∂x (vᵀ ∂²f v), the derivative of the velocity-quadratic term that the exact
Jacobian of the inertia rows needs). Jets are complex so that a planar vector (z, s) is one
jet z + i s and a rotation a multiplication by e^{iα}; every operation is holomorphic, so the
real derivatives of x follow the complex chain rule. With s = ∇f·v::

    (f g):  ∇ = f ∇g + g ∇f,   ∇² = f ∇²g + g ∇²f + ∇f ∇gᵀ + ∇g ∇fᵀ,
            ∇ψ = f ∇ψ_g + g ∇ψ_f + ψ_g ∇f + ψ_f ∇g + 2 s_g ∇²f v + 2 s_f ∇²g v
    h(f):   ∇ = h' ∇f,   ∇² = h'' ∇f ∇fᵀ + h' ∇²f,
            ∇ψ = h''' s² ∇f + 2 h'' s ∇²f v + h'' ψ ∇f + h' ∇ψ_f

The derivatives are exact (the chain rule evaluated at run time, as forward-mode autodiff),
not difference quotients.
"""

from __future__ import annotations

import cmath

import numpy as np

from biplan._compile.numba_cache import kernel

__all__ = [
    "GRAD",
    "HESS",
    "SIZE",
    "THIRD",
    "apply",
    "constant",
    "exp_i",
    "log",
    "product",
    "tan",
    "variable",
]

#: Entries of a jet: the value, the gradient (7), the Hessian (49) and ∇ψ (7).
SIZE = 64
#: Offsets of the gradient, the Hessian and ∇ψ in a jet.
GRAD, HESS, THIRD = 1, 8, 57


@kernel
def constant(value: complex) -> np.ndarray:  # type: ignore[type-arg]
    """The jet of a constant."""
    out = np.zeros(SIZE, dtype=np.complex128)
    out[0] = value
    return out


@kernel
def variable(value: float, k: int) -> np.ndarray:  # type: ignore[type-arg]
    """The jet of the coordinate x_k at x_k = ``value``."""
    out = np.zeros(SIZE, dtype=np.complex128)
    out[0] = value
    out[GRAD + k] = 1.0
    return out


@kernel
def _moments(a: np.ndarray, v: np.ndarray, hv: np.ndarray) -> tuple[complex, complex]:  # type: ignore[type-arg]
    """(s = ∇a·v, ψ = vᵀ ∇²a v) of a jet; fills ``hv`` (7,) with ∇²a v."""
    s = 0j
    psi = 0j
    for i in range(7):
        s += a[GRAD + i] * v[i]
        acc = 0j
        for j in range(7):
            acc += a[HESS + 7 * i + j] * v[j]
        hv[i] = acc
        psi += acc * v[i]
    return s, psi


@kernel
def product(a: np.ndarray, b: np.ndarray, v: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The jet of a b."""
    ha = np.empty(7, dtype=np.complex128)
    hb = np.empty(7, dtype=np.complex128)
    sa, pa = _moments(a, v, ha)
    sb, pb = _moments(b, v, hb)
    fa, fb = a[0], b[0]
    out = np.empty(SIZE, dtype=np.complex128)
    out[0] = fa * fb
    for i in range(7):
        gai, gbi = a[GRAD + i], b[GRAD + i]
        out[GRAD + i] = fa * gbi + fb * gai
        for j in range(7):
            k = HESS + 7 * i + j
            out[k] = fa * b[k] + fb * a[k] + gai * b[GRAD + j] + gbi * a[GRAD + j]
        out[THIRD + i] = (
            fa * b[THIRD + i]
            + fb * a[THIRD + i]
            + pb * gai
            + pa * gbi
            + 2.0 * sb * ha[i]
            + 2.0 * sa * hb[i]
        )
    return out


@kernel
def apply(
    a: np.ndarray,  # type: ignore[type-arg]
    h0: complex,
    h1: complex,
    h2: complex,
    h3: complex,
    v: np.ndarray,  # type: ignore[type-arg]
) -> np.ndarray:  # type: ignore[type-arg]
    """The jet of h(a), given h and its first three derivatives at a's value."""
    ha = np.empty(7, dtype=np.complex128)
    s, psi = _moments(a, v, ha)
    out = np.empty(SIZE, dtype=np.complex128)
    out[0] = h0
    for i in range(7):
        gi = a[GRAD + i]
        out[GRAD + i] = h1 * gi
        for j in range(7):
            k = HESS + 7 * i + j
            out[k] = h2 * gi * a[GRAD + j] + h1 * a[k]
        out[THIRD + i] = (h3 * s * s + h2 * psi) * gi + 2.0 * h2 * s * ha[i] + h1 * a[THIRD + i]
    return out


@kernel
def exp_i(a: np.ndarray, v: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The jet of e^{i a} (a rotation by the angle a)."""
    e = cmath.exp(1j * a[0])
    return apply(a, e, 1j * e, -e, -1j * e, v)


@kernel
def log(a: np.ndarray, v: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The jet of log a (principal branch: Im log(C + i S) = atan2(S, C))."""
    w = a[0]
    r = 1.0 / w
    return apply(a, cmath.log(w), r, -r * r, 2.0 * r * r * r, v)


@kernel
def tan(a: np.ndarray, v: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The jet of tan a."""
    t = cmath.tan(a[0])
    s2 = 1.0 + t * t
    return apply(a, t, s2, 2.0 * t * s2, 2.0 * s2 * (s2 + 2.0 * t * t), v)
