"""Observation of equilibrium states on the compiled system (Numba; MODEL §9, §12).

For packed states
z = [q, λ, λ_∂, μ] and their loads (F [N], U [mm], d), with the tube's layout as data
(:class:`~biplan.model.system.SystemData`), it computes what a path or trajectory records per
step:

* the end force F [N] (the applied one, or the reaction −μ under displacement control), the
  load-point displacement z_p [mm] and the endpoint u_z, u_r [mm], θ [rad] (MODEL §9, R2);
* the strain energy of every fold [N·mm] (helical folds, then circular ones) and the fraction
  of each fold's length on the closed, spinodal and open branch of its law (length-weighted
  over a connector's fields, as :func:`biplan.model.potential.phase_fractions`);
* the stability test of MODEL §12 (main "Equilibrium Stability"): the smallest eigenvalue
  λ_min [N/mm] of the reduced Hessian H_r = Nᵀ K N, K = ∇²_q L, N an orthonormal basis of the
  null space of the active constraint rows, and dim N. The active set is that of
  :mod:`biplan.analysis.stability`: every guide, the contacts with gap w_∂ < 1e-4 mm and
  λ_∂ > 1e-6 N (every closed contact under the S1 reading ``weak_contacts_active``), and the
  end constraint under displacement control;
* the count of active contacts, the largest guide violation max |g| [mm] and the penetration
  max(−w_∂, 0) [mm].

K and the constraint rows are read off the state's KKT Jacobian (its top-left block K, its
top-right columns Gᵀ, −Cᵀ and d·a). With A (active rows) = U Σ Vᵀ, the rows of Vᵀ past the
numerical rank (singular values ≤ 1e-9 σ_max) span the null space N; H_r is formed on them
and its smallest eigenvalue taken (``numpy.linalg.eigvalsh``). The tests compare it with the
JAX oracle (``tests/jax_oracle/observe.py``), which shifts the complement above every
eigenvalue of H_r instead.
λ_min = +∞ when no direction is left (dim N = 0: a contact-locked state).

:func:`observe_state` observes one state from its Jacobian (what a Newton solve ends with),
:func:`observe_rows` a block of a batch, assembling each Jacobian (the blocks run in
parallel, :mod:`biplan.solvers.lanes`); :func:`observe` is the Python entry point that
returns an :class:`Observation` of NumPy arrays.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from biplan._compile.numba_cache import kernel, kernel_array
from biplan.model.system import assemble, chainterm, endpoint
from biplan.model.system.tables import SystemData
from biplan.solvers import lanes
from biplan.solvers.fractions import branch_fractions

__all__ = [
    "ACTIVE_GAP",
    "ACTIVE_MULTIPLIER",
    "PARALLEL_MIN_STATES",
    "RANK_RTOL",
    "STABILITY_TOL",
    "Observation",
    "min_reduced_eigenvalue",
    "observe",
    "observe_rows",
    "observe_state",
    "right_singular",
]

#: A contact is active when its multiplier exceeds this [N] and its gap is below ACTIVE_GAP [mm].
ACTIVE_MULTIPLIER = 1e-6
ACTIVE_GAP = 1e-4
#: Relative SVD rank tolerance of the active-constraint Jacobian.
RANK_RTOL = 1e-9
#: λ_min(H_r) above this is stable, below −STABILITY_TOL unstable, critical in between.
STABILITY_TOL = 1e-8
#: :func:`observe` gives a thread to every this many states (:mod:`biplan.solvers.lanes`).
PARALLEL_MIN_STATES = 8


class Observation(NamedTuple):
    """Observables of a batch of states (leading axis: state)."""

    force: np.ndarray  # [N]
    displacement: np.ndarray  # load-point z_p [mm]
    u_z: np.ndarray
    u_r: np.ndarray
    theta: np.ndarray
    energy: np.ndarray  # Π [N·mm]
    fold_energy: np.ndarray  # (n_folds,) helical then circular [N·mm]
    phase_fraction: np.ndarray  # (n_folds, 3): closed, spinodal, open
    min_eigenvalue: np.ndarray  # +inf when contact-locked
    dof: np.ndarray  # dimension of the admissible perturbation space
    n_active_contacts: np.ndarray
    constraint_residual: np.ndarray  # max |g| [mm]
    penetration: np.ndarray  # max(−w_∂, 0) [mm]: how far a contact closes past flat


@kernel
def min_reduced_eigenvalue(k: np.ndarray, a: np.ndarray, active: np.ndarray) -> tuple[float, int]:
    """(λ_min(Nᵀ K N) [N/mm], dim N) for N the null space of the active rows of ``a``.

    Parameters
    ----------
    k : ndarray (n, n)
        Lagrangian Hessian K = ∇²_q L [N/mm] (symmetrised here).
    a : ndarray (m, n)
        Constraint Jacobian, all candidate rows (dimensionless).
    active : ndarray (m,) of bool
        Which rows are active.

    Returns
    -------
    tuple of (float, int)
        The smallest eigenvalue of the reduced Hessian (+∞ when dim N = 0) and dim N; NaN
        when the Hessian is not finite, and dim N = −1 when the active rows' SVD fails too
        (:func:`right_singular`).
    """
    n = k.shape[0]
    m = 0
    for i in range(active.shape[0]):
        if active[i]:
            m += 1
    rank = 0
    if m > 0:
        rows = np.empty((m, n))
        j = 0
        for i in range(active.shape[0]):
            if active[i]:
                rows[j] = a[i]
                j += 1
        s, vt = right_singular(rows)
        if not (np.all(np.isfinite(s)) and np.all(np.isfinite(vt))):
            return math.nan, -1
        top = max(s.max(), 1e-300)
        for v in s:
            if v > RANK_RTOL * top:
                rank += 1
    else:
        vt = np.eye(n)
    dof = n - rank
    if dof == 0:
        return math.inf, 0
    basis = np.ascontiguousarray(vt[rank:].T)  # (n, dof)
    sym = 0.5 * (k + k.T)
    reduced = basis.T @ (sym @ basis)
    reduced = 0.5 * (reduced + reduced.T)
    if not np.all(np.isfinite(reduced)):
        return math.nan, dof
    return np.linalg.eigvalsh(reduced)[0], dof


@kernel
def right_singular(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(σ, Vᵀ) of ``a`` (m, n): its singular values and right singular vectors (n, n).

    LAPACK's divide-and-conquer SVD (``gesdd``, behind ``numpy.linalg.svd``) can return NaN
    singular vectors for a finite rank-deficient matrix: seen on the 43 active constraint rows
    (rank 31) of a stable state of the ten-module fully bistable tube. Then the SVD of R, where
    a = Q R (Householder QR), is taken: it has the same singular values and right singular
    vectors. NaN results (a non-finite ``a``, or both SVDs failing) are the caller's to report.
    """
    m, n = a.shape
    if not np.all(np.isfinite(a)):
        return np.full(min(m, n), np.nan), np.full((n, n), np.nan)
    _, s, vt = np.linalg.svd(a, True)
    if np.all(np.isfinite(vt)):
        return s, vt
    _, r = np.linalg.qr(a)
    _, s, vt = np.linalg.svd(np.ascontiguousarray(r), True)
    return s, vt


