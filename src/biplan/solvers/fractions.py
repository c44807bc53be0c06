"""The branch fractions of every fold on the compiled system (Numba; MODEL §9).

The fraction of each fold's length on the closed, spinodal and open branch of its trilinear
law: a helical fold's from its two boundary elongations, a connector's length-weighted over its
fields (the compiled :func:`biplan.model.potential.phase_fractions`). The observation of a
state records them (:mod:`biplan.solvers.observation`); the state search labels states by them.
"""

from __future__ import annotations

import numpy as np

from biplan._compile.numba_cache import kernel
from biplan.model.system import assemble
from biplan.model.system.elements import connector_points
from biplan.model.system.tables import SystemData

__all__ = ["branch_fractions", "circular_fractions", "phase_fractions", "segment_fractions"]


@kernel
def segment_fractions(w0: float, wl: float, law: np.ndarray, out: np.ndarray) -> None:
    """Adds the fractions of a linear field from w0 to wL [mm] on the closed, spinodal and open
    branch of law = (k1, k2, k3, w1, w2) to ``out`` (3,)
    (:func:`biplan.laws._jax.phase_fractions`)."""
    w1, w2 = law[3], law[4]
    lo, hi = min(w0, wl), max(w0, wl)
    width = hi - lo
    if width < 1e-14:  # the branch of the midpoint
        mid = 0.5 * (w0 + wl)
        out[0 if mid < w1 else (1 if mid < w2 else 2)] += 1.0
        return
    b2 = min(max(w2, lo), hi)
    b1 = min(min(max(w1, lo), hi), b2)
    out[0] += (b1 - lo) / width
    out[1] += (b2 - b1) / width
    out[2] += (hi - b2) / width


@kernel
def circular_fractions(d: SystemData, q: np.ndarray, out: np.ndarray) -> None:
    """Fills ``out`` (Nc, 3) with each connector's length-weighted branch fractions."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    pitch = d.scalars[0]
    x = np.zeros(7)
    part = np.zeros(3)
    for c in range(nc):
        lo, up = d.conn_lower[c], d.conn_upper[c]
        for k in range(3):
            x[k] = 0.0 if lo < 0 else q[3 * lo + k]
            x[3 + k] = q[3 * up + k]
        x[6] = q[3 * n + c]
        first, last = d.conn_first_point[c], d.conn_first_point[c + 1]
        w, _, _ = connector_points(
            x,
            d.ref[max(lo, 0)],
            d.ref[up],
            pitch,
            first,
            last,
            d.point_s,
            d.point_upper_element,
            d.point_lower_element,
            d.point_rigid,
            d.point_height,
            d.point_flip,
        )
        total = 0.0
        for f in range(d.conn_first_field[c], d.conn_first_field[c + 1]):
            i0, i1 = d.field_start[f], d.field_end[f]
            length = d.point_s[i1] - d.point_s[i0]
            part[:] = 0.0
            segment_fractions(w[i0 - first], w[i1 - first], d.circular[c], part)
            for j in range(3):
                out[c, j] += length * part[j]
            total += length
        for j in range(3):
            out[c, j] /= total


@kernel
def branch_fractions(d: SystemData, q: np.ndarray, gaps: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """(N + Nc, 3) branch fractions of every fold, helical then circular, at q with gaps w_∂."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    fractions = np.zeros((n + nc, 3))
    for i in range(n):  # helical boundary elongations (w0, wa) are the module's gaps
        segment_fractions(gaps[2 * i], gaps[2 * i + 1], d.helical[i], fractions[i])
    if nc:
        circular_fractions(d, q, fractions[n:])
    return fractions


@kernel
def phase_fractions(d: SystemData, q: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The fraction of every fold's length on the closed, spinodal and open branch of its law,
    (N + Nc, 3), helical folds then circular (:func:`biplan.model.potential.phase_fractions`)."""
    n_g, n_c = d.sizes[1], d.sizes[2]
    gaps = assemble.terms(d, q, np.zeros(n_g), np.zeros(n_c), False)[3]
    return branch_fractions(d, q, gaps)
