"""The chain of module frames: per-connector increments, composed by angle sums.

Under the paper's chain (MODEL R1 ``EXACT`` offset, R3 ``ELEMENT`` attachment) the frame of
the module above connector c is the frame below it times a planar rigid increment
A_c = (α_c, t_c) that depends only on the connector's own coordinates x_c = (x_lower,
x_upper, γ_c) (:mod:`biplan.geometry.chain`, module docstring)::

    A_c = E_lower(x_lower)^[SPC] · Trans([Δ_c, 0]),   Δ_c = γ_c + z_L(0) − z_U(0)

Planar rotations compose by adding angles, so the frame of module n is a cumulative sum over
the chain: θ_n = Σ α_c, P_n = Σ R(θ_c−1) t_c. :func:`increments` evaluates every A_c at once
(``vmap`` over connectors, the connector's kind as data) and :func:`top_frame` composes them
by cumulative sums: the traced graph, and what XLA compiles, do not grow with N, and no loop
runs inside the compiled kernels. The result
equals the general frame construction of :func:`biplan.geometry.chain.kinematics` (tested).
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np

from biplan._compile.setup import jax, jnp
from biplan.geometry.chain import (
    GeometryParams,
    line_height,
    load_point_of_edge,
    reference_frames,
    tables,
)
from biplan.geometry.layout import TubeLayout
from biplan.geometry.module import PIVOT, node_positions, rotation
from biplan.options import ChainAttachment, ChainOffset

__all__ = [
    "ChainIndex",
    "chain_index",
    "increment",
    "increment_data",
    "increments",
    "load_point",
    "load_point_height",
    "scannable",
    "top_frame",
]

Array = Any


def scannable(layout: TubeLayout) -> bool:
    """Whether the layout's readings give frames that :func:`top_frame` composes (R1 EXACT
    and R3 ELEMENT, the defaults); other readings use the general construction."""
    opts = layout.options
    return (
        layout.n_connectors > 0
        and opts.chain_offset is ChainOffset.EXACT
        and opts.chain_attachment is ChainAttachment.ELEMENT
    )


class ChainIndex(NamedTuple):
    """Static per-connector data of the increments (NumPy)."""

    dofs: np.ndarray  # (Nc, 7) coordinates (x_lower, x_upper, γ) in q
    lower: np.ndarray  # (Nc,) lower module (0 for the clamp)
    upper: np.ndarray  # (Nc,)
    element: np.ndarray  # (Nc,) lower full element carrying the module above, −1 for none
    seam_upper_element: np.ndarray  # (Nc,)
    seam_lower_element: np.ndarray  # (Nc,)
    seam_rigid: np.ndarray  # (Nc,) bool
    seam_height: np.ndarray  # (Nc,) z of a rigid lower seam, in units of l


@functools.lru_cache(maxsize=128)
def chain_index(layout: TubeLayout) -> ChainIndex:
    """The connector data of a layout (connectors run up the chain, lower = upper − 1)."""
    n = layout.n_modules
    t = tables(layout)
    lower = np.asarray([0 if c.lower is None else c.lower for c in layout.connectors], np.int32)
    upper = np.asarray([c.upper for c in layout.connectors], np.int32)
    element = np.asarray(
        [
            -1 if c.lower is None or c.lower_full_element is None else c.lower_full_element
            for c in layout.connectors
        ],
        np.int32,
    )
    dofs = np.concatenate(
        [
            3 * lower[:, None] + np.arange(3),
            3 * upper[:, None] + np.arange(3),
            (3 * n + np.arange(layout.n_connectors))[:, None],
        ],
        axis=1,
    ).astype(np.int32)
    seam = t.seam_pt
    return ChainIndex(
        dofs,
        lower,
        upper,
        element,
        t.pt_up_el[seam],
        t.pt_lo_el[seam],
        t.pt_lo_rigid[seam],
        t.pt_lo_height[seam],
    )


def increment(
    x: Array,
    ref_lower: Array,
    ref_upper: Array,
    element: Array,
    up_el: Array,
    lo_el: Array,
    rigid: Array,
    height: Array,
    pitch: Array,
) -> Array:
    """(α, t_z, t_s) of one connector's frame increment A_c from x_c (module docstring); the
    arguments after x_c are one row of :func:`increment_data`."""
    lo, up, gam = x[:3], x[3:6], x[6]
    zero = jnp.zeros(())
    z_up = line_height(up, ref_upper, up_el, zero, zero)
    z_lo = jnp.where(rigid, height * pitch, line_height(lo, ref_lower, lo_el, pitch + zero, zero))
    delta = gam + z_lo - z_up
    carried = element >= 0
    angle = jnp.where(carried, jnp.where(element == 0, lo[1], lo[2]), 0.0)
    rot = rotation(angle)
    pivot = jnp.where(element == 0, ref_lower[PIVOT[0]], ref_lower[PIVOT[1]])
    base = jnp.where(carried, pivot - rot @ pivot + jnp.stack([lo[0], 0.0]), jnp.zeros(2))
    t = base + rot @ jnp.stack([delta, 0.0])
    return jnp.concatenate([angle[None], t])


def increment_data(layout: TubeLayout, ref: Array) -> tuple[Array, ...]:
    """The per-connector arguments of :func:`increment` after x_c (one row per connector)."""
    idx = chain_index(layout)
    return (
        ref[idx.lower],
        ref[idx.upper],
        idx.element,
        idx.seam_upper_element,
        idx.seam_lower_element,
        idx.seam_rigid,
        idx.seam_height,
    )


def increments(layout: TubeLayout, geom: GeometryParams, q: Array, ref: Array) -> Array:
    """Frame increments (Nc, 3) = (α [rad], t_z, t_s [mm]) of every connector."""
    fn = functools.partial(increment, pitch=geom.pitch)
    return jax.vmap(fn)(q[chain_index(layout).dofs], *increment_data(layout, ref))


def top_frame(incs: Array) -> tuple[Array, Array]:
    """(θ [rad], P (2,) [mm]) of the top module: the increments composed up the chain,
    θ = Σ α_c and P = Σ_c R(θ_c−1) t_c with θ_c−1 the exclusive cumulative sum of α."""
    alpha = incs[:, 0]
    before = jnp.concatenate([jnp.zeros(1), jnp.cumsum(alpha)[:-1]])
    c, s = jnp.cos(before), jnp.sin(before)
    tz, ts = incs[:, 1], incs[:, 2]
    return alpha.sum(), jnp.stack([(c * tz - s * ts).sum(), (s * tz + c * ts).sum()])


def load_point(
    layout: TubeLayout, geom: GeometryParams, incs: Array, x_top: Array, ref_top: Array
) -> Array:
    """Axial position z [mm] of the load point (MODEL W1) from the connectors' increments
    (Nc, 3) and the top module's coordinates x_top (3,) with its reference nodes ref_top."""
    theta, pos = top_frame(incs)
    nodes = node_positions(x_top, ref_top) @ rotation(theta).T + pos
    segs = jnp.stack(
        [jnp.stack([nodes[i0], nodes[i1]]) for _, i0, i1 in tables(layout).end_segments]
    )
    return load_point_of_edge(layout, geom, segs)


def _load_point(layout: TubeLayout, geom: GeometryParams, q: Array) -> Array:
    ref, _, _ = reference_frames(layout, geom)
    n = layout.n_modules
    incs = increments(layout, geom, q, ref)
    return load_point(layout, geom, incs, q[3 * n - 3 : 3 * n], ref[n - 1])


def load_point_height(layout: TubeLayout, geom: GeometryParams, q: Array) -> Array:
    """z_p(q) [mm] (MODEL W1) through the composed increments; equals
    :func:`biplan.geometry.chain.load_height` on a :func:`scannable` layout. The reference
    point (q = 0) depends on the geometry, not on q: it carries the derivatives with respect
    to R, l and β (design sensitivities)."""
    ref_point = _load_point(layout, geom, jnp.zeros_like(q))
    return _load_point(layout, geom, q) - ref_point
