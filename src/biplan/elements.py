"""Local terms of the BiPlan Lagrangian, evaluated per element and assembled (main Eq.
mft_energy_assembly; MODEL §4–7, §11).

The strain energy and the constraints are sums of local terms, as in a finite-element code:

* a **module** element n sees its own coordinates x_n = (u_n, φ1_n, φ2_n): the helical field
  energy, the two guides g (SI Eq. 11) and the two helical contact gaps (w0, wa) (SI Eq. bound);
* a **connector** element c sees x_c = (x_lower, x_upper, γ_c) (7 numbers; the clamp's
  coordinates are absent for the base fold): the energies of its circular fields and its
  contact gaps (MODEL C1).

Each kind of element is one small pure function of its local coordinates; its gradient,
Hessian and constraint Jacobian come from local autodiff, and ``vmap`` lifts it over the chain
(the element is the unit of compilation; the number of elements is an array dimension). The
local blocks are scattered into the global gradient, Hessian and Jacobian by index tables
(:func:`topology`). Only the load point z_p sees the whole chain (module frames compose along
it); its gradient and Hessian are taken by autodiff of the chain alone, never of the energy
(:func:`chain_terms`). The dense autodiff of the whole Lagrangian is kept as the independent
test oracle (:mod:`biplan._oracle`).

A new kind of fold or connector is one local function of its element's coordinates (as
:func:`module_lagrangian`, :func:`connector_lagrangian`) plus its rows of the index tables.
"""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np

from biplan._jax import jax, jnp
from biplan.geometry import chain, frames
from biplan.geometry.development import spans
from biplan.geometry.module import guides, helical_boundary
from biplan.geometry.tube import TubeLayout
from biplan.laws import _kernels as law_kernels
from biplan.options import ContactForm

__all__ = [
    "ChainTerms",
    "LocalTerms",
    "Topology",
    "chain_terms",
    "connector_lagrangian",
    "local_terms",
    "module_lagrangian",
    "topology",
]

Array = Any

#: Local coordinates of a connector element: lower module (3), upper module (3), γ.
CONNECTOR_DOFS = 7


class Topology(NamedTuple):
    """Static index tables of a layout's elements (NumPy; baked into compiled kernels).

    P, F and G are the most points, fields and contact rows of any connector; shorter
    connectors are padded with masked entries.
    """

    module_dofs: np.ndarray  # (N, 3) global coordinate of each module dof
    connector_dofs: np.ndarray  # (Nc, 7) global coordinate of each connector dof
    point_s: np.ndarray  # (Nc, P) s rank of each field-end point (seam first)
    point_upper_element: np.ndarray  # (Nc, P)
    point_lower_element: np.ndarray  # (Nc, P)
    point_rigid: np.ndarray  # (Nc, P) bool: the lower edge is the clamp or a rigid edge
    point_height: np.ndarray  # (Nc, P) z of a rigid lower edge, in units of l
    point_flip: np.ndarray  # (Nc, P) bool: w ↦ 2γ − w (TpcSign.AS_PRINTED)
    field_start: np.ndarray  # (Nc, F) local point index
    field_end: np.ndarray  # (Nc, F)
    field_mask: np.ndarray  # (Nc, F) float 1/0
    gap_point: np.ndarray  # (Nc, G) local point of each contact row (PER_ENDPOINT)
    gap_point_mask: np.ndarray  # (Nc, G) float 1/0
    gap_row: np.ndarray  # (Nc, Gr) global contact row of each connector gap
    gap_row_mask: np.ndarray  # (Nc, Gr) float 1/0
    lower: np.ndarray  # (Nc,) lower module (0 for the clamp: its rows never enter)
    upper: np.ndarray  # (Nc,)
    module_place: np.ndarray  # (N, 3, n_q) one-hot placement of each module dof
    connector_place: np.ndarray  # (Nc, 7, n_q) the same for connector dofs (clamp rows 0)
    guide_place: np.ndarray  # (N, 2, 2N) guide rows
    helical_gap_place: np.ndarray  # (N, 2, n_c) helical contact rows
    gap_place: np.ndarray  # (Nc, Gr, n_c) connector contact rows (padding rows 0)