@kernel(inline="always")
def _observation(
    d: SystemData,
    z: np.ndarray,
    load: np.ndarray,
    jac: np.ndarray,
    guides: np.ndarray,
    gaps: np.ndarray,
    e_hel: np.ndarray,
    e_circ: np.ndarray,
    zp: float,
    weak_contacts: bool,
) -> tuple:
    """:func:`observe_state` from the state's first-order terms (guides, gaps, energies, z_p);
    inlined into its callers (compiled on its own it would be optimised once more in each)."""
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    n_z = n_q + n_g + n_c + 1
    q = z[:n_q]
    control = load[2] > 0.5
    # active rows [G; C; d·a] (C = −(the contact columns)ᵀ) and the active set
    a = np.zeros((n_g + n_c + 1, n_q))
    active = np.zeros(n_g + n_c + 1, dtype=np.bool_)
    n_active = 0
    for i in range(n_q):
        for r in range(n_g):
            a[r, i] = jac[i, n_q + r]
        for r in range(n_c):
            a[n_g + r, i] = -jac[i, n_q + n_g + r]
        a[n_g + n_c, i] = jac[i, n_z - 1]
    for r in range(n_g):
        active[r] = True
    for r in range(n_c):
        closed = gaps[r] < ACTIVE_GAP
        on = closed if weak_contacts else closed and z[n_q + n_g + r] > ACTIVE_MULTIPLIER
        active[n_g + r] = on
        if on:
            n_active += 1
    active[n_g + n_c] = control
    lam_min, dof = min_reduced_eigenvalue(np.ascontiguousarray(jac[:n_q, :n_q]), a, active)
    # endpoint relative to q = 0
    u_z, u_r, theta = endpoint.endpoint(d, q)
    # energies and branch fractions, helical folds then circular
    fold_energy = np.empty(n + nc)
    fold_energy[:n] = e_hel
    fold_energy[n:] = e_circ
    fractions = branch_fractions(d, q, gaps)
    return (
        -z[n_z - 1] if control else load[0],
        zp,
        u_z,
        u_r,
        theta,
        e_hel.sum() + e_circ.sum(),
        fold_energy,
        fractions,
        lam_min,
        dof,
        n_active,
        np.abs(guides).max(),
        max(-gaps.min(), 0.0),
    )


