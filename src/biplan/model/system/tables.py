"""A tube as data: the arrays every compiled element kernel takes (:mod:`biplan.model.system`).

Connectivity, index tables, reference geometry and per-fold law rows are plain NumPy arrays in
one :class:`SystemData`, so the number of modules and the architecture are array sizes, not
compile-time constants: the kernels compile once per install and serve every tube.
The index tables are those of :func:`biplan.geometry.chain.tables` (one row per connector
field end, "point") and :func:`biplan.geometry.frames.chain_index` (one row per connector).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from biplan._compile.numba_cache import kernel_array
from biplan.geometry import chain, frames
from biplan.geometry.layout import TubeLayout
from biplan.options import (
    ChainAttachment,
    ChainOffset,
    ContactForm,
    EndpointDefinition,
    LoadPoint,
    MirrorConvention,
    ModuleKind,
)

__all__ = ["SystemData", "kernel_data", "system_data"]


class SystemData(NamedTuple):
    """One tube as arrays (float64 or int64; lengths in mm, angles in rad, k in N/mm²).

    N modules, Nc connectors, K connector points (field ends), F fields, n_cc connector
    contact points.
    """

    # sizes (n_q, n_g, n_c) and scalar numbers
    sizes: np.ndarray  # (3,) int: n_q, n_g, n_c
    scalars: np.ndarray  # (7,) l, H, a, ε, c (contact compliance), τ (smooth minimum), H1
    # (4,) int: contact form (0 per endpoint, 1 minimum), endpoint (0 edge, 1 seam), R3
    # attachment (0 element, 1 edge fit; 0 under PAPER, which ignores it), R1 offset (1 paper)
    flags: np.ndarray
    # modules
    ref: np.ndarray  # (N, 7, 2) reference nodes in each module frame
    n_c: np.ndarray  # (N, 2) crease tangent
    n_sp: np.ndarray  # (N, 2) opening normal
    helical: np.ndarray  # (N, 5) law rows (k1, k2, k3, w1, w2)
    # connectors
    circular: np.ndarray  # (Nc, 5)
    conn_lower: np.ndarray  # (Nc,) lower module, -1 for the clamp
    conn_upper: np.ndarray  # (Nc,)
    conn_element: np.ndarray  # (Nc,) lower full element carrying the module above, -1 none
    conn_first_point: np.ndarray  # (Nc + 1,) points of connector c: [first[c], first[c+1])
    conn_first_field: np.ndarray  # (Nc + 1,)
    conn_first_contact: np.ndarray  # (Nc + 1,) into contact_point
    conn_dofs: np.ndarray  # (Nc, 7) global coordinate of each of x_c's, -1 for the clamp's
    # (Nc, 4) int: lower element carrying the frame above (-1 none or the clamp), upper and
    # lower element at the seam, 1 if the seam's lower edge is rigid; and its height [mm]
    conn_seam: np.ndarray
    conn_seam_height: np.ndarray  # (Nc,)
    # (Nc, 2, 2, 2) node indices of the lower and the upper module's edge segments (up to 2
    # segments, start and end node; -1 none) fitted under R3 EDGE_FIT
    conn_edges: np.ndarray
    # connector points
    point_s: np.ndarray  # (K,) s [mm]
    point_upper_element: np.ndarray  # (K,)
    point_lower_element: np.ndarray  # (K,)
    point_rigid: np.ndarray  # (K,) 1: the lower edge is rigid in the attachment frame
    point_height: np.ndarray  # (K,) z of a rigid lower edge [mm]
    point_flip: np.ndarray  # (K,) 1: w -> 2γ - w (TpcSign.AS_PRINTED)
    field_start: np.ndarray  # (F,) point index
    field_end: np.ndarray  # (F,)
    contact_point: np.ndarray  # (n_cc,) point index of each connector contact row
    # load point: weights of the top module's nodes whose z is z_p (MODEL W1)
    load_weights: np.ndarray  # (7,)
    end_segments: np.ndarray  # (S, 2) node indices of the free-end edge segments
    bias_anchor: np.ndarray  # (n_q,) anchor of the proximal bias ½κ‖q − q_a‖²
    bias_stiffness: np.ndarray  # (1,) κ
    load_reference: np.ndarray  # (1,) Z(0), the load point at q = 0 [mm] (geometry only)
    # the bordered banded solve of ∂r/∂z (:mod:`.ordering`; both empty: dense LU)
    solve_order: np.ndarray  # (n_z,) int: the inner unknowns in band order, then the border
    solve_band: np.ndarray  # (3,) int: n_inner, kl, ku


def _reference(kind: ModuleKind, mirror: MirrorConvention, l: float, h: float, h1: float):  # type: ignore[no-untyped-def]
    """Reference nodes (7, 2) and (n_c, n_sp) of one module (as
    :func:`biplan.geometry.module.reference_nodes` and ``directions``, in NumPy)."""
    std = np.array([[0, 0], [l, 0], [l, h], [0, h1], [0, h1], [l, h], [0, h]], dtype=float)
    if kind is ModuleKind.STANDARD:
        qz, qs, cz, cs = 1.0, 1.0, 0.0, 0.0
    elif mirror is MirrorConvention.REFLECTION:
        qz, qs, cz, cs = -1.0, 1.0, l, 0.0
    else:
        qz, qs, cz, cs = -1.0, -1.0, l, h
    nodes = np.stack([qz * std[:, 0] + cz, qs * std[:, 1] + cs], axis=1)
    return nodes, qz, qs


def kernel_data(data: SystemData) -> SystemData:
    """``data`` with every field writable and C-contiguous
    (:func:`biplan._compile.numba_cache.kernel_array`: one compiled signature per kernel)."""
    if all(a.flags.writeable and a.flags.c_contiguous for a in data):
        return data  # (the common case, e.g. every System.at: no copy, no np.require)
    return SystemData(*(kernel_array(a) for a in data))


def system_data(
    layout: TubeLayout,
    radius: float,
    pitch: float,
    beta: float,
    helical: np.ndarray,
    circular: np.ndarray,
) -> SystemData:
    """The arrays of a tube (lengths in mm, β in rad, law rows (k1, k2, k3, w1, w2))."""
    opts = layout.options
    paper = opts.chain_offset is ChainOffset.PAPER
    n, nc = layout.n_modules, layout.n_connectors
    h = 2.0 * math.pi * radius
    h2 = pitch * math.tan(beta)
    h1 = h - h2
    a = pitch / math.cos(beta)
    ref = np.zeros((n, 7, 2))
    n_c = np.zeros((n, 2))
    n_sp = np.zeros((n, 2))
    for i, shape in enumerate(layout.shapes):
        ref[i], qz, qs = _reference(shape.kind, shape.mirror, pitch, h, h1)
        n_c[i] = (qz * math.cos(beta), qs * math.sin(beta))
        n_sp[i] = (-qz * math.sin(beta), qs * math.cos(beta))
    t = chain.tables(layout)
    s_values = np.array([0.0, h1, h2, h])
    minimum = opts.contact is ContactForm.MINIMUM
    if nc:
        idx = frames.chain_index(layout)
        first_point = np.append(t.seam_pt, len(t.pt_conn))
        first_field = np.searchsorted(t.field_conn, np.arange(nc + 1))
        first_contact = np.searchsorted(t.contact_conn, np.arange(nc + 1))
        lower = np.array([-1 if c.lower is None else c.lower for c in layout.connectors])
        element = idx.element
    else:
        first_point = first_field = first_contact = np.zeros(1, dtype=np.int64)
        lower = element = np.zeros(0, dtype=np.int64)
    lower = np.asarray(lower, dtype=np.int64)
    upper = np.array([c.upper for c in layout.connectors], dtype=np.int64)
    n_cc = nc if minimum else len(t.contact_pt)
    n_q = 3 * n + nc
    segs = np.array([[i0, i1] for _, i0, i1 in t.end_segments], dtype=np.int64)
    data = SystemData(
        sizes=np.array([n_q, 2 * n, 2 * n + n_cc], dtype=np.int64),
        scalars=np.array(
            [
                pitch,
                h,
                a,
                opts.contact_smoothing,
                opts.contact_compliance,
                opts.smooth_min_width,
                h1,
            ]
        ),
        flags=np.array(
            [
                1 if minimum else 0,
                0 if opts.endpoint is EndpointDefinition.EDGE else 1,
                1 if opts.chain_attachment is ChainAttachment.EDGE_FIT and not paper else 0,
                1 if paper else 0,
            ],
            dtype=np.int64,
        ),
        ref=ref,
        n_c=n_c,
        n_sp=n_sp,
        helical=np.asarray(helical, dtype=float).reshape(n, 5),
        circular=np.asarray(circular, dtype=float).reshape(nc, 5),
        conn_lower=lower,
        conn_upper=upper,
        conn_element=np.asarray(element, dtype=np.int64),
        conn_first_point=np.asarray(first_point, dtype=np.int64),
        conn_first_field=np.asarray(first_field, dtype=np.int64),
        conn_first_contact=np.asarray(first_contact, dtype=np.int64),
        conn_dofs=_connector_dofs(n, lower, upper),
        conn_seam=_seam_rows(t, first_point, np.where(lower < 0, -1, element)),
        conn_seam_height=(t.pt_lo_height[first_point[:-1]] * pitch).astype(float),
        conn_edges=_edge_table(layout),
        point_s=s_values[t.pt_s].astype(float),
        point_upper_element=t.pt_up_el.astype(np.int64),
        point_lower_element=t.pt_lo_el.astype(np.int64),
        point_rigid=t.pt_lo_rigid.astype(np.int64),
        point_height=t.pt_lo_height * pitch,
        point_flip=t.pt_flip.astype(np.int64),
        field_start=t.field_start.astype(np.int64),
        field_end=t.field_end.astype(np.int64),
        contact_point=t.contact_pt.astype(np.int64),
        load_weights=_load_weights(opts.load_point, ref[-1], segs, h1 / h),
        end_segments=segs,
        bias_anchor=np.zeros(n_q),
        bias_stiffness=np.zeros(1),
        load_reference=np.zeros(1),
        solve_order=np.zeros(0, dtype=np.int64),
        solve_band=np.zeros(0, dtype=np.int64),
    )
    return kernel_data(data)  # law rows from JAX or a frozen array are read-only


def _load_weights(point: LoadPoint, ref_top: np.ndarray, segs: np.ndarray, ratio: float):  # type: ignore[no-untyped-def]
    """Weights ω (7,) with z_p = Σ ω_i z_i over the top module's nodes (MODEL W1;
    :func:`biplan.geometry.chain.load_point_of_edge`). The segments are rigid, so the
    centroid's length weights are the reference lengths."""
    w = np.zeros(7)
    if point is LoadPoint.CENTROID:
        lengths = np.linalg.norm(ref_top[segs[:, 1]] - ref_top[segs[:, 0]], axis=1)
        for (i0, i1), length in zip(segs, lengths, strict=True):
            w[i0] += 0.5 * length / lengths.sum()
            w[i1] += 0.5 * length / lengths.sum()
    elif point is LoadPoint.SEAM:
        w[segs[0, 0]] = 1.0
    elif len(segs) > 1:
        w[segs[0, 1]] = 1.0
    else:
        w[segs[0, 0]] += 1.0 - ratio
        w[segs[0, 1]] += ratio
    return w