def _pad(rows: list[list[Any]], fill: Any, dtype: Any) -> tuple[np.ndarray, np.ndarray]:
    width = max((len(r) for r in rows), default=0)
    width = max(width, 1)
    out = np.full((len(rows), width), fill, dtype=dtype)
    mask = np.zeros((len(rows), width))
    for i, r in enumerate(rows):
        out[i, : len(r)] = r
        mask[i, : len(r)] = 1.0
    return out, mask


@functools.lru_cache(maxsize=128)
def topology(layout: TubeLayout) -> Topology:
    """Element index tables of a layout, from :func:`biplan.geometry.chain.tables`."""
    t = chain.tables(layout)
    n, nc = layout.n_modules, layout.n_connectors
    module_dofs = 3 * np.arange(n, dtype=np.int32)[:, None] + np.arange(3, dtype=np.int32)
    minimum = layout.options.contact is ContactForm.MINIMUM
    cols: dict[str, list[list[Any]]] = {k: [] for k in ("s", "ue", "le", "rig", "hl", "fl")}
    fs, fe, gp, gr = [], [], [], []
    lower, upper, dofs = [], [], []
    contact_row = 2 * n
    for c in range(nc):
        pts = np.flatnonzero(t.pt_conn == c)
        first = int(pts[0])
        assert first == int(t.seam_pt[c])  # the seam is a connector's first point
        cols["s"].append(list(t.pt_s[pts]))
        cols["ue"].append(list(t.pt_up_el[pts]))
        cols["le"].append(list(t.pt_lo_el[pts]))
        cols["rig"].append(list(t.pt_lo_rigid[pts]))
        cols["hl"].append(list(t.pt_lo_height[pts]))
        cols["fl"].append(list(t.pt_flip[pts]))
        fields = np.flatnonzero(t.field_conn == c)
        fs.append(list(t.field_start[fields] - first))
        fe.append(list(t.field_end[fields] - first))
        contacts = list(t.contact_pt[t.contact_conn == c] - first)
        gp.append(contacts)
        n_rows = 1 if minimum else len(contacts)
        gr.append(list(range(contact_row, contact_row + n_rows)))
        contact_row += n_rows
        lo, up = layout.connectors[c].lower, layout.connectors[c].upper
        lower.append(0 if lo is None else lo)
        upper.append(up)
        dofs.append([*module_dofs[lower[-1]], *module_dofs[up], 3 * n + c])
    point_s, _ = _pad(cols["s"], 0, np.int32)
    point_ue, _ = _pad(cols["ue"], 0, np.int32)
    point_le, _ = _pad(cols["le"], 0, np.int32)
    point_rigid, _ = _pad(cols["rig"], True, bool)
    point_height, _ = _pad(cols["hl"], 0.0, float)
    point_flip, _ = _pad(cols["fl"], False, bool)
    field_start, field_mask = _pad(fs, 0, np.int32)
    field_end, _ = _pad(fe, 0, np.int32)
    gap_point, gap_point_mask = _pad(gp, 0, np.int32)
    gap_row, gap_row_mask = _pad(gr, 0, np.int32)
    connector_dofs = np.asarray(dofs, dtype=np.int32).reshape(nc, CONNECTOR_DOFS)
    clamp = np.asarray([c.lower is None for c in layout.connectors], dtype=bool)
    dof_mask = np.ones((nc, CONNECTOR_DOFS))
    dof_mask[clamp, :3] = 0.0
    nq, rows = layout.n_coordinates, np.arange(2 * n).reshape(n, 2)
    return Topology(
        module_dofs,
        connector_dofs,
        point_s,
        point_ue,
        point_le,
        point_rigid,
        point_height,
        point_flip,
        field_start,
        field_end,
        field_mask,
        gap_point,
        gap_point_mask,
        gap_row,
        gap_row_mask,
        np.asarray(lower, dtype=np.int32),
        np.asarray(upper, dtype=np.int32),
        _one_hot(module_dofs, nq),
        _one_hot(connector_dofs, nq, dof_mask),
        _one_hot(rows, 2 * n),
        _one_hot(rows, contact_row),
        _one_hot(gap_row, contact_row, gap_row_mask),
    )


