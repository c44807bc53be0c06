"""The solves of the force-ramp design map (:mod:`biplan.analysis.maps.design_map`): the
quasi-static ramp of a batch of designs, and the pieces of its scalar reference.

Where the models have a compiled :class:`~biplan.model.system.System` (the default chain
readings), each design's ramp is one call of :func:`biplan.solvers.batch.ramp` (compiled once
per install; it releases the GIL, so the chunks of a map run in parallel on threads). Other
readings use the JAX kernel of the layout, batched over the designs with ``jax.vmap``
(:func:`_path`, one compilation per layout and batch size). Both run, per load step, up to
:data:`CHORD_ITERATIONS` chord iterations at the new force with the previous equilibrium's
Jacobian (:func:`biplan.solvers.strategies.chord`), then the globalised Newton, and read the
stability from the Jacobian the Newton ends with: the same iterates, the same records to
round-off.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from biplan._compile.kernel import kernel
from biplan._compile.setup import jax, jnp
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.model.assembly import Load, Model, kernels
from biplan.model.lagrangian import kkt_jacobian, residual
from biplan.model.potential import contact_gaps, load_height
from biplan.solvers import batch
from biplan.solvers.core_settings import Settings
from biplan.solvers.iteration import settings_array
from biplan.solvers.newton import Newton, Status, newton_loop
from biplan.solvers.observation import observe as observe_compiled
from biplan.solvers.observe import Observation, kkt_min_eigenvalue, observe_batch
from biplan.solvers.strategies import chord

__all__ = [
    "CHORD_ITERATIONS",
    "LANES",
    "point_solvers",
    "ramp_compiled",
    "ramp_jax",
    "stack_params",
]

Array = Any

#: Name of the design (vmap) axis of the batched JAX ramp (Newton skips work no lane needs).
LANES = "designs"
#: Most chord iterations (the previous equilibrium's Jacobian, residuals only) per load step.
CHORD_ITERATIONS = 8


@kernel("chord")
def _chord(layout: TubeLayout, p: Any, z: Array, jac: Array, load: Load, atol: Array) -> Array:
    """The start of a load step: :func:`biplan.solvers.strategies.chord` at ``load`` with the
    previous equilibrium's KKT Jacobian ``jac`` (at most :data:`CHORD_ITERATIONS` steps)."""
    return chord(lambda zc: residual(layout, p, zc, load), jac, z, atol, CHORD_ITERATIONS)


@kernel("design_lanes", statics=2, in_axes=(0, None, None, None), axis_name=LANES)
def _path(
    layout: TubeLayout,
    free_steps: int,
    p: Any,
    z0: Array,
    forces: Array,
    settings: Settings,
    axis_name: str | None = None,
) -> tuple:
    """Load stepping through ``forces`` from z0 (pure; vmapped over designs, the vmap axis
    named ``axis_name``).

    Each step starts with up to :data:`CHORD_ITERATIONS` chord iterations at the new load with
    the KKT Jacobian of the previous equilibrium (cheap: residuals and solves only) and is
    finished by the globalised :func:`newton_loop`, whose first pass also evaluates the
    Jacobian at the converged state. Stability is read from that Jacobian
    (:func:`kkt_min_eigenvalue`), so no second Hessian is evaluated per step.
    """
    zero = jnp.asarray(0.0)
    weak = layout.options.weak_contacts_active
    nq = layout.n_coordinates

    def body(carry: tuple, f: Array) -> tuple:
        z, jac, alive = carry
        load = Load(f, zero, zero)
        start = _chord(layout, p, z, jac, load, settings.atol)
        out = newton_loop(
            layout, p, start, load, settings, free_steps=free_steps, axis_name=axis_name
        )
        ok = alive & (out.status == Status.CONVERGED.value) & jnp.all(jnp.isfinite(out.z))
        q = out.z[:nq]
        end = chain.endpoint(layout, p.geometry, q)
        min_eig = kkt_min_eigenvalue(layout, out.z, out.jac, contact_gaps(layout, p, q), load, weak)
        first_bad = jnp.where(alive & ~ok, out.status, -1)
        z_next = jnp.where(ok, out.z, z)
        jac_next = jnp.where(ok, out.jac, jac)
        rec = (ok, first_bad, end.u_z, end.u_r, load_height(layout, p, q), min_eig)
        return (z_next, jac_next, ok), rec

    jac0 = kkt_jacobian(layout, p, z0, Load(forces[0], zero, zero))
    carry, outs = jax.lax.scan(body, (z0, jac0, jnp.asarray(True)), forces)  # type: ignore[var-annotated]
    return carry[0], outs


