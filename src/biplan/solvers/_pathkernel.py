"""The compiled core of path following: a corrector and a whole adaptive path in one loop.

The load parameter Λ enters the loading affinely, ``Load(F = c_F Λ, U = c_U Λ, d)`` with
``ctl = (c_F, c_U, d)``: force control (1, 0, 0), displacement control (0, 1, 1), pressure
(πR², 0, 0). The corrector solves the augmented system (Riks/Crisfield; Allgower & Georg)::

    r(z, Λ) = 0,     c_zᵀ z + c_Λ Λ = ρ

by Newton on the bordered matrix [[J, ∂r/∂Λ], [c_zᵀ, c_Λ]]. The side condition is either the
pseudo-arclength hyperplane through the predictor, orthogonal to the tangent in the weighted
norm ‖(δq, δΛ)‖² = δqᵀδq + w_Λ² δΛ² (multipliers carry no weight), or Λ = Λ_target (natural
parameter stepping and the final step onto the stop value).

:func:`path_loop` runs the predictor–corrector with step adaptation inside one
``lax.while_loop`` and writes the accepted states into fixed-size buffers, so a whole path is
one compiled call per tube layout and buffer size.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from biplan._compile import linalg
from biplan._compile.kernel import kernel
from biplan._compile.setup import jax, jnp
from biplan.geometry.layout import TubeLayout
from biplan.model.lagrangian import kkt_jacobian, residual, sizes
from biplan.model.params import Load, ModelParams
from biplan.solvers.core_settings import Status
from biplan.solvers.observe import Observation, observe_from_jacobian
from biplan.solvers.strategies import damped, residual_norm

Array = Any

#: Codes of the loop status (see ``PathStatus``).
RUNNING, COMPLETED, MAX_STEPS, STALLED = -1, 0, 1, 2
#: The path would have run back past its start value (the step is not recorded), or it passed
#: a limit point of Λ and was asked to stop there (the step past it is recorded).
RETURNED, LIMIT_POINT = 5, 6


def load_of(ctl: Array, load_parameter: Array) -> Load:
    """The Load at parameter Λ for control coefficients ``ctl = (c_F, c_U, d)``."""
    return Load(ctl[0] * load_parameter, ctl[1] * load_parameter, ctl[2])


def _weights(layout: TubeLayout, n: int) -> Array:
    nq, _, _ = sizes(layout)
    return jnp.concatenate([jnp.ones(nq), jnp.zeros(n - nq)])


def _blocks(layout: TubeLayout, p: ModelParams, z: Array, load_parameter: Array, ctl: Array):
    def r_of(zz: Array, ll: Array) -> Array:
        return residual(layout, p, zz, load_of(ctl, ll))

    r, r_load = jax.jvp(lambda ll: r_of(z, ll), (load_parameter,), (jnp.ones_like(load_parameter),))
    jac = kkt_jacobian(layout, p, z, load_of(ctl, load_parameter))
    return r, r_load, jac


def _bordered_solve(jac: Array, r_load: Array, row_z: Array, row_l: Array, rhs: Array) -> Array:
    top = jnp.concatenate([jac, r_load[:, None]], axis=1)
    bottom = jnp.concatenate([row_z, row_l[None]])[None, :]
    return linalg.solve(jnp.concatenate([top, bottom], axis=0), rhs)


class CorrectorOut(NamedTuple):
    z: Array
    load_parameter: Array
    converged: Array
    iterations: Array
    residual: Array  # ‖r‖∞ at the returned point
    jac: Array  # Jacobian blocks at the returned point (for the tangent)
    r_load: Array


@kernel("corrector", in_axes=(None, 0, 0, None, 0, 0, 0, None, None), axis_name="lanes")
def corrector(
    layout: TubeLayout,
    p: ModelParams,
    z0: Array,
    load_parameter0: Array,
    ctl: Array,
    row_z: Array,
    row_l: Array,
    rho: Array,
    atol: Array,
    max_iterations: Array,
    axis_name: str | None = None,
) -> CorrectorOut:
    """Damped Newton (:func:`biplan.solvers.strategies.damped`) on the bordered system from
    (z0, Λ0); pure, jit/vmap-able. ``axis_name``: the enclosing ``vmap`` axis, if any."""
    n = z0.shape[0]

    def aug(x: Array) -> Array:
        z, load_parameter = x[:n], x[n]
        r = residual(layout, p, z, load_of(ctl, load_parameter))
        return jnp.concatenate([r, (row_z @ z + row_l * load_parameter - rho)[None]])

    def jac(x: Array) -> Array:
        _, r_load, j = _blocks(layout, p, x[:n], x[n], ctl)
        top = jnp.concatenate([j, r_load[:, None]], axis=1)
        return jnp.concatenate([top, jnp.concatenate([row_z, row_l[None]])[None, :]], axis=0)

    x0 = jnp.concatenate([z0, load_parameter0[None]])
    out = damped(aug, jac, x0, atol, max_iterations, axis_name=axis_name)
    return CorrectorOut(
        out.z[:n],
        out.z[n],
        out.status == Status.CONVERGED.value,
        out.steps,
        residual_norm(out),
        out.jac[:n, :n],
        out.jac[:n, n],
    )


def tangent(jac: Array, r_load: Array, weights: Array, w_lam: Array, previous: Array) -> Array:
    """Unit tangent (weighted norm) of the solution curve, oriented along ``previous``."""
    n = jac.shape[0]
    row_z = weights * previous[:n]
    row_l = w_lam**2 * previous[n]
    rhs = jnp.zeros(n + 1).at[n].set(1.0)
    t = _bordered_solve(jac, r_load, row_z, row_l, rhs)
    norm = jnp.sqrt(jnp.sum(weights * t[:n] ** 2) + (w_lam * t[n]) ** 2)
    return t / norm


class PathBuffers(NamedTuple):
    z: Array  # (B, n)
    load_parameter: Array  # (B,)
    tangent: Array  # (B, n + 1)
    step: Array  # (B,) step length that reached the state
    iterations: Array  # (B,)
    count: Array  # accepted states (incl. the start)
    cutbacks: Array
    status: Array
    observation: Observation  # (B, …) of every accepted state, from its corrector's Jacobian


@kernel("path", statics=2)
def path_loop(
    layout: TubeLayout,
    buffer_size: int,
    p: ModelParams,
    z0: Array,
    load_parameter0: Array,
    ctl: Array,
    stop: Array,
    settings: Array,
) -> PathBuffers:
    """Adaptive predictor–corrector path from (z0, Λ0) toward Λ = ``stop``.

    ``settings = [natural, ds0, ds_min, ds_max, grow, max_steps, atol, max_iterations, w_Λ,
    stop_at_limit]``; natural = 1 steps Λ by ds (load stepping), 0 uses pseudo-arclength steps
    ds; stop_at_limit = 1 ends the loop (``LIMIT_POINT``) at the first state past a limit point
    of Λ (the Λ-component of the tangent turned against the direction of ``stop``).

    A corrected state whose Λ lies beyond the start value on the far side from ``stop`` ends
    the loop with ``RETURNED`` before it is recorded: the path never runs back past its own
    start.
    """
    natural = settings[0] > 0.5
    ds0, ds_min, ds_max, grow = settings[1], settings[2], settings[3], settings[4]
    max_steps, atol, max_it, w_lam = settings[5], settings[6], settings[7], settings[8]
    stop_at_limit = settings[9] > 0.5
    n = z0.shape[0]
    weights = _weights(layout, n)
    direction = jnp.sign(stop - load_parameter0)

    weak = layout.options.weak_contacts_active

    def observed(z: Array, load_parameter: Array, jac: Array) -> Observation:
        return observe_from_jacobian(layout, p, z, load_of(ctl, load_parameter), jac, weak)

    # The start's tangent and observation come from the loop's first pass: a corrector with
    # no step (Λ fixed at Λ0) evaluates the Jacobian at z0, so the kernel holds one residual
    # and one Jacobian site, not a second pair for the start (half the compile time).
    t_orient = jnp.zeros(n + 1).at[n].set(direction)
    shapes = jax.eval_shape(observed, z0, load_parameter0, jnp.zeros((n, n)))

    buf = PathBuffers(
        z=jnp.zeros((buffer_size, n)).at[0].set(z0),
        load_parameter=jnp.zeros(buffer_size).at[0].set(load_parameter0),
        tangent=jnp.zeros((buffer_size, n + 1)),
        step=jnp.zeros(buffer_size),
        iterations=jnp.zeros(buffer_size, dtype=int),
        count=jnp.asarray(1),
        cutbacks=jnp.asarray(0),
        status=jnp.asarray(RUNNING),
        observation=jax.tree_util.tree_map(
            lambda v: jnp.zeros((buffer_size, *v.shape), v.dtype), shapes
        ),
    )

    def cond(s: tuple) -> Array:
        return s[0].status == RUNNING

    def body(s: tuple) -> tuple:
        b, z, load_parameter, t, ds, fails, started = s
        first = ~started
        tz, tl = t[:n], t[n]
        # predictor
        h = ds * direction
        tl_safe = jnp.where(jnp.abs(tl) > 1e-12, tl, 1e-12)
        # natural step: tangent predictor (load stepping) or, as an arclength retry, none
        z_nat = jnp.where(natural, z + (h / tl_safe) * tz, z)
        l_nat = load_parameter + h
        z_arc, l_arc = z + ds * tz, load_parameter + ds * tl
        # Retry cycle after failures (arclength only): pseudo-arclength → local
        # parametrisation → natural step of Λ; the step halves after a full failed cycle.
        mode = jnp.where(natural, 2, fails % 3)
        zp = jnp.where(mode == 2, z_nat, z_arc)
        lp = jnp.where(mode == 2, l_nat, l_arc)
        # the first pass stays at the start: Λ fixed at Λ0, z0 as the predictor, no step
        zp = jnp.where(first, z, zp)
        lp = jnp.where(first, load_parameter, lp)
        final = ~first & ((lp - stop) * direction >= 0.0)
        # side condition: hyperplane ⟂ tangent, or Λ fixed (natural / final step)
        fix = (mode == 2) | final | first
        # After a failed pseudo-arclength corrector, alternate with the local parametrisation
        # by the coordinate that changes fastest (Rheinboldt): it passes the corners of the path
        # that piecewise-linear laws create when several folds cross a breakpoint together.
        j = jnp.argmax(weights * jnp.abs(tz))
        local = (mode == 1) & ~fix
        e = jnp.zeros(n + 1).at[j].set(1.0)
        row_z = jnp.where(fix, 0.0, jnp.where(local, e[:n], weights * tz))
        row_l = jnp.where(fix, 1.0, jnp.where(local, e[n], w_lam**2 * tl))
        target = jnp.where(final, stop, lp)
        rho = jnp.where(fix, target, row_z @ zp + row_l * lp)
        zp = jnp.where(final & natural, z + ((stop - load_parameter) / tl_safe) * tz, zp)
        c = corrector(
            layout,
            p,
            zp,
            jnp.where(fix, target, lp),
            ctl,
            row_z,
            row_l,
            rho,
            atol,
            jnp.where(first, 0, max_it),
        )
        ok = c.converged
        # orient the new tangent along the old one after a pseudo-arclength step (smooth limit
        # points), along the secant of the step after a retry (sharp corners, where the old
        # tangent would point back along the new branch)
        secant = jnp.concatenate([c.z - z, (c.load_parameter - load_parameter)[None]])
        sec_norm = jnp.sqrt(jnp.sum(weights * secant[:n] ** 2) + (w_lam * secant[n]) ** 2)
        t_new = tangent(
            c.jac,
            c.r_load,
            weights,
            w_lam,
            jnp.where((sec_norm > 0) & (mode > 0) & started, secant, t),
        )
        # a retry must move on along the branch in q, not fall back onto the traversed part
        forward = jnp.sum(weights * secant[:n] * tz) > 0.0
        ok = ok & jnp.all(jnp.isfinite(t_new)) & ((mode == 0) | natural | forward)
        back = ok & started & ((c.load_parameter - load_parameter0) * direction < 0.0)
        turned = ok & ~back & stop_at_limit & (t_new[n] * direction < 0.0) & started
        # the first pass records only the start's tangent and observation (at index 0)
        ok = ok & ~back & started
        record = ok | first
        i = jnp.where(first, 0, b.count)
        # the state's observation from the corrector's Jacobian (computed for recorded states)
        obs = jax.lax.cond(
            record,
            lambda: observed(c.z, c.load_parameter, c.jac),
            lambda: jax.tree_util.tree_map(lambda v: v[0], b.observation),
        )
        nb = b._replace(
            observation=jax.tree_util.tree_map(
                lambda buf_v, v: jnp.where(record, buf_v.at[i].set(v), buf_v),
                b.observation,
                obs,
            ),
            z=jnp.where(ok, b.z.at[i].set(c.z), b.z),
            load_parameter=jnp.where(
                ok, b.load_parameter.at[i].set(c.load_parameter), b.load_parameter
            ),
            tangent=jnp.where(record, b.tangent.at[i].set(t_new), b.tangent),
            step=jnp.where(ok, b.step.at[i].set(ds), b.step),
            iterations=jnp.where(ok, b.iterations.at[i].set(c.iterations), b.iterations),
            count=b.count + ok.astype(int),
            cutbacks=b.cutbacks + (~ok & ~back & started).astype(int),
        )
        easy = c.iterations <= 3
        hard = c.iterations >= 7
        ds_ok = jnp.where(easy, jnp.minimum(ds * grow, ds_max), jnp.where(hard, 0.7 * ds, ds))
        ds_new = jnp.where(ok, ds_ok, jnp.where((mode == 2) & started, 0.5 * ds, ds))
        status = jnp.where(
            back,
            RETURNED,
            jnp.where(
                turned & ~final,
                LIMIT_POINT,
                jnp.where(
                    ok & final,
                    COMPLETED,
                    jnp.where(
                        ~ok & (ds_new < ds_min),
                        STALLED,
                        jnp.where(
                            (nb.count - 1 >= max_steps) | (nb.count >= buffer_size),
                            MAX_STEPS,
                            RUNNING,
                        ),
                    ),
                ),
            ),
        )
        nb = nb._replace(status=jnp.where(first, RUNNING, status))
        return (
            nb,
            jnp.where(ok, c.z, z),
            jnp.where(ok, c.load_parameter, load_parameter),
            jnp.where(record, t_new, t),
            ds_new,
            jnp.where(record, 0, fails + 1),
            jnp.asarray(True),
        )

    init = (buf, z0, load_parameter0, t_orient, ds0, jnp.asarray(0), jnp.asarray(False))
    out = jax.lax.while_loop(cond, body, init)
    return out[0]