def _one_hot(index: np.ndarray, size: int, mask: np.ndarray | None = None) -> np.ndarray:
    """(…, size) one-hot rows of integer indices (zero rows where ``mask`` is 0)."""
    out = (index[..., None] == np.arange(size)).astype(float)
    return out if mask is None else out * mask[..., None]


# --- element functions -------------------------------------------------------------------
def module_constraints(x: Array, ref: Array, n_c: Array, n_sp: Array) -> Array:
    """(g_C, g_F, w0, wa) [mm] of one module from its coordinates x = (u, φ1, φ2)."""
    return jnp.concatenate([guides(x, ref, n_c), helical_boundary(x, ref, n_sp)])


def module_lagrangian(
    x: Array,
    multipliers: Array,
    ref: Array,
    n_c: Array,
    n_sp: Array,
    length: Array,
    coeffs: Array,
) -> Array:
    """Module element's share of L [N·mm]: Ψ-energy of its helical field + λ_g·g − λ_∂·w.

    ``multipliers`` = (λ_gC, λ_gF, λ_∂0, λ_∂a); ``coeffs`` the helical law row (5,).
    """
    w = helical_boundary(x, ref, n_sp)
    energy = law_kernels.field_energy(w[0], w[1], length, tuple(coeffs))
    return energy + multipliers[:2] @ guides(x, ref, n_c) - multipliers[2:] @ w


def connector_points(
    x: Array,
    ref_lower: Array,
    ref_upper: Array,
    s: Array,
    upper_element: Array,
    lower_element: Array,
    rigid: Array,
    height: Array,
    pitch: Array,
    flip: Array | None = None,
) -> Array:
    """Elongation w [mm] of a connector at its field-end points (point 0 is the seam).

    w(s) = z_U(s) + Δ − z_L(s), Δ = γ + z_L(0) − z_U(0) (SI Eqs. VC_w, MODEL §7); at the
    points marked by ``flip`` (the first field's split end of a TPC under
    ``TpcSign.AS_PRINTED``, a static table) 2γ − w instead.
    """
    lo, up, gam = x[:3], x[3:6], x[6]
    line = jax.vmap(chain.line_height, in_axes=(None, None, 0, 0, 0))
    z_up = line(up, ref_upper, upper_element, jnp.zeros_like(s), s)
    z_lo = jnp.where(rigid, height * pitch, line(lo, ref_lower, lower_element, pitch + 0.0 * s, s))
    w = z_up + (gam + z_lo[0] - z_up[0]) - z_lo
    if flip is not None:
        w = jnp.where(flip, 2.0 * gam - w, w)
    return w


class ConnectorData(NamedTuple):
    """Traced per-connector data of :func:`connector_lagrangian` (one row of each table)."""

    ref_lower: Array
    ref_upper: Array
    s: Array  # (P,) s of each point [mm]
    upper_element: Array
    lower_element: Array
    rigid: Array
    height: Array
    field_start: Array
    field_end: Array
    field_mask: Array
    gap_point: Array
    gap_point_mask: Array
    coeffs: Array  # (5,) circular law row
    flip: Array | None = None  # (P,) bool, only under TpcSign.AS_PRINTED


def connector_gaps(
    x: Array, d: ConnectorData, pitch: Array, minimum: bool, width: Array
) -> tuple[Array, Array]:
    """(field energies (F,) [N·mm], contact gaps [mm]) of one connector element."""
    w = connector_points(
        x,
        d.ref_lower,
        d.ref_upper,
        d.s,
        d.upper_element,
        d.lower_element,
        d.rigid,
        d.height,
        pitch,
        d.flip,
    )
    length = d.s[d.field_end] - d.s[d.field_start]
    energies = d.field_mask * law_kernels.field_energy(
        w[d.field_start], w[d.field_end], length, tuple(d.coeffs)
    )
    pts = w[d.gap_point]
    if minimum:  # MODEL C1 MINIMUM: −τ logsumexp(−w/τ) over the connector's points
        gaps = -width * jax.nn.logsumexp(jnp.where(d.gap_point_mask > 0, -pts / width, -jnp.inf))
        return energies, gaps[None]
    return energies, pts * d.gap_point_mask


