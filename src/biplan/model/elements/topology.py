"""Static index tables of a layout's elements and the scatter-add that places element blocks
into the global gradient, Hessian and constraint Jacobians (:mod:`biplan.model.elements`)."""

from __future__ import annotations

import functools
from typing import Any, NamedTuple

import numpy as np

from biplan._compile.setup import jnp
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.options import ContactForm

__all__ = ["CONNECTOR_DOFS", "Topology", "place_matrix", "place_vector", "topology"]

Array = Any

#: Local coordinates of a connector element: lower module (3), upper module (3), γ.
CONNECTOR_DOFS = 7


class Topology(NamedTuple):
    """Static index tables of a layout's elements (NumPy; baked into compiled kernels).

    P, F and G are the most points, fields and contact rows of any connector; shorter
    connectors are padded with masked entries. The element blocks are added into the global
    arrays at these indices (:func:`place_vector`, :func:`place_matrix`).
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
    connector_dof_mask: np.ndarray  # (Nc, 7) float 1/0: 0 for the clamp's (absent) dofs
    module_rows: np.ndarray  # (N, 2) rows 2n, 2n + 1: module n's guides and helical gaps
    n_contacts: int


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
    rows = np.arange(2 * n, dtype=np.int32).reshape(n, 2)
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
        dof_mask,
        rows,
        contact_row,
    )


def place_vector(index: np.ndarray, values: Array, size: int, mask: Any = None) -> Array:
    """Σ_e of element vectors ``values`` (E, k) added at rows ``index`` (E, k): an (size,)
    vector (entries where ``mask`` is 0 add nothing)."""
    values = values if mask is None else values * mask
    return jnp.zeros(size, values.dtype).at[index.reshape(-1)].add(values.reshape(-1))


def place_matrix(
    rows: np.ndarray,
    blocks: Array,
    cols: np.ndarray,
    shape: tuple[int, int],
    row_mask: Any = None,
    col_mask: Any = None,
) -> Array:
    """Σ_e of element blocks (E, r, c) added at rows ``rows`` (E, r) and columns ``cols``
    (E, c) of a zero (shape) matrix: one scatter-add of the E·r·c entries, O(E) work beside
    the dense result."""
    if row_mask is not None:
        blocks = blocks * row_mask[:, :, None]
    if col_mask is not None:
        blocks = blocks * col_mask[:, None, :]
    e, r, c = blocks.shape
    ri = np.broadcast_to(rows[:, :, None], (e, r, c)).reshape(-1)
    ci = np.broadcast_to(cols[:, None, :], (e, r, c)).reshape(-1)
    return jnp.zeros(shape, blocks.dtype).at[ri, ci].add(blocks.reshape(-1))
