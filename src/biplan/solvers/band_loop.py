"""Constrained climbing-image nudged elastic band on the compiled system (Numba).

The band is an array of images q_0 … q_{M−1} (n_q each); q_0 and q_{M−1} are the two stable
states and stay fixed. :func:`fire_band` runs the whole optimisation:

1. **Constraint-projected gradient** (:func:`image_gradient`). With c = [g(q); w_∂(q)]
   (guides, contact gaps) and its Jacobian, the *active* rows are the guides and the contacts
   that are closed (w_∂ < the contact tolerance) and pushed on (a positive least-squares
   multiplier; contacts with a negative one are released and the multipliers re-estimated
   once). The projected gradient is the least-squares residual ∇Π + Gᵀλ − C_aᵀλ_∂ = P ∇Π,
   P the orthogonal projector onto the null space of the active rows (pseudo-inverse, so a
   rank-deficient set is harmless).
2. **NEB force** (:func:`band_forces`; Henkelman & Jónsson 2000): improved energy-weighted
   tangent τ, projected by P and normalised; F = −(P∇Π)_⊥ + k (|q_{i+1} − q_i| −
   |q_i − q_{i−1}|) τ, and for the climbing image (highest interior energy, once switched on)
   F = −P∇Π + 2 (P∇Π · τ) τ (Henkelman, Uberuaga & Jónsson 2000).
3. **FIRE** step (Bitzek et al. 2006) on the interior images, the step capped per image.
4. **Return to the manifold** of every interior image (:func:`biplan.solvers.manifold.project`).

Convergence: max |F| over the interior images below the tolerance, with the climbing image on.
The algorithm, its constants and its iterates are those of the JAX kernel it replaces
(the tests' oracle ``tests/jax_oracle/neb.py``), up to rounding.
"""

from __future__ import annotations

from typing import NamedTuple, cast

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.assemble import _FIRST, _SECOND, _terms
from biplan.model.system.tables import SystemData
from biplan.solvers.manifold import pinv, project

__all__ = [
    "FIRE_ALPHA0",
    "FIRE_DEC",
    "FIRE_FALPHA",
    "FIRE_INC",
    "FIRE_N_MIN",
    "BandSettings",
    "band_forces",
    "fire_band",
    "image_gradient",
]

#: False as a run-time value (a literal would compile a specialisation of its own)
_OFF = cast(bool, np.False_)
#: FIRE constants (Bitzek et al. 2006).
FIRE_N_MIN, FIRE_INC, FIRE_DEC, FIRE_ALPHA0, FIRE_FALPHA = 5, 1.1, 0.5, 0.1, 0.99


@kernel
def _multipliers(signed: np.ndarray, active: np.ndarray, grad: np.ndarray) -> tuple:  # type: ignore[type-arg]
    """(least-squares multipliers x of rowsᵀ x ≈ −∇Π, the rows, pinv(rowsᵀ)): ``rows`` the
    signed constraint rows where ``active`` (zero elsewhere)."""
    rows = signed.copy()
    for i in range(rows.shape[0]):
        if not active[i]:
            rows[i] = 0.0
    inverse = pinv(np.ascontiguousarray(rows.T))
    return inverse @ -grad, rows, inverse


@kernel
def image_gradient(d: SystemData, q: np.ndarray, contact_tol: float) -> tuple:  # type: ignore[type-arg]
    """(Π [N·mm], P∇Π (n_q,), λ (n_g,) [N], λ_∂ (n_c,) [N] (0 off the active set), active
    signed rows A (n_g + n_c, n_q), pinv(Aᵀ)) at one image (module docstring, step 1);
    ``contact_tol`` [mm]."""
    n_g, n_c = d.sizes[1], d.sizes[2]
    t = _terms(d, q, np.zeros(n_g), np.zeros(n_c), _SECOND)
    grad, gaps = t[0], t[3]
    energy = np.sum(t[6]) + np.sum(t[7])
    # rows with a sign: guides +G, contacts −C (stationarity ∇Π + Gᵀλ − Cᵀλ_∂ = 0)
    signed = np.empty((n_g + n_c, grad.shape[0]))
    signed[:n_g] = t[4]
    signed[n_g:] = -t[5]
    active = np.ones(n_g + n_c, dtype=np.bool_)
    for i in range(n_c):
        active[n_g + i] = gaps[i] < contact_tol
    mult, rows, inverse = _multipliers(signed, active, grad)
    released = False
    for i in range(n_c):
        if active[n_g + i] and not mult[n_g + i] > 0.0:
            active[n_g + i] = False
            released = True
    if released:  # else the same set: the same multipliers
        mult, rows, inverse = _multipliers(signed, active, grad)
    proj = grad + rows.T @ mult
    lam_c = np.zeros(n_c)
    for i in range(n_c):
        if active[n_g + i]:
            lam_c[i] = mult[n_g + i]
    return energy, proj, mult[:n_g].copy(), lam_c, rows, inverse


