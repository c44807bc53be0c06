"""Constrained climbing-image nudged elastic band: the compiled kernel (one per layout).

The band is a fixed-shape array of images q_0 … q_{M−1} (n_q each); q_0 and q_{M−1} are the
two stable states and stay fixed. One ``jax.lax.while_loop`` runs the whole optimisation, each
pass ``vmap``-ping over the images:

1. **Constraint-projected gradient.** With c = [g(q); w_∂(q)] (guides, contact gaps) and its
   Jacobian, the *active* rows are the guides and the contacts that are closed (w_∂ < the
   contact tolerance) and pushed on (a positive least-squares multiplier; contacts with a
   negative one are released and the multipliers re-estimated once). The projected gradient is
   the least-squares residual ∇Π + Gᵀλ − C_aᵀλ_∂ = P ∇Π, P the orthogonal projector onto the
   null space of the active rows (pseudo-inverse, so a rank-deficient set is harmless).
2. **NEB force** (Henkelman & Jónsson 2000): improved energy-weighted tangent τ, projected by
   P and normalised; F = −(P∇Π)_⊥ + k (|q_{i+1} − q_i| − |q_i − q_{i−1}|) τ, and for the
   climbing image (highest interior energy, once switched on) F = −P∇Π + 2 (P∇Π · τ) τ
   (Henkelman, Uberuaga & Jónsson 2000).
3. **FIRE** step (Bitzek et al. 2006) on the interior images, the step capped per image.
4. **Return to the manifold.** Each image is pulled back by minimum-norm Gauss–Newton steps
   on [g(q); min(w_∂(q), 0)] (guides exactly, penetrated contacts to zero gap), run by the
   Newton core (:func:`project`).

Convergence: max |F| over the interior images below the tolerance, with the climbing image on.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from biplan._compile import linalg
from biplan._compile.setup import jax, jnp
from biplan._compile.traced import traced
from biplan.geometry.layout import TubeLayout
from biplan.model.lagrangian import sizes
from biplan.model.params import ModelParams
from biplan.model.potential import contact_gaps, energy, guide_values
from jax_oracle.core import iterate
from jax_oracle.settings import Settings
from jax_oracle.strategies import minimum_norm

__all__ = ["BandOutput", "band_forces", "fire_band", "project"]

Array = Any

#: Gauss–Newton iterations of the return to the constraint manifold after each step.
PROJECTION_ITERATIONS = 4
#: Constraint violation [mm] below which the return stops early.
PROJECTION_TOLERANCE = 1e-13
#: FIRE constants (Bitzek et al. 2006).
FIRE_N_MIN, FIRE_INC, FIRE_DEC, FIRE_ALPHA0, FIRE_FALPHA = 5, 1.1, 0.5, 0.1, 0.99


class BandOutput(NamedTuple):
    """Outcome of a band relaxation."""

    q: Array  # (M, n_q) images
    energy: Array  # (M,) Π [N·mm]
    guide_multipliers: Array  # (M, n_g) least-squares λ [N]
    contact_multipliers: Array  # (M, n_c) least-squares λ_∂ [N] (0 off the active set)
    max_force: Array  # max |F| over the interior images [N]
    climbing: Array  # index of the climbing image (−1 if never switched on)
    iterations: Array
    constraint_residual: Array  # max |g| and max(−w_∂, 0) over the band [mm]


def _constraints(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    return jnp.concatenate([guide_values(layout, p, q), contact_gaps(layout, p, q)])


def _lstsq(a: Array, b: Array) -> Array:
    """Minimum-norm least-squares x of aᵀx ≈ b (rows of a may be zero)."""
    return linalg.pinv(a.T, rtol=1e-10) @ b


def image_gradient(
    layout: TubeLayout, p: ModelParams, q: Array, contact_tol: Array
) -> tuple[Array, Array, Array, Array, Array]:
    """(Π, P∇Π, λ, λ_∂, A) at one image: energy [N·mm], projected gradient, multipliers [N]
    and the active signed constraint rows A (inactive rows zero)."""
    _nq, ng, _nc = sizes(layout)
    e, grad = jax.value_and_grad(lambda x: energy(layout, p, x))(q)
    c = _constraints(layout, p, q)
    jac = jax.jacfwd(lambda x: _constraints(layout, p, x))(q)
    gap = c[ng:]
    near = gap < contact_tol
    # rows of A with a sign: guides +G, contacts −C (stationarity ∇Π + Gᵀλ − Cᵀλ_∂ = 0)
    signed = jnp.concatenate([jac[:ng], -jac[ng:]])

    def solve(active_c: Array) -> Array:
        rows = jnp.where(jnp.concatenate([jnp.ones(ng, bool), active_c])[:, None], signed, 0.0)
        return _lstsq(rows, -grad), rows

    mult, rows = solve(near)
    pushed = near & (mult[ng:] > 0.0)
    mult, rows = solve(pushed)
    proj = grad + rows.T @ mult
    lam_c = jnp.where(pushed, mult[ng:], 0.0)
    return e, proj, mult[:ng], lam_c, rows


def _project_direction(rows: Array, v: Array) -> Array:
    """v minus its component in the row space of the active constraint rows."""
    return v - linalg.pinv(rows, rtol=1e-10) @ (rows @ v)


def project(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    """Return one image to the constraint manifold: g(q) = 0, w_∂(q) ≥ 0 — minimum-norm
    Gauss–Newton steps on [g(q); min(w_∂(q), 0)] by the Newton core
    (jax_oracle.core.iterate` with :func:`~jax_oracle.strategies.minimum_norm`):
    :data:`PROJECTION_ITERATIONS` full steps (the watchdog's free steps), ending at the
    iterate of smallest violation, or earlier below :data:`PROJECTION_TOLERANCE`."""
    _nq, ng, nc = sizes(layout)

    def res(x: Array) -> Array:
        c = _constraints(layout, p, x)
        return jnp.concatenate([c[:ng], jnp.minimum(c[ng:], 0.0)])

    settings = Settings.of(PROJECTION_TOLERANCE, PROJECTION_ITERATIONS, 1, 1e-4, 0)
    out = iterate(
        res,
        jax.jacfwd(res),
        q,
        settings,
        free_steps=PROJECTION_ITERATIONS,
        levenberg_marquardt=False,
        solve=minimum_norm,
        n_equations=ng + nc,
    )
    return out.z


def band_forces(
    layout: TubeLayout, p: ModelParams, q: Array, spring: Array, contact_tol: Array, climb: Array
) -> tuple[Array, Array, Array, Array, Array]:
    """NEB forces (M, n_q) of a band; also energies, multipliers and the climbing index.

    ``climb`` (bool scalar): whether the highest interior image climbs.
    """
    e, grad, lam, lam_c, rows = jax.vmap(lambda x: image_gradient(layout, p, x, contact_tol))(q)
    m = q.shape[0]
    d_next = q[2:] - q[1:-1]
    d_prev = q[1:-1] - q[:-2]
    e_prev, e_mid, e_next = e[:-2], e[1:-1], e[2:]
    # improved tangent (Henkelman & Jónsson 2000)
    up = (e_next > e_mid) & (e_mid > e_prev)
    down = (e_next < e_mid) & (e_mid < e_prev)
    dmax = jnp.maximum(jnp.abs(e_next - e_mid), jnp.abs(e_prev - e_mid))
    dmin = jnp.minimum(jnp.abs(e_next - e_mid), jnp.abs(e_prev - e_mid))
    mixed = jnp.where(
        (e_next > e_prev)[:, None],
        dmax[:, None] * d_next + dmin[:, None] * d_prev,
        dmin[:, None] * d_next + dmax[:, None] * d_prev,
    )
    tau = jnp.where(up[:, None], d_next, jnp.where(down[:, None], d_prev, mixed))
    tau = jax.vmap(_project_direction)(rows[1:-1], tau)
    tau = tau / (jnp.linalg.norm(tau, axis=1, keepdims=True) + 1e-300)
    g = grad[1:-1]
    g_par = jnp.sum(g * tau, axis=1, keepdims=True)
    spring_f = spring * (
        jnp.linalg.norm(d_next, axis=1, keepdims=True)
        - jnp.linalg.norm(d_prev, axis=1, keepdims=True)
    )
    neb = -(g - g_par * tau) + spring_f * tau
    top = jnp.argmax(e_mid)
    climbing = -g + 2.0 * g_par * tau
    is_top = (jnp.arange(m - 2) == top)[:, None] & climb
    f = jnp.where(is_top, climbing, neb)
    f = jnp.concatenate([jnp.zeros_like(q[:1]), f, jnp.zeros_like(q[:1])])
    return f, e, lam, lam_c, top + 1


class _State(NamedTuple):
    q: Array
    v: Array
    dt: Array
    alpha: Array
    n_pos: Array
    climb: Array  # climbing image on for the next force evaluation
    climbed: Array  # climbing image was on for the last one (fmax)
    fmax: Array
    it: Array


@traced("band")
def fire_band(layout: TubeLayout, p: ModelParams, q0: Array, settings: Array) -> BandOutput:
    """Relax a band q0 (M, n_q) whose end images are stationary states (pure; jit/vmap-able).

    ``settings`` = [spring, tolerance, max_iterations, climbing (0/1), dt, dt_max, max_step,
    contact_tol, climb_start]: spring [N/mm], tolerance [N], FIRE time steps, max step [mm],
    contact tolerance [mm], force below which the climbing image switches on [N].
    """
    spring, tol, max_it, use_climb = settings[0], settings[1], settings[2], settings[3] > 0.5
    dt0, dt_max, max_step, contact_tol, climb_start = (
        settings[4],
        settings[5],
        settings[6],
        settings[7],
        settings[8],
    )
    _nq, ng, _nc = sizes(layout)
    proj = jax.vmap(lambda x: project(layout, p, x))
    interior = jnp.zeros(q0.shape[0], bool).at[1:-1].set(True)[:, None]
    q_start = jnp.where(interior, proj(q0), q0)

    def forces(q: Array, climb: Array) -> Array:
        return band_forces(layout, p, q, spring, contact_tol, climb)[0]

    def body(s: _State) -> _State:
        f = forces(s.q, s.climb)
        power = jnp.sum(f * s.v)
        fn = jnp.linalg.norm(f) + 1e-300
        vn = jnp.linalg.norm(s.v)
        v = (1.0 - s.alpha) * s.v + s.alpha * vn * f / fn
        good = power > 0.0
        n_pos = jnp.where(good, s.n_pos + 1, 0)
        grow = good & (n_pos > FIRE_N_MIN)
        dt = jnp.where(
            grow, jnp.minimum(s.dt * FIRE_INC, dt_max), jnp.where(good, s.dt, s.dt * FIRE_DEC)
        )
        alpha = jnp.where(grow, s.alpha * FIRE_FALPHA, jnp.where(good, s.alpha, FIRE_ALPHA0))
        v = jnp.where(good, v, 0.0) + dt * f
        step = dt * v
        norm = jnp.max(jnp.abs(step), axis=1, keepdims=True)
        step = step * jnp.minimum(1.0, max_step / (norm + 1e-300))
        q = s.q + jnp.where(interior, step, 0.0)
        q = jnp.where(interior, proj(q), s.q)
        q = jnp.where(jnp.all(jnp.isfinite(q)), q, s.q)
        fmax = jnp.max(jnp.abs(f))
        climb = s.climb | (use_climb & (fmax < climb_start))
        return _State(q, v, dt, alpha, n_pos, climb, s.climb, fmax, s.it + 1)

    def cond(s: _State) -> Array:
        done = (s.fmax < tol) & (s.climbed | ~use_climb)
        return ~done & (s.it < max_it)

    init = _State(
        q=q_start,
        v=jnp.zeros_like(q0),
        dt=dt0,
        alpha=jnp.asarray(FIRE_ALPHA0),
        n_pos=jnp.asarray(0),
        climb=jnp.asarray(False),
        climbed=jnp.asarray(False),
        fmax=jnp.asarray(jnp.inf),
        it=jnp.asarray(0),
    )
    out = jax.lax.while_loop(cond, body, init)
    _f, e, lam, lam_c, top = band_forces(layout, p, out.q, spring, contact_tol, out.climb)
    c = jax.vmap(lambda x: _constraints(layout, p, x))(out.q)
    viol = jnp.maximum(jnp.max(jnp.abs(c[:, :ng])), jnp.max(jnp.maximum(-c[:, ng:], 0.0)))
    return BandOutput(
        q=out.q,
        energy=e,
        guide_multipliers=lam,
        contact_multipliers=lam_c,
        max_force=out.fmax,
        climbing=jnp.where(out.climb, top, -1),
        iterations=out.it,
        constraint_residual=viol,
    )
