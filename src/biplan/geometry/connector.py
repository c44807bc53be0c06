"""Circular-fold connectors between neighbouring modules (SI Eqs. VC_w, 25; MODEL.md §7).

A connector joins the top edge of a lower module (or the flat clamp edge) to the bottom edge of
an upper module. Its *attachment frame* is the body frame of the lower element when the lower
edge is held by one element (SPC: open chain, the SI's H^SPC) and the lower module frame
otherwise (TPC: closed loop, H^TPC = I). The upper module frame is the attachment frame
translated axially by Δ = γ + z_L(0) − z_U(0), so that the opening at the seam is exactly γ.

The elongation at circumferential position s is the axial gap between the two edge lines, each
rotated with its element and evaluated at fixed s::

    w(s) = z_U(s) + Δ − z_L(s),     z_e(s) = z_e(0) − s tan φ_e

The split points cut [0, H] into fields on which w is linear: one field for two full edges
(SPC: w = γ − s tan φ1), two for coinciding splits (TPC: w_ℓ = γ ± x[tan φ_ℓ − tan φ_ℓ']),
three when the splits differ (point-reflection mirror). This module only builds the *static*
description (which element of which module bounds each field end); the traced evaluation is
vectorised in :mod:`biplan.geometry.kinematics`.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

from biplan.geometry.module import Edge

__all__ = ["SPLIT_RANK", "ConnectorSpec", "FieldEnd"]

#: Circumferential positions by symbol: 0 → s = 0, 1 → H1, 2 → H2, 3 → H.
SPLIT_RANK = {"0": 0, "H1": 1, "H2": 2, "H": 3}


@dataclass(frozen=True)
class FieldEnd:
    """One end of a connector field: where (symbol of s) and which elements bound it.

    ``lower_element`` is ``None`` when the lower edge is rigid in the attachment frame (a full
    lower edge, whose body frame carries the upper module, or the clamp).
    """

    s: str
    upper_element: int
    lower_element: int | None


@dataclass(frozen=True)
class ConnectorSpec:
    """Static description of one circular connector.

    ``lower`` is the index of the lower module or ``None`` for the clamp; ``lower_edge`` is its
    top edge (``None`` for the flat clamp). ``h1_first`` tells whether H1 ≤ H2 (the order of
    the split points when the two edges split at different places).
    """

    lower: int | None
    upper: int
    lower_edge: Edge | None
    upper_edge: Edge
    h1_first: bool = True

    @property
    def splits(self) -> tuple[str, ...]:
        """Distinct split symbols inside (0, H), in increasing s."""
        out: list[str] = []
        for e in (self.lower_edge, self.upper_edge):
            if e is not None and e.split is not None and e.split not in out:
                out.append(e.split)
        order = ("H1", "H2") if self.h1_first else ("H2", "H1")
        return tuple(s for s in order if s in out)

    @property
    def n_fields(self) -> int:
        """Number of linear BiPlan fields of this connector."""
        return len(self.splits) + 1

    @property
    def kind(self) -> str:
        """``"SPC"`` (one field), ``"TPC"`` (two) or ``"3PC"`` (three, mismatched splits)."""
        return {1: "SPC", 2: "TPC"}.get(self.n_fields, "3PC")

    @property
    def lower_full_element(self) -> int | None:
        """Element holding the lower edge when it is a full edge (SPC attachment), else None."""
        e = self.lower_edge
        if e is not None and len(e.segments) == 1:
            return e.segments[0][0]
        return None

    def field_ends(self) -> tuple[tuple[FieldEnd, FieldEnd], ...]:
        """(start, end) of every field, in increasing s."""
        bounds = ("0", *self.splits, "H")
        rank = {b: i for i, b in enumerate(bounds)}

        def element(edge: Edge | None, hi: str) -> int | None:
            if edge is None:
                return None
            if edge.split is None:
                return edge.segments[0][0]
            return edge.segments[0 if rank[hi] <= rank[edge.split] else 1][0]

        out = []
        rigid_lower = self.lower_edge is None or self.lower_full_element is not None
        for a, b in itertools.pairwise(bounds):
            up = element(self.upper_edge, b)
            lo = None if rigid_lower else element(self.lower_edge, b)
            assert up is not None
            out.append((FieldEnd(a, up, lo), FieldEnd(b, up, lo)))
        return tuple(out)

    def contact_points(self) -> tuple[tuple[int, int], ...]:
        """Distinct boundary points as (field, 0 = start | 1 = end): the seam, both sides of
        each split, and the far end s = H only for a single (SPC) field — with split edges both
        elements pivot at the seam, so w(H) = γ there."""
        n = self.n_fields
        pts = [(0, 0)]
        for k in range(n - 1):
            pts += [(k, 1), (k + 1, 0)]
        if n == 1:
            pts.append((0, 1))
        return tuple(pts)
