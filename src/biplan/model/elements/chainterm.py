"""The chain term: the load point's axial displacement z_p(q) and its derivatives (MODEL W1).

z_p is the only term of the Lagrangian that sees the whole tube: the module frames compose up
the chain. On the default chain readings (:func:`biplan.geometry.frames.scannable`) it is a
function Z(y) of the connectors' frame increments y_c = A_c(x_c) (3 numbers each, from the
connector's own 7 coordinates) and of the top module's coordinates, so its derivatives split
into local and chain parts (chain rule)::

    ∇z_p  = Σ_c P_cᵀ J_cᵀ ∂Z/∂y_c                        (J_c = ∂y_c/∂x_c, 3 × 7)
    ∇²z_p = Σ_c P_cᵀ (Σ_k ∂Z/∂y_ck ∇²y_ck) P_c  +  Jᵀ ∇²Z J

with P_c the placement of connector c's coordinates. J_c and ∇²y_c are local autodiff
(``vmap`` over connectors, as the elements); ∇²Z is the Hessian of a cumulative sum over
3 (N_c + 1) numbers; the blocks J_eᵀ ∇²Z_ef J_f are added into the dense matrix by one
scatter. No derivative of the whole chain's kinematics is taken. Other readings (the paper's
chain offset, the edge-fit attachment) differentiate z_p(q) by autodiff of the general frame
construction.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np

from biplan._compile.setup import jax, jnp
from biplan.geometry import chain, frames
from biplan.geometry.layout import TubeLayout
from biplan.model.elements.topology import place_matrix, place_vector

__all__ = ["ChainTerms", "chain_terms", "load_point_height"]

Array = Any


class ChainTerms(NamedTuple):
    """The load point's axial displacement z_p [mm] and its derivatives (MODEL W1)."""

    value: Array
    gradient: Array  # (n_q,)
    hessian: Array  # (n_q, n_q) (None unless second order)


def load_point_height(layout: TubeLayout, geom: chain.GeometryParams, q: Array) -> Array:
    """z_p(q) [mm]: the load point's axial displacement from q = 0 (the chain's only term).

    On the default chain readings the frames are composed from per-connector increments
    (:mod:`biplan.geometry.frames`); other readings use the general construction.
    """
    if frames.scannable(layout):
        return frames.load_point_height(layout, geom, q)
    ref = chain.kinematics(layout, geom, jnp.zeros_like(q))  # depends on the geometry only
    return chain.load_height(layout, geom, chain.kinematics(layout, geom, q), ref)


def chain_terms(
    layout: TubeLayout, geom: chain.GeometryParams, q: Array, second_order: bool = True
) -> ChainTerms:
    """z_p with its gradient and (optionally) Hessian (module docstring).

    Parameters
    ----------
    layout, geom
        The tube layout and its traced geometry (R, l, β).
    q : array (n_q,)
        Generalised coordinates.
    second_order : bool
        Also assemble ∇²z_p (n_q, n_q).
    """
    if not frames.scannable(layout):
        fn = functools.partial(load_point_height, layout, geom)
        value, gradient = jax.value_and_grad(fn)(q)
        return ChainTerms(value, gradient, jax.hessian(fn)(q) if second_order else None)
    n, nq = layout.n_modules, layout.n_coordinates
    ref, _, _ = chain.reference_frames(layout, geom)
    data = frames.increment_data(layout, ref)
    dofs = frames.chain_index(layout).dofs  # (Nc, 7)
    top = np.arange(3 * n - 3, 3 * n, dtype=np.int32)

    inc = functools.partial(frames.increment, pitch=geom.pitch)

    def with_jacobian(x: Array, *row: Array) -> tuple[Array, tuple[Array, Array]]:
        jac = jax.jacfwd(inc)(x, *row)
        return jac, (jac, inc(x, *row))

    def point(incs: Array, x_top: Array) -> Array:
        return frames.load_point(layout, geom, incs, x_top, ref[n - 1])

    x = q[dofs]
    if second_order:
        hess_y, (jac, incs) = jax.vmap(jax.jacfwd(with_jacobian, has_aux=True))(x, *data)
    else:
        jac, incs = jax.vmap(lambda x_, *row: with_jacobian(x_, *row)[1])(x, *data)
    x_top = q[top]
    origin = point(jax.vmap(inc)(jnp.zeros_like(x), *data), jnp.zeros(3))
    value = point(incs, x_top) - origin  # the origin depends on the geometry only
    g_inc, g_top = jax.grad(point, argnums=(0, 1))(incs, x_top)
    gradient = place_vector(dofs, jnp.einsum("cak,ca->ck", jac, g_inc), nq) + place_vector(
        top[None], g_top[None], nq
    )
    if not second_order:
        return ChainTerms(value, gradient, None)

    # local part: Σ_k ∂Z/∂y_ck ∇²y_ck, one 7 × 7 block per connector
    hessian = place_matrix(dofs, jnp.einsum("ca,cakl->ckl", g_inc, hess_y), dofs, (nq, nq))
    # chain part: Jᵀ ∇²Z J, the top module an extra element with J = [I₃ 0]
    y_dofs = np.concatenate([dofs, np.concatenate([top, np.full(4, top[0])])[None]])
    j_top = np.zeros((1, 3, 7))
    j_top[0, :, :3] = np.eye(3)
    jy = jnp.concatenate([jac, jnp.asarray(j_top)])  # (E, 3, 7)
    e = jy.shape[0]

    def flat(y: Array) -> Array:
        return point(y[:-1], y[-1])

    hz = jax.hessian(flat)(jnp.concatenate([incs, x_top[None]]))  # (E, 3, E, 3)
    blocks = jnp.einsum("eak,eafb,fbl->ekfl", jy, hz, jy).reshape(1, 7 * e, 7 * e)
    rows = y_dofs.reshape(1, -1)
    return ChainTerms(value, gradient, hessian + place_matrix(rows, blocks, rows, (nq, nq)))
