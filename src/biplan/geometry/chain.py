"""Vectorised kinematics of a whole tube and its chain reconstruction (SI "Global
Reconstruction"; MODEL.md §4–9).

:func:`kinematics` evaluates, in one pass batched over modules and connector field ends,
everything the energy and the constraints need: deformed nodes, guides g, helical boundary
elongations, connector field elongations and the module frames ⁰T_n. The connector structure
enters only through static index tables (:func:`tables`), so the traced graph stays small and
compiles fast.

Frames (homogeneous 3×3 on [z, s, 1]) for a connector between lower m and upper n::

    exact (R1 default):  ⁰T_n = ⁰T_m · E_m · Trans([Δ, 0]),   Δ = γ + z_L(0) − z_U(0)
    paper (R1 literal):  ⁰T_n = ⁰T_m · Trans(Δ_p [1, tan θ]) · H_m,   Δ_p = γ − u_n + z_top

with E_m the lower element's rigid map for an SPC (H^SPC) and the identity for a TPC
(H^TPC = I). Global nodes X̄ = ⁰T_n X (SI Eq. global_module_min). The cylinder wrap is
(z, s) ↦ (R cos(s/R), R sin(s/R), z) (MODEL.md §10).
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np

from biplan._compile.setup import array_module, jax, jnp
from biplan.geometry.connector import SPLIT_RANK
from biplan.geometry.development import spans
from biplan.geometry.layout import TubeLayout
from biplan.geometry.module import (
    PIVOT,
    directions,
    guides,
    helical_boundary,
    node_positions,
    reference_nodes,
    rotation,
)
from biplan.options import ChainAttachment, ChainOffset, EndpointDefinition, LoadPoint, TpcSign

__all__ = [
    "Endpoint",
    "GeometryParams",
    "Kinematics",
    "endpoint",
    "kinematics",
    "line_height",
    "load_height",
    "load_point_of_edge",
    "reference_frames",
    "tables",
    "wrap_to_cylinder",
]

Array = Any


class GeometryParams(NamedTuple):
    """Traced geometry scalars: R [mm], l [mm], β [rad]."""

    radius: Array
    pitch: Array
    beta: Array


class Endpoint(NamedTuple):
    """Endpoint observables: axial u_z [mm], transverse u_r [mm], slope θ [rad]."""

    u_z: Array
    u_r: Array
    theta: Array


class Tables(NamedTuple):
    """Static index tables of a layout (NumPy, baked into the compiled kernels)."""

    kinds: tuple  # module kinds
    pt_conn: np.ndarray  # (K,) connector of each field-end point
    pt_s: np.ndarray  # (K,) s symbol rank (0, H1, H2, H)
    pt_up_mod: np.ndarray
    pt_up_el: np.ndarray
    pt_lo_mod: np.ndarray
    pt_lo_el: np.ndarray
    pt_lo_rigid: np.ndarray  # bool
    pt_lo_height: np.ndarray  # 1.0 if the rigid lower edge sits at z = l, 0.0 for the clamp
    seam_pt: np.ndarray  # (Nc,) index of each connector's s = 0 point
    field_start: np.ndarray  # (F,)
    field_end: np.ndarray
    field_conn: np.ndarray
    pt_flip: np.ndarray  # (K,) bool: w ↦ 2γ − w (TpcSign.AS_PRINTED: a TPC's first field end)
    contact_pt: np.ndarray  # (n_cc,) points carrying a contact condition
    contact_conn: np.ndarray
    end_segments: tuple  # free-end edge: ((element, node0, node1), ...)


@functools.lru_cache(maxsize=128)
def tables(layout: TubeLayout) -> Tables:
    """Build the static tables of a layout."""
    cols: dict[str, list] = {k: [] for k in ("c", "s", "um", "ue", "lm", "le", "rig", "hl")}
    seam, fs, fe, fc, cp, cc, flip = [], [], [], [], [], [], []
    printed = layout.options.tpc_sign is TpcSign.AS_PRINTED
    for c, spec in enumerate(layout.connectors):
        first = len(cols["c"])
        seam.append(first)
        for j, ends in enumerate(spec.field_ends()):
            for end in ends:
                cols["c"].append(c)
                cols["s"].append(SPLIT_RANK[end.s])
                cols["um"].append(spec.upper)
                cols["ue"].append(end.upper_element)
                cols["lm"].append(0 if spec.lower is None else spec.lower)
                cols["le"].append(0 if end.lower_element is None else end.lower_element)
                cols["rig"].append(end.lower_element is None)
                cols["hl"].append(0.0 if spec.lower is None else 1.0)
            fs.append(first + 2 * j)
            fe.append(first + 2 * j + 1)
            fc.append(c)
            # SI Eq. VC_w as printed: the first field of a TPC (s from the seam to the split,
            # element 1) is mirrored about γ; its seam end (w = γ) is unchanged.
            flip += [False, printed and spec.kind == "TPC" and j == 0]
        for field, side in spec.contact_points():
            cp.append(first + 2 * field + side)
            cc.append(c)
    ints = {k: np.asarray(v, dtype=np.int32) for k, v in cols.items() if k not in ("rig", "hl")}
    return Tables(
        tuple(s.kind for s in layout.shapes),
        ints["c"],
        ints["s"],
        ints["um"],
        ints["ue"],
        ints["lm"],
        ints["le"],
        np.asarray(cols["rig"], dtype=bool),
        np.asarray(cols["hl"], dtype=float),
        np.asarray(seam, dtype=np.int32),
        np.asarray(fs, dtype=np.int32),
        np.asarray(fe, dtype=np.int32),
        np.asarray(fc, dtype=np.int32),
        np.asarray(flip, dtype=bool),
        np.asarray(cp, dtype=np.int32),
        np.asarray(cc, dtype=np.int32),
        layout.shapes[-1].top.segments,
    )


class Kinematics(NamedTuple):
    """Everything the energy and constraints need, for one configuration q."""

    local_nodes: Array  # (N, 7, 2) nodes in each module frame
    reference: Array  # (N, 7, 2) reference nodes
    guides: Array  # (2N,)
    helical: Array  # (N, 2) boundary elongations (w0, wa)
    helical_length: Array  # a
    point_w: Array  # (K,) connector elongations at field ends
    field_start: Array  # (F,)
    field_end: Array  # (F,)
    field_length: Array  # (F,)
    frames: Array  # (N, 3, 3)


def reference_frames(layout: TubeLayout, geom: GeometryParams) -> tuple[Array, Array, Array]:
    """Reference nodes (N, 7, 2) [mm], crease tangents n_c (N, 2) and opening normals n_sp
    (N, 2) of every module, in its own frame."""
    h, h1, _, _ = spans(geom.radius, geom.pitch, geom.beta)
    kinds, index = _shape_kinds(layout)
    nodes, ncs, nsps = [], [], []
    for kind, mirror in kinds:  # each distinct module shape once: the graph does not grow with N
        nodes.append(reference_nodes(kind, mirror, geom.pitch, h, h1))
        n_c, n_sp = directions(kind, mirror, geom.beta)
        ncs.append(n_c)
        nsps.append(n_sp)
    return jnp.stack(nodes)[index], jnp.stack(ncs)[index], jnp.stack(nsps)[index]


@functools.lru_cache(maxsize=128)
def _shape_kinds(layout: TubeLayout) -> tuple[tuple[Any, ...], np.ndarray]:
    """The distinct (kind, mirror) of a layout's modules and each module's index into them."""
    kinds = tuple(dict.fromkeys((s.kind, s.mirror) for s in layout.shapes))
    index = np.asarray([kinds.index((s.kind, s.mirror)) for s in layout.shapes], np.int32)
    return kinds, index


def line_height(qm: Array, ref: Array, el: Array, z_edge: Array, s: Array) -> Array:
    """z at circumferential position s of the edge line z = z_edge of element ``el``."""
    pivot = jnp.where(el == 0, ref[PIVOT[0]], ref[PIVOT[1]])
    phi = jnp.where(el == 0, qm[1], qm[2])
    p0 = jnp.stack([z_edge, jnp.zeros_like(z_edge)])
    p = rotation(phi) @ (p0 - pivot) + pivot + jnp.stack([qm[0], 0.0])
    return p[0] - (s - p[1]) * jnp.tan(phi)


def _hom(rot: Array, t: Array) -> Array:
    return jnp.concatenate(
        [jnp.concatenate([rot, t[:, None]], axis=1), jnp.array([[0.0, 0.0, 1.0]])], axis=0
    )


def _trans(dz: Array, ds: Array = 0.0) -> Array:
    return _hom(jnp.eye(2), jnp.stack([dz, jnp.asarray(ds, dtype=float) + 0.0 * dz]))


def _element_hom(qm: Array, ref: Array, element: int) -> Array:
    """Homogeneous form of χ_i: r ↦ R(φ_i)(r − P_i) + P_i + [u, 0]."""
    rot = rotation(qm[1 + element])
    p = ref[PIVOT[element]]
    return _hom(rot, p - rot @ p + jnp.stack([qm[0], 0.0]))


def kinematics(layout: TubeLayout, geom: GeometryParams, q: Array) -> Kinematics:
    """Evaluate the tube's kinematics at q (see module docstring)."""
    t = tables(layout)
    n = layout.n_modules
    h, h1, h2, a = spans(geom.radius, geom.pitch, geom.beta)
    ref, n_c, n_sp = reference_frames(layout, geom)
    qm = q[: 3 * n].reshape(n, 3)
    gam = q[3 * n :]
    local = jax.vmap(node_positions)(qm, ref)
    g = jax.vmap(guides)(qm, ref, n_c).reshape(-1)
    w_h = jax.vmap(helical_boundary)(qm, ref, n_sp)

    if layout.n_connectors:
        s_val = jnp.stack([0.0 * h, h1, h2, h])[t.pt_s]
        z_up = jax.vmap(line_height)(
            qm[t.pt_up_mod], ref[t.pt_up_mod], t.pt_up_el, jnp.zeros_like(s_val), s_val
        )
        z_lo_line = jax.vmap(line_height)(
            qm[t.pt_lo_mod], ref[t.pt_lo_mod], t.pt_lo_el, geom.pitch + 0.0 * s_val, s_val
        )
        z_lo = jnp.where(t.pt_lo_rigid, t.pt_lo_height * geom.pitch, z_lo_line)
        delta = gam + z_lo[t.seam_pt] - z_up[t.seam_pt]
        w_pt = z_up + delta[t.pt_conn] - z_lo
        if t.pt_flip.any():  # TpcSign.AS_PRINTED
            w_pt = jnp.where(t.pt_flip, 2.0 * gam[t.pt_conn] - w_pt, w_pt)
        f_start, f_end = w_pt[t.field_start], w_pt[t.field_end]
        f_len = s_val[t.field_end] - s_val[t.field_start]
    else:
        delta = w_pt = f_start = f_end = f_len = jnp.zeros((0,))

    z_lo_seam = z_lo[t.seam_pt] if layout.n_connectors else jnp.zeros((0,))
    frames = _frames(layout, geom, qm, gam, ref, delta, local, z_lo_seam)
    return Kinematics(local, ref, g, w_h, a, w_pt, f_start, f_end, f_len, frames)