@kernel
def observe_state(
    d: SystemData, z: np.ndarray, load: np.ndarray, jac: np.ndarray, weak_contacts: bool
) -> tuple:
    """The observables of one state z from its KKT Jacobian (module docstring).

    Parameters
    ----------
    d : SystemData
        The tube as arrays.
    z : ndarray (n_z,)
        Packed state [q, λ, λ_∂, μ].
    load : ndarray (3,)
        (F [N], U [mm], d): end force, prescribed displacement, 1.0 under displacement control.
    jac : ndarray (n_z, n_z)
        The KKT Jacobian ∂r/∂z at (z, load) (:func:`biplan.model.system.assemble.evaluate`).
    weak_contacts : bool
        Count closed contacts as active whatever their multiplier (S1).

    Returns
    -------
    tuple
        The fields of :class:`Observation`: force [N], displacement
        z_p [mm], u_z [mm], u_r [mm], θ [rad], energy [N·mm], fold energies (N + Nc,)
        [N·mm], phase fractions (N + Nc, 3), λ_min [N/mm] (+∞ when dim N = 0), dim N,
        active contacts, max |g| [mm], penetration [mm].
    """
    n_q, n_g, n_c = d.sizes[0], d.sizes[1], d.sizes[2]
    q = z[:n_q]
    t = assemble.terms(d, q, z[n_q : n_q + n_g], z[n_q + n_g : n_q + n_g + n_c], False)
    zp = chainterm.load_height(d, q) - d.load_reference[0]
    return _observation(d, z, load, jac, t[2], t[3], t[6], t[7], zp, weak_contacts)


@kernel(inline="always")
def _observe_one(d: SystemData, z: np.ndarray, load: np.ndarray, weak_contacts: bool) -> tuple:
    """:func:`observe_state` of z with its Jacobian assembled here."""
    _, jac, _, _, t = assemble.evaluate(d, z, load, True)
    zp = chainterm.load_height(d, z[: d.sizes[0]]) - d.load_reference[0]  # as observe_state
    return _observation(d, z, load, jac, t[2], t[3], t[6], t[7], zp, weak_contacts)


@kernel
def _allocate(k: int, n_f: int) -> tuple:
    """The output arrays of :func:`observe_rows` for k states of n_f folds."""
    return (
        np.empty(k),
        np.empty(k),
        np.empty(k),
        np.empty(k),
        np.empty(k),
        np.empty(k),
        np.empty((k, n_f)),
        np.empty((k, n_f, 3)),
        np.empty(k),
        np.empty(k, dtype=np.int64),
        np.empty(k, dtype=np.int64),
        np.empty(k),
        np.empty(k),
    )


@kernel
def _store(out: tuple, i: int, o: tuple) -> None:
    """Writes one state's observation ``o`` into row i of the outputs ``out``."""
    out[0][i], out[1][i], out[2][i], out[3][i], out[4][i] = o[0], o[1], o[2], o[3], o[4]
    out[5][i] = o[5]
    out[6][i] = o[6]
    out[7][i] = o[7]
    out[8][i], out[9][i], out[10][i], out[11][i], out[12][i] = o[8], o[9], o[10], o[11], o[12]


