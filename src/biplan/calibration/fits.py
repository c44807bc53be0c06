"""Fold laws fitted to one measured Circular Folded Tube (CFT) curve: arrays in, a LawFit out.

Specimen → fold field
---------------------
A CFT is a tube of circular folds only. Each fold is one field of length H = 2πR (the
circumference) and, under an axial end load, its elongation is uniform along the fold; n
identical folds in series each carry the whole end force. Hence, with w the fold elongation
[mm] and f(w) the line force of the law [N/mm] (MODEL.md §1)::

    F = H · f(w),        u = n · w                                   (uniform fields)

where F [N] is the specimen force and u [mm] the tube extension. The fields are uniform, and
so the conversion holds, on the stable phases 1 and 2 where the specimens are measured; inside
the spinodal n > 1 folds in series open one by one and it does not (the spinodal is not
measured; it is interpolated). A law's stiffness k [N/mm²] is therefore the specimen stiffness
dF/du [N/mm] times n / H. Pressure readings convert with the end area πR²
(:attr:`CftGeometry.end_area`).

Fits (at the fold-field level)
------------------------------
* linear: least-squares line f = k w through the origin, or f = k w + c with a free offset
  (the offset is reported, not part of the law); k > 0 (:func:`scipy.optimize.lsq_linear`).
* trilinear: constrained, continuous piecewise-linear least squares. For breakpoints
  w1 < w2 the law is linear in (k1, k2, k3) in the basis
  ``[min(w, w1), clip(w − w1, 0, w2 − w1), max(w − w2, 0)]`` (the force of
  :class:`~biplan.laws.TrilinearLaw` written as a sum). Fixed breakpoints give a bounded
  linear problem (k1 > 0, k2 < 0, k3 > 0, :func:`scipy.optimize.lsq_linear`); free
  breakpoints are fitted jointly by :func:`scipy.optimize.least_squares` in the
  parametrisation ``k1 = e^p0, k2 = −e^p1, k3 = e^p2, w1 = e^p3, w2 = w1 + e^p4``, which
  guarantees k1 > 0, k2 < 0, k3 > 0 and 0 < w1 < w2, started from a grid search over
  breakpoint pairs (or a given start). Without data inside the spinodal, free breakpoints are
  identifiable only if the curve carries the interpolated spinodal (see
  :mod:`biplan.calibration.calibrate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares, lsq_linear

from biplan._errors import ConfigError, check_integer, check_range
from biplan.laws import LinearLaw, TrilinearLaw

__all__ = ["CftGeometry", "LawFit", "cft_force", "fit_linear", "fit_trilinear"]

_TINY = 1e-12


@dataclass(frozen=True)
class CftGeometry:
    """Geometry of a calibration CFT specimen.

    Parameters
    ----------
    radius : float
        Tube radius R [mm] (> 0); default 2 mm (SI Table calib).
    n_folds : int
        Number of identical circular folds in series (≥ 1).
    """

    radius: float = 2.0
    n_folds: int = 1

    def __post_init__(self) -> None:
        r = check_range("radius", self.radius, low=0.0, unit="mm")
        object.__setattr__(self, "radius", r)
        object.__setattr__(self, "n_folds", check_integer("n_folds", self.n_folds, low=1))

    @property
    def fold_length(self) -> float:
        """Field length H = 2πR [mm] of one circular fold."""
        return 2.0 * math.pi * self.radius

    @property
    def end_area(self) -> float:
        """End area πR² [mm²] on which an internal pressure acts (F = p πR²)."""
        return math.pi * self.radius**2

    def to_field(self, displacement: np.ndarray, force: np.ndarray) -> tuple[np.ndarray, ...]:
        """(w, f) = (u / n, F / H): specimen [mm, N] → fold field [mm, N/mm]."""
        u, f = np.asarray(displacement, dtype=float), np.asarray(force, dtype=float)
        return u / self.n_folds, f / self.fold_length

    def to_specimen(self, elongation: np.ndarray, line_force: np.ndarray) -> tuple[np.ndarray, ...]:
        """(u, F) = (n w, H f): fold field [mm, N/mm] → specimen [mm, N]."""
        w, f = np.asarray(elongation, dtype=float), np.asarray(line_force, dtype=float)
        return w * self.n_folds, f * self.fold_length


def cft_force(
    law: TrilinearLaw | LinearLaw, geometry: CftGeometry, displacement: np.ndarray
) -> np.ndarray:
    """Specimen force F = H f(u / n) [N] of a CFT at extension ``displacement`` u [mm].

    Uniform fields (see the module docstring): exact on the stable phases. Evaluated in NumPy
    through the fit basis (equal to ``law.force``, which compiles a JAX function per array
    shape), so that it is cheap on curves of any length.
    """
    w = np.asarray(displacement, dtype=float) / geometry.n_folds
    k1, k2, k3, w1, w2 = law.coefficients
    linear = k1 == k2 == k3
    line = k1 * w if linear else _basis(w.ravel(), w1, w2) @ np.array([k1, k2, k3])
    return np.reshape(line, w.shape) * geometry.fold_length


@dataclass(frozen=True, eq=False)
class LawFit:
    """A law fitted to one specimen-level curve.

    Attributes
    ----------
    law : TrilinearLaw or LinearLaw
        The fold-field law [N/mm², mm].
    geometry : CftGeometry
    offset : float
        Line-force offset c [N/mm] of a linear fit with a free offset (else 0).
    displacement, force : ndarray, shape (M,)
        The fitted data [mm, N].
    fitted : ndarray, shape (M,)
        The fit at the data [N].
    residual : ndarray, shape (M,)
        ``fitted − force`` [N].
    """

    law: TrilinearLaw | LinearLaw
    geometry: CftGeometry
    offset: float
    displacement: np.ndarray
    force: np.ndarray
    fitted: np.ndarray
    residual: np.ndarray

    @property
    def rms(self) -> float:
        """Root-mean-square residual [N]."""
        return float(np.sqrt(np.mean(self.residual**2)))

    @property
    def parameters(self) -> np.ndarray:
        """(k1, k2, k3, l1, l2) of a trilinear law, (k, offset) of a linear one."""
        if isinstance(self.law, TrilinearLaw):
            return np.asarray(self.law.coefficients, dtype=float)
        return np.array([self.law.stiffness, self.offset])


def _basis(w: np.ndarray, w1: float, w2: float) -> np.ndarray:
    """(M, 3) basis in which the trilinear force is linear in (k1, k2, k3)."""
    return np.stack(
        [np.minimum(w, w1), np.clip(w - w1, 0.0, w2 - w1), np.maximum(w - w2, 0.0)], axis=1
    )


def _check_curve(displacement: np.ndarray, force: np.ndarray, n_min: int) -> tuple[np.ndarray, ...]:
    u = np.asarray(displacement, dtype=float).ravel()
    f = np.asarray(force, dtype=float).ravel()
    if u.shape != f.shape:
        raise ConfigError("force", f.shape, f"the displacement's shape {u.shape}")
    if u.size < n_min or not (np.all(np.isfinite(u)) and np.all(np.isfinite(f))):
        raise ConfigError("curve", f"{u.size} points", f"at least {n_min} finite (u, F) points")
    return u, f


def _fit_fixed(w: np.ndarray, f: np.ndarray, w1: float, w2: float) -> np.ndarray:
    """(k1, k2, k3) by bounded linear least squares at fixed breakpoints."""
    scale = max(float(np.max(np.abs(f))) / max(float(np.max(np.abs(w))), _TINY), 1.0)
    lo, hi = [_TINY * scale, -np.inf, _TINY * scale], [np.inf, -_TINY * scale, np.inf]
    return np.asarray(lsq_linear(_basis(w, w1, w2), f, bounds=(lo, hi)).x)


def _grid_start(w: np.ndarray, f: np.ndarray) -> tuple[float, float]:
    """Breakpoints of the best fixed-breakpoint fit over a grid of candidate pairs."""
    lo, hi = max(float(w.min()), 0.0), float(w.max())
    cand = np.linspace(lo, hi, 22)[1:-1]
    cand = cand[cand > 0]
    best, pair = np.inf, (cand[0], cand[-1])
    for i, a in enumerate(cand):
        for b in cand[i + 1 :]:
            k = _fit_fixed(w, f, float(a), float(b))
            cost = float(np.sum((_basis(w, a, b) @ k - f) ** 2))
            if cost < best:
                best, pair = cost, (float(a), float(b))
    return pair


def _fit_free(w: np.ndarray, f: np.ndarray, start: tuple[float, float]) -> np.ndarray:
    """(k1, k2, k3, w1, w2) by nonlinear least squares from breakpoints ``start``."""
    w1, w2 = start
    k = _fit_fixed(w, f, w1, w2)
    k1, k3 = max(k[0], _TINY), max(k[2], _TINY)
    k2 = min(k[1], -1e-3 * k1)
    p0 = np.log([k1, -k2, k3, w1, w2 - w1])

    def unpack(p: np.ndarray) -> tuple[float, ...]:
        e = np.exp(p)
        return e[0], -e[1], e[2], e[3], e[3] + e[4]

    def residual(p: np.ndarray) -> np.ndarray:
        a1, a2, a3, b1, b2 = unpack(p)
        return np.asarray(_basis(w, b1, b2) @ np.array([a1, a2, a3]) - f)

    def jacobian(p: np.ndarray) -> np.ndarray:
        a1, a2, a3, b1, b2 = unpack(p)
        basis = _basis(w, b1, b2)
        dw1 = (a1 - a2) * (w > b1)
        dw2 = (a2 - a3) * (w > b2)
        return np.column_stack(
            [
                a1 * basis[:, 0],
                a2 * basis[:, 1],
                a3 * basis[:, 2],
                (dw1 + dw2) * b1,
                dw2 * (b2 - b1),
            ]
        )

    sol = least_squares(residual, p0, jac=jacobian, method="trf", x_scale="jac")
    return np.array(unpack(sol.x))


def _trilinear_params(
    w: np.ndarray,
    f: np.ndarray,
    fixed: tuple[float, float] | None = None,
    start: tuple[float, float] | None = None,
) -> np.ndarray:
    """Field-level (k1, k2, k3, w1, w2): fixed breakpoints, else free from ``start``."""
    if fixed is not None:
        return np.array([*_fit_fixed(w, f, *fixed), *fixed])
    return _fit_free(w, f, start if start is not None else _grid_start(w, f))


def _linear_params(w: np.ndarray, f: np.ndarray, offset: bool) -> np.ndarray:
    """Field-level (k, c) with k > 0; c = 0 without offset."""
    a = w[:, None] if not offset else np.column_stack([w, np.ones_like(w)])
    lo = [_TINY] + ([-np.inf] if offset else [])
    x = lsq_linear(a, f, bounds=(lo, [np.inf] * a.shape[1])).x
    return np.array([x[0], x[1] if offset else 0.0])


def _law_fit(params: np.ndarray, geometry: CftGeometry, u: np.ndarray, F: np.ndarray) -> LawFit:
    """The LawFit of field-level parameters (5: trilinear, 2: linear) on data (u, F)."""
    w = u / geometry.n_folds
    law: TrilinearLaw | LinearLaw
    if params.size == 5:
        k, t = tuple(map(float, params[:3])), tuple(map(float, params[3:]))
        law = TrilinearLaw(stiffness=k, transitions=t)  # type: ignore[arg-type]
        line = _basis(w, t[0], t[1]) @ np.asarray(k)
        offset = 0.0
    else:
        law, offset = LinearLaw(float(params[0])), float(params[1])
        line = params[0] * w + offset
    fitted = geometry.fold_length * line
    return LawFit(law, geometry, offset, u, F, fitted, fitted - F)


def fit_trilinear(
    displacement: np.ndarray,
    force: np.ndarray,
    geometry: CftGeometry | None = None,
    *,
    breakpoints: tuple[float, float] | None = None,
    start: tuple[float, float] | None = None,
) -> LawFit:
    """Fit a trilinear law (k1 > 0, k2 < 0, k3 > 0, 0 < w1 < w2) to a CFT curve.

    Parameters
    ----------
    displacement, force : array_like, shape (M,)
        Specimen extension u [mm] and force F [N] (e.g. :meth:`Band.fit_curve`).
    geometry : CftGeometry, optional
        Default R = 2 mm, one fold.
    breakpoints : (float, float), optional
        Fixed specimen-level breakpoints (u1, u2) [mm], 0 < u1 < u2 (e.g. the measured
        stability limits); the field breakpoints are u / n. Default: fitted.
    start : (float, float), optional
        Specimen-level starting breakpoints of a free fit [mm]; default a grid search.

    Returns
    -------
    LawFit

    Raises
    ------
    ConfigError
        On fewer than 5 finite points or invalid breakpoints.
    """
    geometry = geometry or CftGeometry()
    u, F = _check_curve(displacement, force, 5)
    w, f = geometry.to_field(u, F)
    n = geometry.n_folds
    fixed = None
    if breakpoints is not None:
        b1 = check_range("breakpoints[0]", breakpoints[0], low=0.0)
        b2 = check_range("breakpoints[1]", breakpoints[1], low=b1)
        fixed = (b1 / n, b2 / n)
    s = (start[0] / n, start[1] / n) if start is not None else None
    return _law_fit(_trilinear_params(w, f, fixed, s), geometry, u, F)


def fit_linear(
    displacement: np.ndarray,
    force: np.ndarray,
    geometry: CftGeometry | None = None,
    *,
    offset: bool = False,
) -> LawFit:
    """Fit a linear law f = k w (+ c) with k > 0 to a CFT curve by least squares.

    Parameters
    ----------
    displacement, force : array_like, shape (M,)
        Specimen extension u [mm] and force F [N].
    geometry : CftGeometry, optional
    offset : bool
        Fit a free line-force offset c [N/mm] (reported in :attr:`LawFit.offset`).

    Returns
    -------
    LawFit
    """
    geometry = geometry or CftGeometry()
    u, F = _check_curve(displacement, force, 2)
    w, f = geometry.to_field(u, F)
    return _law_fit(_linear_params(w, f, offset), geometry, u, F)