def _edge_table(layout: TubeLayout) -> np.ndarray:
    """``conn_edges`` (Nc, 2, 2, 2): the (start, end) nodes of the segments of each
    connector's lower edge (none at the clamp) and upper edge, -1 where there is none."""
    out = np.full((layout.n_connectors, 2, 2, 2), -1, dtype=np.int64)
    for c, spec in enumerate(layout.connectors):
        for side, edge in enumerate((spec.lower_edge, spec.upper_edge)):
            for k, (_, i0, i1) in enumerate(edge.segments if edge is not None else ()):
                out[c, side, k] = i0, i1
    return out


def _connector_dofs(n: int, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """(Nc, 7): x_c = (u, φ1, φ2 of the lower module, u, φ1, φ2 of the upper one, γ_c) as
    global coordinates of q = (modules' (u, φ1, φ2)…, γ…), -1 for the clamp's."""
    out = np.empty((len(upper), 7), dtype=np.int64)
    for c in range(len(upper)):
        for k in range(3):
            out[c, k] = -1 if lower[c] < 0 else 3 * lower[c] + k
            out[c, 3 + k] = 3 * upper[c] + k
        out[c, 6] = 3 * n + c
    return out


def _seam_rows(t: chain.Tables, first_point: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """``conn_seam`` (Nc, 4): each connector's frame element (``frame``) and, at its seam (its
    first point), the upper and lower element and whether the lower edge is rigid."""
    seam = first_point[:-1]
    rows = [frame, t.pt_up_el[seam], t.pt_lo_el[seam], t.pt_lo_rigid[seam]]
    return np.stack(rows, axis=1).astype(np.int64).reshape(-1, 4)