def connector_lagrangian(
    x: Array, multipliers: Array, d: ConnectorData, pitch: Array, minimum: bool, width: Array
) -> Array:
    """Connector element's share of L [N·mm]: its field energies − λ_∂·w_∂."""
    energies, gaps = connector_gaps(x, d, pitch, minimum, width)
    return energies.sum() - multipliers @ gaps


# --- assembly ----------------------------------------------------------------------------
class LocalTerms(NamedTuple):
    """The local part of the KKT system at (q, λ, λ_∂), assembled over the chain."""

    gradient: Array  # (n_q,) ∇_q of Π + λ·g − λ_∂·w_∂
    hessian: Array  # (n_q, n_q) its Hessian (None unless second order)
    guides: Array  # (2N,)
    gaps: Array  # (n_c,)
    guide_jacobian: Array  # (2N, n_q) (None unless second order)
    gap_jacobian: Array  # (n_c, n_q) (None unless second order)
    helical_energy: Array  # (N,)
    circular_energy: Array  # (Nc,)


def _module_arrays(layout: TubeLayout, p: Any) -> tuple[Array, Array, Array, Array]:
    geom = p.geometry
    ref, n_c, n_sp = chain.reference_frames(layout, geom)
    _, _, _, a = spans(geom.radius, geom.pitch, geom.beta)
    return ref, n_c, n_sp, a


def _connector_data(layout: TubeLayout, p: Any, ref: Array) -> ConnectorData:
    topo = topology(layout)
    geom = p.geometry
    h, h1, h2, _ = spans(geom.radius, geom.pitch, geom.beta)
    s_values = jnp.stack([0.0 * h, h1, h2, h])
    return ConnectorData(
        ref[topo.lower],
        ref[topo.upper],
        s_values[topo.point_s],
        topo.point_upper_element,
        topo.point_lower_element,
        topo.point_rigid,
        topo.point_height,
        topo.field_start,
        topo.field_end,
        topo.field_mask,
        topo.gap_point,
        topo.gap_point_mask,
        p.circular,
        jnp.asarray(topo.point_flip) if topo.point_flip.any() else None,
    )


def _place_vector(place: Array, values: Array) -> Array:
    """Σ_e of element vectors (E, k) placed by one-hot rows (E, k, n): an (n,) vector."""
    return jnp.einsum("ek,ekn->n", values, place)


def _place_matrix(rows: Array, blocks: Array, cols: Array) -> Array:
    """Σ_e of element blocks (E, r, c) placed by one-hot rows (E, r, R) and cols (E, c, C).

    Dense products with constant one-hot tables rather than a scatter: XLA:CPU runs a
    scatter of many small blocks as a loop over them (slow, and much slower under ``vmap``),
    while these are two matrix products.
    """
    return jnp.einsum("eri,erj->ij", rows, jnp.einsum("erc,ecj->erj", blocks, cols))


def _evaluate(lagrangian: Any, values: Any, second_order: bool) -> Any:
    """Per element, (∇ℓ, constraint rows c, extras, ∇²ℓ, ∂c/∂x) of an element's Lagrangian
    ℓ(x, …) and ``values(x, …) = (c, extras)``, in one forward-over-reverse pass (second
    derivatives are None unless ``second_order``)."""

    def first(x: Array, *args: Any) -> tuple[tuple[Array, Array], tuple[Array, Array, Array]]:
        grad = jax.jacfwd(lagrangian)(x, *args)
        rows, extras = values(x, *args)
        return (grad, rows), (grad, rows, extras)

    def evaluate(x: Array, *args: Any) -> tuple[Array, ...]:
        if not second_order:
            grad, rows, extras = first(x, *args)[1]
            return grad, rows, extras, None, None
        (hess, jac), (grad, rows, extras) = jax.jacfwd(first, has_aux=True)(x, *args)
        return grad, rows, extras, hess, jac

    return jax.vmap(evaluate)