def _edge_fit(local: Array, ref: Array, segments: tuple[tuple[int, int, int], ...]) -> Array:
    """Least-squares rigid motion (homogeneous, module frame) of a module's edge: reference
    segment ends → deformed ones, each end weighted by half its segment's reference length."""
    idx = np.array([[a, b] for _, a, b in segments])
    p, q = ref[idx], local[idx]  # (k, 2 ends, 2)
    w = jnp.linalg.norm(p[:, 1] - p[:, 0], axis=1)[:, None] * jnp.ones((1, 2))
    p, q, w = p.reshape(-1, 2), q.reshape(-1, 2), w.reshape(-1)
    pc = (w[:, None] * p).sum(0) / w.sum()
    qc = (w[:, None] * q).sum(0) / w.sum()
    h = ((p - pc) * w[:, None]).T @ (q - qc)
    angle = jnp.arctan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    rot = rotation(angle)
    return _hom(rot, qc - rot @ pc)


def _hom_inverse(h: Array) -> Array:
    rot_t = h[:2, :2].T
    return _hom(rot_t, -rot_t @ h[:2, 2])


def _frames(
    layout: TubeLayout,
    geom: GeometryParams,
    qm: Array,
    gam: Array,
    ref: Array,
    delta: Array,
    local: Array,
    z_lo_seam: Array,
) -> Array:
    out: list[Array | None] = [None] * layout.n_modules
    paper = layout.options.chain_offset is ChainOffset.PAPER
    fit = layout.options.chain_attachment is ChainAttachment.EDGE_FIT
    if not layout.has_base_connector:
        out[0] = jnp.eye(3)
    for c, spec in enumerate(layout.connectors):
        up = spec.upper
        if fit and not paper:
            # R3 EDGE_FIT: the least-squares fit of the upper module's bottom edge sits γ above
            # the fit of the lower module's top edge (the clamp line for the base connector):
            # F_up · fit_up = F_lo · fit_lo · Trans(l + γ)  ⇒  F_up = … · fit_up⁻¹.
            below = (
                _trans(z_lo_seam[c] + gam[c])
                if spec.lower is None
                else out[spec.lower]  # type: ignore[operator]
                @ _edge_fit(local[spec.lower], ref[spec.lower], spec.lower_edge.segments)  # type: ignore[union-attr]
                @ _trans(geom.pitch + gam[c])
            )
            out[up] = below @ _hom_inverse(_edge_fit(local[up], ref[up], spec.upper_edge.segments))
            continue
        if spec.lower is None:
            out[up] = _trans(gam[c] - qm[up, 0]) if paper else _trans(delta[c])
            continue
        lo = spec.lower
        t_lo = out[lo]
        assert t_lo is not None
        e = spec.lower_full_element
        if paper:
            dp = gam[c] - qm[up, 0] + geom.pitch
            if e is None:
                out[up] = t_lo @ _trans(dp)
            else:
                theta = qm[lo, 1 + e]
                pivot = ref[lo, PIVOT[e]] + jnp.stack([qm[lo, 0], 0.0])
                rot = rotation(theta)
                out[up] = t_lo @ _trans(dp, dp * jnp.tan(theta)) @ _hom(rot, pivot - rot @ pivot)
        else:
            attach = t_lo if e is None else t_lo @ _element_hom(qm[lo], ref[lo], e)
            out[up] = attach @ _trans(delta[c])
    return jnp.stack(out)  # type: ignore[arg-type]


