"""The free end's displacement and tilt (u_z, u_r, θ) of MODEL R2, compiled (Numba).

The free-end edge's segment ends are the top module's nodes in the frame composed up the chain
(:func:`edge_points`, the chain of :mod:`.chainterm`); their length-weighted means and
least-squares tilt (``EndpointDefinition.EDGE``) or the seam node and its segment's slope
(``SEAM_NODE``) give the endpoint (:func:`edge_statistics`), relative to q = 0
(:func:`endpoint`; :func:`biplan.geometry.chain.endpoint` in JAX, the oracle).
"""

from __future__ import annotations

import math

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system.chainterm import _chain_end
from biplan.model.system.elements import angles, rotated
from biplan.model.system.tables import SystemData

__all__ = ["edge_points", "edge_statistics", "endpoint"]


@kernel
def edge_points(d: SystemData, q: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """Global (z, s) [mm] of the free-end edge's segment ends, (S, 2, 2) (the top module's
    nodes in the frame composed up the chain; :func:`biplan.geometry.chain.end_edge_points`)."""
    n = d.ref.shape[0]
    theta, pz, ps = _chain_end(d, q)
    ct, st = math.cos(theta), math.sin(theta)
    segs = d.end_segments
    out = np.zeros((segs.shape[0], 2, 2))
    u, trig = q[3 * n - 3], angles(q[3 * n - 2], q[3 * n - 1])
    for j in range(segs.shape[0]):
        for end in range(2):
            i = segs[j, end]
            z, s, _, _, _, _ = rotated(u, trig, d.ref, n - 1, i, 0 if i < 4 else 1)
            out[j, end, 0] = pz + ct * z - st * s
            out[j, end, 1] = ps + st * z + ct * s
    return out


@kernel
def edge_statistics(segs: np.ndarray, seam: bool) -> tuple[float, float, float]:
    """Mean z, mean s [mm] and tilt θ [rad] of the free-end edge from its segment ends
    (S, 2, 2): the length-weighted means and least-squares tilt (``EndpointDefinition.EDGE``,
    :func:`biplan.geometry.chain._edge_stats`), or the seam node and its segment's slope
    (``seam``, ``SEAM_NODE``)."""
    if seam:
        z0, s0 = segs[0, 0, 0], segs[0, 0, 1]
        z1, s1 = segs[0, 1, 0], segs[0, 1, 1]
        return z0, s0, math.atan(-(z1 - z0) / (s1 - s0))
    total = zm = sm = ss = zs = 0.0
    for j in range(segs.shape[0]):
        z0, s0 = segs[j, 0, 0], segs[j, 0, 1]
        z1, s1 = segs[j, 1, 0], segs[j, 1, 1]
        length = math.hypot(z1 - z0, s1 - s0)
        total += length
        zm += length * (z0 + z1) / 2
        sm += length * (s0 + s1) / 2
        ss += length * (s0 * s0 + s0 * s1 + s1 * s1) / 3
        zs += length * (2 * z0 * s0 + z0 * s1 + z1 * s0 + 2 * z1 * s1) / 6
    zm /= total
    sm /= total
    ss = ss / total - sm * sm
    zs = zs / total - zm * sm
    return zm, sm, math.atan(-zs / ss)


@kernel
def endpoint(d: SystemData, q: np.ndarray) -> tuple[float, float, float]:
    """(u_z [mm], u_r [mm], θ [rad]) of the free end relative to q = 0 (MODEL R2)."""
    seam = d.flags[1] == 1
    now = edge_statistics(edge_points(d, q), seam)
    ref = edge_statistics(edge_points(d, np.zeros(d.sizes[0])), seam)
    return now[0] - ref[0], now[1] - ref[1], now[2] - ref[2]
