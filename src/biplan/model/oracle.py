"""The whole-tube autodiff of the Lagrangian: the independent check of the local assembly.

:mod:`biplan.model.lagrangian` assembles the residual and the KKT Jacobian from element blocks
(:mod:`biplan.model.elements`). This module keeps the original global form: one Lagrangian of the
whole chain, differentiated by ``jax.grad`` / ``jax.hessian`` / ``jax.jacfwd`` over all n_q
coordinates at once. It costs O(N²) or more per evaluation and compiles slowly, so no solver
uses it; the tests compare the two to round-off on several layouts, and
``benchmarks/bench_scaling.py`` runs it as the baseline.
"""

from __future__ import annotations

from typing import Any

from biplan._compile.setup import jax, jnp
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.model.lagrangian import StateData, _sizes, _split, kkt_matrix, sfb
from biplan.model.params import Load, ModelParams
from biplan.model.potential import _energies, _gaps, _kin

__all__ = ["kkt_jacobian", "lagrangian", "residual", "state_data"]

Array = Any


def _reference_load_point(layout: TubeLayout, p: ModelParams) -> chain.Kinematics:
    """Kinematics at q = 0 (the reference of the load point's displacement)."""
    return _kin(layout, p, jnp.zeros(layout.n_coordinates))


def lagrangian(
    layout: TubeLayout,
    p: ModelParams,
    z: Array,
    load: Load,
    kin_ref: chain.Kinematics | None = None,
) -> Array:
    """L(q, λ, λ_∂, μ) of the module docstring [N·mm]."""
    q, lam, lam_c, mu = _split(layout, z)
    if kin_ref is None:
        kin_ref = _reference_load_point(layout, p)
    kin = _kin(layout, p, q)
    zp = chain.load_height(layout, p.geometry, kin, kin_ref)
    helical, circ = _energies(layout, p, kin)
    return (
        helical.sum()
        + circ.sum()
        + 0.5 * p.bias_stiffness * jnp.sum((q - p.bias_anchor) ** 2)
        - load.force * zp
        + lam @ kin.guides
        - lam_c @ _gaps(layout, p, kin)
        + mu * load.displacement_control * (zp - load.displacement)
    )


def residual(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Array:
    """KKT residual r(z) (MODEL §11) for z = [q, λ, λ_∂, μ]."""
    q, _, lam_c, mu = _split(layout, z)
    kin_ref = _reference_load_point(layout, p)
    rest = z[layout.n_coordinates :]
    grad_q = jax.grad(lambda qq: lagrangian(layout, p, jnp.concatenate([qq, rest]), load, kin_ref))(
        q
    )
    kin = _kin(layout, p, q)
    zp = chain.load_height(layout, p.geometry, kin, kin_ref)
    d = load.displacement_control
    return jnp.concatenate(
        [
            grad_q,
            kin.guides,
            sfb(_gaps(layout, p, kin) + p.compliance * lam_c, lam_c, p.smoothing),
            (d * (zp - load.displacement) + (1.0 - d) * mu)[None],
        ]
    )


def _constraint_values(
    layout: TubeLayout, p: ModelParams, q: Array, kin_ref: chain.Kinematics
) -> Array:
    """[g(q), w_∂(q), z_p(q)]: everything the KKT rows differentiate."""
    kin = _kin(layout, p, q)
    zp = chain.load_height(layout, p.geometry, kin, kin_ref)
    return jnp.concatenate([kin.guides, _gaps(layout, p, kin), zp[None]])


def kkt_jacobian(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Array:
    """∂r/∂z assembled from its blocks (MODEL §11)::

        [[K,        Gᵀ, −Cᵀ,          d a],
         [G,        0,   0,            0 ],
         [D_w C,    0,   D_λ,          0 ],
         [d aᵀ,     0,   0,        1 − d ]]

    K = ∇²_q L (autodiff Hessian over the n_q coordinates), [G; C; aᵀ] the autodiff Jacobian
    of (g, w_∂, z_p), D_w = diag(ŵ/ρ − 1), D_λ = diag(c (ŵ/ρ − 1) + λ/ρ − 1),
    ρ = √(ŵ² + λ² + ε²), ŵ = w + c λ (c: ``ModelOptions.contact_compliance``).
    The blocks come from this module's global autodiff; their arrangement is the
    assembly's :func:`biplan.model.lagrangian.kkt_matrix` (itself checked against the autodiff of
    the whole residual, ``Model.jacobian_autodiff``).
    """
    nq, ng, nc = _sizes(layout)
    q, _lam, lam_c, _mu = _split(layout, z)
    kin_ref = _reference_load_point(layout, p)
    rest = z[nq:]
    k = jax.hessian(lambda qq: lagrangian(layout, p, jnp.concatenate([qq, rest]), load, kin_ref))(q)
    jc = jax.jacfwd(lambda qq: _constraint_values(layout, p, qq, kin_ref))(q)
    gaps = _constraint_values(layout, p, q, kin_ref)[ng : ng + nc]
    return kkt_matrix(p, load, k, jc[:ng], jc[ng : ng + nc], jc[-1], gaps, lam_c)


def state_data(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> StateData:
    """Energy split, endpoint, Lagrangian Hessian and constraint Jacobians at z."""
    nq, _ng, _nc = _sizes(layout)
    q = z[:nq]
    kin_ref = _reference_load_point(layout, p)
    kin = _kin(layout, p, q)
    helical, circ = _energies(layout, p, kin)
    rest = z[nq:]
    k = jax.hessian(lambda qq: lagrangian(layout, p, jnp.concatenate([qq, rest]), load, kin_ref))(q)
    jc = jax.jacfwd(lambda qq: _constraint_values(layout, p, qq, kin_ref))(q)
    return StateData(
        energy=helical.sum() + circ.sum(),
        helical_energy=helical,
        circular_energy=circ,
        load_displacement=chain.load_height(layout, p.geometry, kin, kin_ref),
        endpoint=chain.endpoint(layout, p.geometry, q),
        lagrangian_hessian=k,
        constraint_jacobian=jc,
        gaps=_gaps(layout, p, kin),
    )