def global_nodes(kin: Kinematics) -> Array:
    """Deformed nodes in the global (z, s) plane, (N, 7, 2) [mm] (SI Eq. global_module_min)."""
    xp = array_module(kin.local_nodes, kin.frames)
    hom = xp.concatenate([kin.local_nodes, xp.ones((*kin.local_nodes.shape[:2], 1))], axis=2)
    return xp.einsum("nij,nkj->nki", kin.frames, hom)[..., :2]


def end_edge_points(layout: TubeLayout, kin: Kinematics) -> Array:
    """Global (z, s) of the free-end edge's segment ends, (n_segments, 2, 2)."""
    pts = global_nodes(kin)[-1]
    segs = tables(layout).end_segments
    return jnp.stack([jnp.stack([pts[i0], pts[i1]]) for _, i0, i1 in segs])


def _edge_stats(segs: Array) -> tuple[Array, Array, Array]:
    """Length-weighted mean z, mean s and least-squares tilt θ of a polyline of segments."""
    z0, z1 = segs[:, 0, 0], segs[:, 1, 0]
    s0, s1 = segs[:, 0, 1], segs[:, 1, 1]
    length = jnp.hypot(z1 - z0, s1 - s0)
    total = length.sum()
    zm = (length * (z0 + z1) / 2).sum() / total
    sm = (length * (s0 + s1) / 2).sum() / total
    ss = (length * (s0**2 + s0 * s1 + s1**2) / 3).sum() / total - sm**2
    zs = (length * (2 * z0 * s0 + z0 * s1 + z1 * s0 + 2 * z1 * s1) / 6).sum() / total - zm * sm
    return zm, sm, jnp.arctan(-zs / ss)