@kernel
def _argmax(x: np.ndarray) -> int:
    """Index of the largest entry, the first NaN counting as largest (as ``jnp.argmax``)."""
    best = 0
    for i in range(x.shape[0]):
        if x[i] != x[i]:
            return i
        if x[i] > x[best]:
            best = i
    return best


@kernel(inline="always")
def _gradients(
    d: SystemData, q: np.ndarray, contact_tol: float, first: int, last: int, out: tuple
) -> None:  # type: ignore[type-arg]
    """:func:`image_gradient` of the images ``first`` … ``last − 1`` of q into the arrays
    ``out`` = (Π (M,), P∇Π (M, n_q), λ (M, n_g), λ_∂ (M, n_c), A (M, n_g + n_c, n_q),
    pinv(Aᵀ) (M, n_g + n_c, n_q)). Inlined into :func:`fire_band`, its one caller."""
    e, grad, lam, lam_c, rows, inverses = out
    for i in range(first, last):
        e[i], grad[i], lam[i], lam_c[i], rows[i], inverses[i] = image_gradient(d, q[i], contact_tol)


@kernel
def _band_arrays(d: SystemData, m: int) -> tuple:  # type: ignore[type-arg]
    """The arrays of :func:`_gradients` for a band of m images."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    return (
        np.empty(m),
        np.empty((m, n_q)),
        np.empty((m, n_g)),
        np.empty((m, n_c)),
        np.empty((m, n_g + n_c, n_q)),
        np.empty((m, n_g + n_c, n_q)),
    )


@kernel
def _forces(q: np.ndarray, arrays: tuple, spring: float, climb: bool) -> tuple:  # type: ignore[type-arg]
    """(F (M, n_q), index of the highest interior image) from the image data ``arrays`` of
    :func:`_gradients` (module docstring, step 2)."""
    e, grad, _, _, rows, inverses = arrays
    m, n_q = q.shape
    top = _argmax(e[1 : m - 1])
    f = np.zeros((m, n_q))
    for i in range(1, m - 1):
        d_next, d_prev = q[i + 1] - q[i], q[i] - q[i - 1]
        e_prev, e_mid, e_next = e[i - 1], e[i], e[i + 1]
        # improved tangent (Henkelman & Jónsson 2000)
        if e_next > e_mid and e_mid > e_prev:
            tau = d_next
        elif e_next < e_mid and e_mid < e_prev:
            tau = d_prev
        else:
            dmax = max(abs(e_next - e_mid), abs(e_prev - e_mid))
            dmin = min(abs(e_next - e_mid), abs(e_prev - e_mid))
            if e_next > e_prev:
                tau = dmax * d_next + dmin * d_prev
            else:
                tau = dmin * d_next + dmax * d_prev
        # the tangent projected off the active rows A: τ − A⁺ A τ, A⁺ = pinv(Aᵀ)ᵀ
        tau = tau - inverses[i].T @ (rows[i] @ tau)
        tau = tau / (np.sqrt(np.sum(tau * tau)) + 1e-300)
        g = grad[i]
        g_par = np.sum(g * tau)
        if climb and i - 1 == top:
            f[i] = -g + 2.0 * g_par * tau
        else:
            stretch = np.sqrt(np.sum(d_next * d_next)) - np.sqrt(np.sum(d_prev * d_prev))
            f[i] = -(g - g_par * tau) + spring * stretch * tau
    return f, top + 1


@kernel
def band_forces(
    d: SystemData, q: np.ndarray, spring: float, contact_tol: float, climb: bool
) -> tuple:  # type: ignore[type-arg]
    """(NEB forces F (M, n_q) [N] (zero at the ends), Π (M,) [N·mm], λ (M, n_g) [N],
    λ_∂ (M, n_c) [N], index of the highest interior image) of a band q (M, n_q); ``spring``
    k [N/mm], ``contact_tol`` [mm], ``climb``: whether the highest interior image climbs."""
    arrays = _band_arrays(d, q.shape[0])
    _gradients(d, q, contact_tol, 0, q.shape[0], arrays)
    f, top = _forces(q, arrays, spring, climb)
    return f, arrays[0], arrays[2], arrays[3], top


class BandSettings(NamedTuple):
    """The settings of :func:`fire_band`, by name
    (:meth:`biplan.analysis.states.barriers.NudgedElasticBand.loop_settings`).

    Attributes
    ----------
    spring : float
        Spring constant between images [N/mm].
    tolerance : float
        Largest force on an interior image at convergence [N].
    max_iterations : int
        FIRE time steps.
    climbing : bool
        Switch the climbing image on.
    time_step, max_time_step : float
        FIRE's initial and largest time step.
    max_step : float
        Largest move of an image coordinate in one step [mm or rad].
    contact_tolerance : float
        Gap [mm] below which a contact row is active.
    climb_start : float
        Force [N] below which the climbing image switches on.
    """

    spring: float
    tolerance: float
    max_iterations: int
    climbing: bool
    time_step: float
    max_time_step: float
    max_step: float
    contact_tolerance: float
    climb_start: float


@kernel
def fire_band(d: SystemData, q0: np.ndarray, settings: BandSettings) -> tuple:  # type: ignore[type-arg]
    """Relax a band q0 (M, n_q) whose end images are stationary states (module docstring);
    ``settings``: :class:`BandSettings`.

    Returns (q (M, n_q), Π (M,) [N·mm], λ (M, n_g) [N], λ_∂ (M, n_c) [N], max |F| over the
    interior images [N], index of the climbing image (−1 if never switched on), FIRE
    iterations, max |g| and max(−w_∂, 0) over the band [mm]).
    """
    spring, tol = settings.spring, settings.tolerance
    max_it, use_climb = settings.max_iterations, settings.climbing
    dt, dt_max, max_step = settings.time_step, settings.max_time_step, settings.max_step
    contact_tol, climb_start = settings.contact_tolerance, settings.climb_start
    m, n_q = q0.shape
    q = q0.copy()
    for i in range(1, m - 1):
        q[i] = project(d, q0[i])
    arrays = _band_arrays(d, m)
    _gradients(d, q, contact_tol, 0, 1, arrays)  # the end images stay: once
    _gradients(d, q, contact_tol, m - 1, m, arrays)
    v = np.zeros((m, n_q))
    alpha, n_pos = FIRE_ALPHA0, 0
    climb = climbed = _OFF
    fmax, it = np.inf, 0
    while not (fmax < tol and (climbed or not use_climb)) and it < max_it:
        _gradients(d, q, contact_tol, 1, m - 1, arrays)
        f = _forces(q, arrays, spring, climb)[0]
        power = np.sum(f * v)
        fn = np.sqrt(np.sum(f * f)) + 1e-300
        vn = np.sqrt(np.sum(v * v))
        mixed = (1.0 - alpha) * v + alpha * vn * f / fn
        good = power > 0.0
        n_pos = n_pos + 1 if good else 0
        if good and n_pos > FIRE_N_MIN:
            dt, alpha = min(dt * FIRE_INC, dt_max), alpha * FIRE_FALPHA
        elif not good:
            dt, alpha = dt * FIRE_DEC, FIRE_ALPHA0
        v = (mixed if good else np.zeros((m, n_q))) + dt * f
        new = q.copy()
        for i in range(1, m - 1):
            step = dt * v[i]
            scale = min(1.0, max_step / (np.max(np.abs(step)) + 1e-300))
            new[i] = project(d, q[i] + step * scale)
        if np.all(np.isfinite(new)):
            q = new
        fmax = np.max(np.abs(f))
        climbed = climb
        climb = climb or (use_climb and fmax < climb_start)
        it += 1
    _gradients(d, q, contact_tol, 1, m - 1, arrays)
    top = _forces(q, arrays, spring, climb)[1]
    e, lam, lam_c = arrays[0], arrays[2], arrays[3]
    violation = 0.0
    n_g = d.sizes[1]
    for i in range(m):
        t = _terms(d, q[i], np.zeros(n_g), np.zeros(d.sizes[2]), _FIRST)
        violation = max(violation, np.max(np.abs(t[2])), np.max(-t[3]))
    return q, e, lam, lam_c, fmax, top if climb else -1, it, violation