def local_terms(
    layout: TubeLayout,
    p: Any,
    q: Array,
    lam: Array,
    lam_c: Array,
    second_order: bool = True,
) -> LocalTerms:
    """Evaluate every element and assemble (see module docstring).

    Parameters
    ----------
    layout, p
        The tube layout and the model's traced parameters (:class:`biplan.assembly.ModelParams`).
    q, lam, lam_c
        Coordinates (n_q,), guide multipliers (2N,) [N], contact multipliers (n_c,) [N/mm].
    second_order
        Also assemble the Hessian and the constraint Jacobians.
    """
    topo = topology(layout)
    n, nc = layout.n_modules, layout.n_connectors
    ref, n_c, n_sp, a = _module_arrays(layout, p)
    mult = jnp.concatenate([lam.reshape(n, 2), lam_c[: 2 * n].reshape(n, 2)], axis=1)

    def mod_lag(x: Array, m: Array, r: Array, nc_: Array, nsp: Array, k: Array) -> Array:
        return module_lagrangian(x, m, r, nc_, nsp, a, k)

    def mod_values(x: Array, m: Array, r: Array, nc_: Array, nsp: Array, k: Array) -> Any:
        rows = module_constraints(x, r, nc_, nsp)
        return rows, law_kernels.field_energy(rows[2], rows[3], a, tuple(k))

    grad_m, cons_m, helical_energy, hess_m, jac_m = _evaluate(mod_lag, mod_values, second_order)(
        q[topo.module_dofs], mult, ref, n_c, n_sp, p.helical
    )
    gradient = _place_vector(topo.module_place, grad_m)
    gaps = _place_vector(topo.helical_gap_place, cons_m[:, 2:])
    hessian: Array = None
    guide_jac: Array = None
    gap_jac: Array = None
    if second_order:
        place = topo.module_place
        hessian = _place_matrix(place, hess_m, place)
        guide_jac = _place_matrix(topo.guide_place, jac_m[:, :2], place)
        gap_jac = _place_matrix(topo.helical_gap_place, jac_m[:, 2:], place)
    circular_energy = jnp.zeros((0,))

    if nc:
        minimum = layout.options.contact is ContactForm.MINIMUM
        width, pitch = p.smooth_min_width, p.geometry.pitch

        def con_lag(x: Array, m: Array, d: ConnectorData) -> Array:
            return connector_lagrangian(x, m, d, pitch, minimum, width)

        def con_values(x: Array, m: Array, d: ConnectorData) -> Any:
            energies, rows = connector_gaps(x, d, pitch, minimum, width)
            return rows, energies.sum()

        dofs, gap_row = topo.connector_dofs, topo.gap_row
        grad_c, gaps_c, circular_energy, hess_c, jac_c = _evaluate(
            con_lag, con_values, second_order
        )(q[dofs], lam_c[gap_row] * topo.gap_row_mask, _connector_data(layout, p, ref))
        place = topo.connector_place
        gradient = gradient + _place_vector(place, grad_c)
        gaps = gaps + _place_vector(topo.gap_place, gaps_c)
        if second_order:
            hessian = hessian + _place_matrix(place, hess_c, place)
            gap_jac = gap_jac + _place_matrix(topo.gap_place, jac_c, place)
    return LocalTerms(
        gradient,
        hessian,
        cons_m[:, :2].reshape(-1),
        gaps,
        guide_jac,
        gap_jac,
        helical_energy,
        circular_energy,
    )


class ChainTerms(NamedTuple):
    """The load point's axial displacement z_p [mm] and its derivatives (MODEL W1)."""

    value: Array
    gradient: Array  # (n_q,)
    hessian: Array  # (n_q, n_q) (None unless second order)


def load_point_height(layout: TubeLayout, geom: chain.GeometryParams, q: Array) -> Array:
    """z_p(q) [mm]: the load point's axial displacement from q = 0 (the chain's only term).

    On the default chain readings the frames are composed by a scan over the connectors
    (:mod:`biplan.geometry.frames`); other readings use the general construction.
    """
    if frames.scannable(layout):
        return frames.load_point_height(layout, geom, q)
    ref = chain.kinematics(layout, geom, jnp.zeros_like(q))  # depends on the geometry only
    return chain.load_height(layout, geom, chain.kinematics(layout, geom, q), ref)


def chain_terms(
    layout: TubeLayout, geom: chain.GeometryParams, q: Array, second_order: bool = True
) -> ChainTerms:
    """z_p with its gradient and (optionally) Hessian, by autodiff of the chain alone."""
    fn = functools.partial(load_point_height, layout, geom)
    value, gradient = jax.value_and_grad(fn)(q)
    return ChainTerms(value, gradient, jax.hessian(fn)(q) if second_order else None)