def _observables(layout: TubeLayout, kin: Kinematics) -> tuple[Array, Array, Array]:
    segs = end_edge_points(layout, kin)
    if layout.options.endpoint is EndpointDefinition.EDGE:
        return _edge_stats(segs)
    p0, p1 = segs[0, 0], segs[0, 1]
    return p0[0], p0[1], jnp.arctan(-(p1[0] - p0[0]) / (p1[1] - p0[1]))


def endpoint(layout: TubeLayout, geom: GeometryParams, q: Array) -> Endpoint:
    """Endpoint displacement (u_z, u_r) [mm] and slope θ [rad] relative to q = 0 (MODEL R2)."""
    z, s, th = _observables(layout, kinematics(layout, geom, q))
    z0, s0, th0 = _observables(layout, kinematics(layout, geom, jnp.zeros_like(q)))
    return Endpoint(z - z0, s - s0, th - th0)


def _load_point(layout: TubeLayout, geom: GeometryParams, kin: Kinematics) -> Array:
    return load_point_of_edge(layout, geom, end_edge_points(layout, kin))


def load_point_of_edge(layout: TubeLayout, geom: GeometryParams, segs: Array) -> Array:
    """Axial position z [mm] of the load point (MODEL CHOICE W1) on the free-end edge,
    given as its segments' global end points (n_segments, 2, 2)."""
    point = layout.options.load_point
    if point is LoadPoint.CENTROID:
        return _edge_stats(segs)[0]
    if point is LoadPoint.SEAM:
        return segs[0, 0, 0]
    if segs.shape[0] > 1:  # split edge: the split node
        return segs[0, 1, 0]
    h, h1, _, _ = spans(geom.radius, geom.pitch, geom.beta)
    return segs[0, 0, 0] + (h1 / h) * (segs[0, 1, 0] - segs[0, 0, 0])


def load_height(
    layout: TubeLayout, geom: GeometryParams, kin: Kinematics, kin_ref: Kinematics
) -> Array:
    """Axial displacement [mm] of the load point (MODEL CHOICE W1); W_ext = F · this."""
    return _load_point(layout, geom, kin) - _load_point(layout, geom, kin_ref)


def wrap_to_cylinder(points: Array, radius: Array) -> Array:
    """(z, s) ↦ (x, y, z) = (R cos(s/R), R sin(s/R), z) for points (..., 2)."""
    xp = array_module(points, radius)
    z, s = points[..., 0], points[..., 1]
    return xp.stack([radius * xp.cos(s / radius), radius * xp.sin(s / radius), z], axis=-1)
