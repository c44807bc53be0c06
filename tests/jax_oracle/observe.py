"""The JAX observation of equilibrium states, kept as the oracle of the compiled one
(:mod:`biplan.solvers.observation`): endpoint, energies, phase fractions, stability.

One jitted, ``vmap``-ped kernel per tube layout evaluates, for a chunk of packed states
z = [q, λ, λ_∂, μ] and their loads, everything a path or trajectory records per step:

* end force F [N] (the applied one, or the reaction −μ under displacement control), the
  load-point displacement z_p [mm] and the endpoint u_z, u_r [mm], θ [rad] (MODEL §9);
* the strain energy of every fold [N·mm] and the fraction of each fold's length on the closed,
  spinodal and open branch of its law (length-weighted over a connector's fields);
* the smallest eigenvalue of the reduced Hessian H_r = Nᵀ K N (main "Equilibrium Stability",
  MODEL §12) and the dimension of N, with the active set of :mod:`biplan.analysis.stability`
  (guides, contacts with λ_∂ > 1e-6 and w_∂ < 1e-4, the end constraint under displacement
  control).

States at rest (no end load: the state search) have a kernel of their own
(:func:`observe_at_rest`), which skips the Hessian of the load point's displacement: its
coefficient vanishes there, and at N = 10 it costs more than everything else observed.

The reduced eigenvalue is computed without a data-dependent basis size, so it can be jitted:
with A the active-constraint Jacobian (inactive rows zeroed) and A = U Σ Vᵀ, the rows of Vᵀ
past the numerical rank span the null space; the rotated Hessian V K Vᵀ is restricted to them
and the complement is shifted to σ = ‖K‖_F + 1, above every eigenvalue of the null-space block,
so the smallest eigenvalue of the shifted matrix is λ_min(H_r). ``analysis.stability`` is the
NumPy reference of the same test; the tests check that the three agree.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from biplan._compile import linalg
from biplan._compile.setup import jnp
from biplan._compile.traced import traced
from biplan.geometry.layout import TubeLayout
from biplan.model.lagrangian import (
    StateData,
    sizes,
    state_data,
    state_data_at_rest,
    state_from_jacobian,
)
from biplan.model.params import AT_REST, Load, ModelParams
from biplan.model.potential import guide_values, phase_fractions
from biplan.solvers.observation import Observation

__all__ = [
    "ACTIVE_GAP",
    "ACTIVE_MULTIPLIER",
    "CHUNK",
    "RANK_RTOL",
    "STABILITY_TOL",
    "Observation",
    "kkt_min_eigenvalue",
    "min_reduced_eigenvalue",
    "observe",
    "observe_at_rest",
    "observe_batch",
]

Array = Any

#: A contact is active when its multiplier exceeds this [N] and its gap is below ACTIVE_GAP [mm].
ACTIVE_MULTIPLIER = 1e-6
ACTIVE_GAP = 1e-4
#: Relative SVD rank tolerance of the active-constraint Jacobian.
RANK_RTOL = 1e-9
#: λ_min(H_r) above this is stable, below −STABILITY_TOL unstable, critical in between.
STABILITY_TOL = 1e-8
#: States are observed in chunks of this many (one compiled shape).
CHUNK = 16


def min_reduced_eigenvalue(k: Array, a: Array, active: Array) -> tuple[Array, Array]:
    """(λ_min(Nᵀ K N), dim N) for N the null space of the active rows of ``a``.

    Parameters
    ----------
    k : array (n, n)
        Symmetric Lagrangian Hessian.
    a : array (m, n)
        Constraint Jacobian (all candidate rows).
    active : array (m,) of bool
        Which rows are active.
    """
    n = k.shape[0]
    a = jnp.where(active[:, None], a, 0.0)
    _, s, vt = linalg.svd(a)
    sig = jnp.zeros(n).at[: min(a.shape[0], n)].set(s[: min(a.shape[0], n)])
    rank = jnp.sum(sig > RANK_RTOL * jnp.maximum(jnp.max(sig), 1e-300))
    null = jnp.arange(n) >= rank
    k = 0.5 * (k + k.T)
    rot = vt @ k @ vt.T
    shift = jnp.sqrt(jnp.sum(k**2)) + 1.0
    both = null[:, None] & null[None, :]
    m = jnp.where(both, rot, 0.0) + jnp.diag(jnp.where(null, 0.0, shift))
    min_eig = linalg.eigvalsh(m)[0]
    dof = n - rank
    return jnp.where(dof > 0, min_eig, jnp.inf), dof


def _active_rows(
    layout: TubeLayout, z: Array, gaps: Array, load: Load, weak_contacts: bool
) -> tuple[Array, Array, Array]:
    """(active rows [guides; contacts; end constraint], active contacts, displacement control)
    of the stability test (module docstring)."""
    nq, ng, nc = sizes(layout)
    closed = gaps < ACTIVE_GAP
    lam_c = z[nq + ng : nq + ng + nc]
    contact = closed if weak_contacts else closed & (lam_c > ACTIVE_MULTIPLIER)
    d = load.displacement_control > 0.5
    return jnp.concatenate([jnp.ones(ng, bool), contact, d[None]]), contact, d


def kkt_min_eigenvalue(
    layout: TubeLayout, z: Array, jac: Array, gaps: Array, load: Load, weak_contacts: bool = False
) -> Array:
    """λ_min(H_r) at a state z from its KKT Jacobian ``jac`` (``lagrangian.kkt_jacobian``).

    The Jacobian already holds what the stability test needs (MODEL §11–12): its top-left
    block is K = ∇²_q L, its top-right columns are Gᵀ and −Cᵀ (the guide and contact
    gradients) and the last column d·a. Reusing them saves the second Hessian evaluation of
    :func:`observe` where a solver has just computed the Jacobian at its converged state. The
    active set is that of :func:`observe`; ``gaps`` are the contact gaps w_∂(q) [mm].
    """
    nq, ng, nc = sizes(layout)
    k = jac[:nq, :nq]
    cols = jac[:nq, nq:].T  # rows [G; −C; d·a]
    a = jnp.concatenate([cols[:ng], -cols[ng : ng + nc], cols[-1:]])
    return min_reduced_eigenvalue(k, a, _active_rows(layout, z, gaps, load, weak_contacts)[0])[0]


def observe(
    layout: TubeLayout, p: ModelParams, z: Array, load: Load, weak_contacts: bool = False
) -> Observation:
    """Observables of one packed state z under ``load`` (pure; see module docstring)."""
    return observation(layout, p, z, load, state_data(layout, p, z, load), weak_contacts)


def observe_from_jacobian(
    layout: TubeLayout,
    p: ModelParams,
    z: Array,
    load: Load,
    jac: Array,
    weak_contacts: bool = False,
) -> Observation:
    """:func:`observe` from the KKT Jacobian ``jac`` at z (``lagrangian.kkt_jacobian``), which
    a solver has at hand at its converged state: no second assembly
    (:func:`biplan.model.lagrangian.state_from_jacobian`)."""
    data = state_from_jacobian(layout, p, z, load, jac)
    return observation(layout, p, z, load, data, weak_contacts)


def observation(
    layout: TubeLayout,
    p: ModelParams,
    z: Array,
    load: Load,
    data: StateData,
    weak_contacts: bool = False,
) -> Observation:
    """The observables of z under ``load`` from its :class:`~biplan.model.lagrangian.StateData`."""
    nq = sizes(layout)[0]
    active, contact, d = _active_rows(layout, z, data.gaps, load, weak_contacts)
    lam_min, dof = min_reduced_eigenvalue(data.lagrangian_hessian, data.constraint_jacobian, active)
    force = jnp.where(d, -z[-1], load.force)
    return Observation(
        force=force,
        displacement=data.load_displacement,
        u_z=data.endpoint.u_z,
        u_r=data.endpoint.u_r,
        theta=data.endpoint.theta,
        energy=data.energy,
        fold_energy=jnp.concatenate([data.helical_energy, data.circular_energy]),
        phase_fraction=phase_fractions(layout, p, z[:nq]),
        min_eigenvalue=lam_min,
        dof=dof,
        n_active_contacts=jnp.sum(contact),
        constraint_residual=jnp.max(jnp.abs(guide_values(layout, p, z[:nq]))),
        penetration=jnp.maximum(-jnp.min(data.gaps), 0.0),
    )


@traced("observe", in_axes=(None, 0, 0))
def _observe_layout(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Observation:
    """:func:`observe` with the layout's own reading of weak contacts."""
    return observe(layout, p, z, load, layout.options.weak_contacts_active)