def stack_params(models: Sequence[Model], batch: int) -> Any:
    """The ModelParams of ``models`` stacked along a leading axis, padded to ``batch`` by
    repeating the last one."""
    ps = [m.params for m in models] + [models[-1].params] * (batch - len(models))
    return jax.tree_util.tree_map(lambda *a: jnp.stack([jnp.asarray(x) for x in a]), *ps)


def _settings(newton: Newton) -> np.ndarray:
    return settings_array(
        newton.atol, newton.max_steps, newton.max_backtracks, newton.armijo, newton.free_steps
    )


def ramp_compiled(
    models: Sequence[Model], forces: np.ndarray, newton: Newton
) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """The ramp through ``forces`` [N] of every model (each with a compiled System), from
    q = 0: :func:`biplan.solvers.batch.ramp`, one call per design.

    Returns
    -------
    records : tuple of ndarray, each (len(models), len(forces))
        Per design and load step: converged, the failing status (−1 none), u_z, u_r [mm],
        the load-point displacement [mm] and λ_min of the reduced Hessian [N/mm] (NaN past
        a failed step).
    z_last : ndarray (len(models), n_z)
        The last converged packed state of each design.
    """
    s = _settings(newton)
    f = np.ascontiguousarray(forces, dtype=float)
    outs = []
    for m in models:
        system = m.system()
        if system is None:
            raise ValueError("ramp_compiled: a model without a compiled System")
        z0 = np.asarray(m.pack(m.zeros()), dtype=float)
        weak = bool(m.options.weak_contacts_active)
        outs.append(batch.ramp(system.data, z0, f, s, CHORD_ITERATIONS, weak))
    z_last = np.stack([o[0] for o in outs])
    records = tuple(np.stack([o[k] for o in outs]) for k in range(1, 7))
    return records, z_last


def ramp_jax(
    layout: TubeLayout, models: Sequence[Model], forces: np.ndarray, newton: Newton, size: int
) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """:func:`ramp_compiled` on the JAX kernel of ``layout`` (:func:`_path`), the designs
    padded to ``size`` (one compilation per layout, watchdog length and size)."""
    z0 = jnp.asarray(models[0].pack(models[0].zeros()))
    params = stack_params(models, size)
    run = _path.compiled(layout, newton.free_steps)
    z_last, rec = run(params, z0, jnp.asarray(forces), newton.settings())
    n = len(models)
    return tuple(np.asarray(r)[:n] for r in rec), np.asarray(z_last)[:n]


def point_solvers(
    model: Model, atol: float
) -> tuple[
    Callable[[np.ndarray, Load], np.ndarray],
    Callable[[np.ndarray, np.ndarray, Load], np.ndarray],
    Callable[[np.ndarray, Load], Observation],
]:
    """The pieces of the design map's scalar reference for one design, on its compiled System
    where it has one, else on the JAX kernels: the KKT Jacobian ``jacobian(z, load)``, the
    chord start ``start(z, jac, load)`` (:data:`CHORD_ITERATIONS`, tolerance ``atol``) and the
    observation of the states ``observe(zs, loads)`` (a Load of (k,) arrays), which evaluates
    each Hessian afresh."""
    system = model.system()
    if system is None:
        kk = kernels(model.layout)
        jax_chord = _chord.compiled(model.layout)
        p = model.params

        def jacobian(z: np.ndarray, load: Load) -> np.ndarray:
            return np.asarray(kk.jacobian(p, jnp.asarray(z), load))

        def start(z: np.ndarray, jac: np.ndarray, load: Load) -> np.ndarray:
            out = jax_chord(p, jnp.asarray(z), jnp.asarray(jac), load, jnp.asarray(atol))
            return np.asarray(out)

        def observe(zs: np.ndarray, loads: Load) -> Observation:
            return observe_batch(model.layout, p, zs, loads)

        return jacobian, start, observe
    data = system.data

    def jacobian_c(z: np.ndarray, load: Load) -> np.ndarray:
        return np.asarray(model.system(load).jacobian(z))  # type: ignore[union-attr]

    def start_c(z: np.ndarray, jac: np.ndarray, load: Load) -> np.ndarray:
        f = np.array([load.force, load.displacement, load.displacement_control], dtype=float)
        z = np.asarray(z, dtype=float)
        return np.asarray(batch.chord(data, z, np.asarray(jac, float), f, atol, CHORD_ITERATIONS))

    def observe_c(zs: np.ndarray, loads: Load) -> Observation:
        return observe_compiled(model, zs, loads)

    return jacobian_c, start_c, observe_c
