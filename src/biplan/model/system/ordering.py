"""The order of the unknowns for the bordered banded solve of the KKT Jacobian (layout data).

:func:`solve_layout` finds, once per tube layout, the structure that
:mod:`biplan.solvers.bordered` exploits: the structural pattern of ∂r/∂z (the union of the
Jacobians at two random states under an end force and displacement control at once, so that
the chain term and the end constraint's row and column are in it), its border (the unknowns
whose rows couple more than a few others, taken greedily: the frame angles α_c of the chain
term and the multiplier μ) and a reverse Cuthill–McKee order of the rest, whose bandwidths
it measures; of the borders of :data:`DEGREE_LIMITS` it keeps the cheapest
(:func:`solve_cost`). The result enters :class:`~.tables.SystemData` as ``solve_order`` (the
inner unknowns in band order, then the border) and ``solve_band`` (n_inner, kl, ku); both
are empty, and every solve is dense LU, for tubes below :data:`MIN_UNKNOWNS` unknowns, when
the structure does not pay (:data:`MIN_GAIN`; e.g. denser chains of other readings) or when
``BIPLAN_KKT_SOLVE=dense`` (:data:`SOLVE_ENV`).

Measured crossover (``benchmarks/bench_linear.py``, docs/performance.md): the bordered banded
solve wins from N = 12 (n_z = 127) on, by ≈ 10× at N = 48; at N = 6 (n_z = 64) dense LU is as
fast, so tubes below :data:`MIN_UNKNOWNS` keep it.
"""

from __future__ import annotations

import os

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import reverse_cuthill_mckee

from biplan.model.system import assemble
from biplan.model.system.tables import SystemData

__all__ = [
    "DEGREE_LIMITS",
    "MIN_GAIN",
    "MIN_UNKNOWNS",
    "PATTERN_LOAD",
    "SOLVE_ENV",
    "jacobian_pattern",
    "solve_cost",
    "solve_layout",
]

#: Environment variable: ``dense`` gives every layout seen afterwards dense LU (the linear
#: algebra of earlier versions, for comparisons: ``benchmarks/bench_long_tube.py``).
SOLVE_ENV = "BIPLAN_KKT_SOLVE"
#: Tubes with fewer unknowns n_z solve densely (N = 6: 64 unknowns; N = 12: 127).
MIN_UNKNOWNS = 100
#: The border takes unknowns while one couples more than this many of the others; each limit
#: is tried, and the cheapest arrangement (:func:`solve_cost`) kept.
DEGREE_LIMITS = (6, 8, 10, 12, 16, 20, 24, 32)
#: (F [N], u [mm], control) of :func:`jacobian_pattern`: an end force and, with the control
#: half-way (a value no solve uses), the displacement constraint's row and column too, so that
#: one evaluation carries the terms of both loads (the force's curvature of the load point,
#: μ·control − F ≠ 0 at μ ∈ (0.5, 1)).
PATTERN_LOAD = (1.0, 0.5, 0.5)
#: The structure is used only where its flops are at most 1/this of dense LU's (2n³/3).
MIN_GAIN = 4.0


def jacobian_pattern(data: SystemData, seed: int = 0) -> sp.csr_matrix:
    """Boolean sparse (n_z, n_z): where ∂r/∂z can be non-zero, symmetrised: the union of the
    Jacobians at two random states under :data:`PATTERN_LOAD`, an end force and displacement
    control at once (the union of the Jacobians under each load alone, but for entries of
    rounding: terms of the chain that cancel to 1e-20 … 1e-16 of the largest)."""
    n_q, n_g, n_c = (int(v) for v in data.sizes)
    n_z = n_q + n_g + n_c + 1
    rng = np.random.default_rng(seed)
    pattern = np.zeros((n_z, n_z), dtype=bool)
    # one array, zeroed between the evaluations: a fresh one each would fault its pages in
    # again (NumPy's zeros are allocated as they are written)
    jac = np.zeros((n_z, n_z))
    load = np.array(PATTERN_LOAD)
    for k in range(2):
        z = np.concatenate([rng.uniform(-0.1, 0.1, n_q), rng.uniform(0.5, 1.0, n_g + n_c + 1)])
        if k:
            jac[:, :] = 0.0
        pattern |= assemble.evaluate_into(data, z, load, True, jac)[1] != 0.0
    i, j = np.nonzero(pattern)
    i, j = np.concatenate([i, j]), np.concatenate([j, i])  # symmetrised
    sparse = sp.csr_matrix((np.ones(i.size, dtype=np.int8), (i, j)), shape=(n_z, n_z))
    sparse = sparse.astype(bool)  # (duplicates summed)
    sparse.sort_indices()
    return sparse