@kernel(nogil=True)
def observe_rows(
    d: SystemData,
    zs: np.ndarray,
    loads: np.ndarray,
    weak_contacts: bool,
    out: tuple,  # type: ignore[type-arg]
    lo: int,
    hi: int,
) -> None:
    """:func:`observe_state` of the states lo … hi − 1, each with its Jacobian assembled here,
    into rows lo:hi of ``out`` (:func:`_allocate`; a lane of :func:`biplan.solvers.lanes.run_rows`).

    Parameters
    ----------
    d : SystemData
        The tube as arrays.
    zs : ndarray (k, n_z)
        Packed states [q, λ, λ_∂, μ].
    loads : ndarray (k, 3)
        (F [N], U [mm], d) of each state.
    weak_contacts : bool
        Count closed contacts as active whatever their multiplier (S1).
    out : tuple
        The fields of :func:`observe_state` as arrays with leading axis k (fold energies
        (k, N + Nc) [N·mm], phase fractions (k, N + Nc, 3); dim N and the active contacts
        int64).
    lo, hi : int
        The rows to observe.
    """
    for i in range(lo, hi):
        _store(out, i, _observe_one(d, zs[i], loads[i], weak_contacts))


def observe(
    system_or_data: Any,
    zs: np.ndarray,
    loads: Any = None,
    weak_contacts: bool | None = None,
    parallel: bool | None = None,
) -> Any:
    """Observe states on the compiled system (module docstring).

    Parameters
    ----------
    system_or_data : Model, System or SystemData
        The tube: a :class:`~biplan.Model` (its :meth:`~biplan.Model.system`), its System or
        the System's data; a System's own load is ignored.
    zs : array_like (k, n_z) or (n_z,)
        Packed states [q, λ, λ_∂, μ].
    loads : array_like (k, 3) or (3,), or Load, optional
        (F [N], U [mm], d) of each state, or one load for all; a
        :class:`~biplan.model.params.Load` of scalars or (k,) arrays is accepted too.
        ``None``: at rest, (0, 0, 0).
    weak_contacts : bool, optional
        Count closed contacts as active whatever their multiplier (S1
        ``weak_contacts_active``). Default: a Model's own option; for a System or SystemData,
        which do not carry it, ``False`` (the default reading).
    parallel : bool, optional
        Observe blocks of states on :func:`~biplan.solvers.lanes.thread_count` threads
        (:mod:`biplan.solvers.lanes`) or all in the calling thread; default: a thread per
        :data:`PARALLEL_MIN_STATES` states, up to that count.

    Returns
    -------
    Observation
        :class:`Observation` of NumPy arrays with leading axis k.
    """
    source = system_or_data
    zs = np.ascontiguousarray(np.atleast_2d(np.asarray(zs, dtype=float)))
    k = zs.shape[0]
    if k == 0:
        raise ValueError("no states to observe")
    if loads is None:
        table = np.zeros((k, 3))
    elif isinstance(loads, tuple):  # a Load of scalars or (k,) arrays
        table = np.stack([np.broadcast_to(np.asarray(v, float), (k,)) for v in loads], axis=1)
    else:
        table = np.broadcast_to(np.asarray(loads, dtype=float), (k, 3))
    table = kernel_array(table, float)  # (a broadcast row is read-only)
    if hasattr(source, "layout") and callable(getattr(source, "system", None)):  # a Model
        model = source
        if weak_contacts is None:
            weak_contacts = model.options.weak_contacts_active
        source = model.system()
    d: SystemData = getattr(source, "data", source)
    finite = np.all(np.isfinite(zs), axis=1) & np.all(np.isfinite(table), axis=1)
    if not finite.all():  # NaN rows of a failed solve: NaN observables, the others as usual
        out = _missing(k, d.ref.shape[0] + d.conn_upper.shape[0])
        if finite.any():
            part = observe(d, zs[finite], table[finite], bool(weak_contacts), parallel)
            for field, v in zip(out, part, strict=True):
                field[finite] = v
        return out
    fields = _allocate(k, d.ref.shape[0] + d.conn_upper.shape[0])
    threads = 1 if parallel is False else None
    rows = 1 if parallel else PARALLEL_MIN_STATES
    lanes.run_rows(
        observe_rows, k, d, zs, table, bool(weak_contacts), fields, threads=threads, min_rows=rows
    )
    return Observation(*fields)


def _missing(k: int, n_folds: int) -> Observation:
    """An :class:`Observation` of k states with NaN everywhere (0 for the counts)."""
    nan = np.full(k, np.nan)
    return Observation(
        nan.copy(), nan.copy(), nan.copy(), nan.copy(), nan.copy(), nan.copy(),
        np.full((k, n_folds), np.nan), np.full((k, n_folds, 3), np.nan), nan.copy(),
        np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64), nan.copy(), nan.copy(),
    )  # fmt: skip