@traced("observe_at_rest", in_axes=(None, 0))
def _observe_at_rest_layout(layout: TubeLayout, p: ModelParams, z: Array) -> Observation:
    """:func:`observe_at_rest` with the layout's own reading of weak contacts."""
    return observe_at_rest(layout, p, z, layout.options.weak_contacts_active)


def observe_at_rest(
    layout: TubeLayout, p: ModelParams, z: Array, weak_contacts: bool = False
) -> Observation:
    """:func:`observe` of z under :data:`~biplan.model.params.AT_REST` (no end load), from
    :func:`~biplan.model.lagrangian.state_data_at_rest`: the same observables, without
    evaluating the load point's Hessian (its coefficient vanishes at rest)."""
    data = state_data_at_rest(layout, p, z)
    return observation(layout, p, z, AT_REST.for_jax(), data, weak_contacts)


def observe_batch(
    layout: TubeLayout, params: ModelParams, z: Array, loads: Load | None
) -> Observation:
    """Observe states ``z`` (k, n_z) under ``loads`` (a Load of (k,) arrays; ``None``: at rest,
    through :func:`observe_at_rest`'s kernel), in chunks.

    Returns NumPy arrays with leading axis k. Chunks of :data:`CHUNK` states keep one
    compiled shape whatever k is.
    """
    z = np.asarray(z, dtype=float)
    k = z.shape[0]
    # the per-state arguments: z, and the load columns unless at rest
    columns = (
        [z] if loads is None else [z, *(np.broadcast_to(np.asarray(v, float), (k,)) for v in loads)]
    )
    fn = (
        _observe_at_rest_layout.compiled(layout)
        if loads is None
        else _observe_layout.compiled(layout)
    )
    parts: list[Observation] = []
    for lo in range(0, k, CHUNK):
        hi = min(lo + CHUNK, k)
        pad = CHUNK - (hi - lo)
        zc, *lc = (
            jnp.asarray(np.concatenate([c[lo:hi], np.repeat(c[hi - 1 : hi], pad, axis=0)]))
            for c in columns
        )
        out = fn(params, zc) if loads is None else fn(params, zc, Load(*lc))
        parts.append(Observation(*(np.asarray(v)[: hi - lo] for v in out)))
    if not parts:
        raise ValueError("no states to observe")
    return Observation(*(np.concatenate(vs, axis=0) for vs in zip(*parts, strict=True)))