def _border(pattern: sp.csr_matrix, degree_limit: int) -> np.ndarray:
    """The border: the unknown of most neighbours among the others, repeatedly, while that
    is above ``degree_limit`` (the top module's coordinates couple to every frame angle,
    and to little else once those are in the border)."""
    degree = np.diff(pattern.indptr) - pattern.diagonal().astype(int)
    border: list[int] = []
    while True:
        i = int(np.argmax(degree))
        if degree[i] <= degree_limit:
            return np.sort(np.array(border, dtype=np.int64))
        border.append(i)
        # the pattern is symmetric: column i's rows are row i's columns
        degree[pattern.indices[pattern.indptr[i] : pattern.indptr[i + 1]]] -= 1
        degree[i] = -1


def solve_cost(n: int, n_border: int, kl: int, ku: int) -> float:
    """Flops of one bordered banded solve of n unknowns, ``n_border`` of them in the border
    (banded LU, k + 1 banded solves, the Schur complement and its dense LU)."""
    m, k = n - n_border, n_border
    return 2.0 * (m * kl * (kl + ku) + (k + 1) * m * (2 * kl + ku) + k * (k + 1) * m + k**3 / 3)


def _arrangement(pattern: sp.csr_matrix, degree_limit: int) -> tuple[np.ndarray, int, int, int]:
    """(order, n_inner, kl, ku) with the border of ``degree_limit``."""
    n_z = pattern.shape[0]
    border = _border(pattern, degree_limit)
    inner = np.setdiff1d(np.arange(n_z), border)
    sub = pattern[inner][:, inner]
    perm = inner[reverse_cuthill_mckee(sub, symmetric_mode=True)]
    band = pattern[perm][:, perm].tocoo()
    rows, cols = band.row, band.col
    kl = int(max((rows - cols).max(initial=0), 0))
    ku = int(max((cols - rows).max(initial=0), 0))
    return np.concatenate([perm, border]).astype(np.int64), inner.size, kl, ku


def solve_layout(
    data: SystemData, min_unknowns: int = MIN_UNKNOWNS, min_gain: float = MIN_GAIN
) -> tuple[np.ndarray, np.ndarray]:
    """(``solve_order`` (n_z,), ``solve_band`` (3,) = (n_inner, kl, ku)), int64, of the
    bordered banded solve (module docstring); two empty arrays where dense LU is used
    (``min_unknowns``, ``min_gain``: :data:`MIN_UNKNOWNS`, :data:`MIN_GAIN`)."""
    n_q, n_g, n_c = (int(v) for v in data.sizes)
    n_z = n_q + n_g + n_c + 1
    none = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    if n_z < min_unknowns or os.environ.get(SOLVE_ENV, "").lower() == "dense":
        return none
    pattern = jacobian_pattern(data)
    best = min(
        (_arrangement(pattern, limit) for limit in DEGREE_LIMITS),
        key=lambda a: solve_cost(n_z, n_z - a[1], a[2], a[3]),
    )
    order, n_inner, kl, ku = best
    if solve_cost(n_z, n_z - n_inner, kl, ku) * min_gain > 2.0 * n_z**3 / 3.0:
        return none
    return order, np.array([n_inner, kl, ku], dtype=np.int64)
