"""Events of an equilibrium path: where the stability of its states changes, located.

:func:`biplan.solvers.continuation.trace_path` observes its recorded states
(:func:`observe_states`); where the smallest reduced-Hessian eigenvalue changes sign between two
of them (:func:`sign_changes`), :func:`locate` brackets the crossing by repeated multisection
on the secant between them (:data:`MULTISECTION_POINTS` interior points a round, corrected onto
the path in parallel by :func:`biplan.solvers.path_loop.correct_rows`), and :func:`insert`
puts the located states into the path's arrays.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from biplan.model.assembly import Model
from biplan.solvers import lanes, observation, path_loop
from biplan.solvers.observation import STABILITY_TOL, Observation

__all__ = ["MULTISECTION_POINTS", "Corrector", "insert", "locate", "observe_states", "sign_changes"]

#: Interior points of a multisection round of the event location (corrected in parallel).
MULTISECTION_POINTS = 16


class Corrector(Protocol):
    """The corrector settings the location reads (a path method: ``ArcLength``,
    ``LoadStepping``)."""

    @property
    def atol(self) -> float: ...

    @property
    def max_iterations(self) -> int: ...

    @property
    def event_tolerance(self) -> float: ...


def observe_states(
    model: Model, z: np.ndarray, ctl: np.ndarray, load_parameter: np.ndarray
) -> Observation:
    """The observation of path states z (k, n_z) at Λ (k,) (:mod:`biplan.solvers.observation`)."""
    lam = np.asarray(load_parameter, dtype=float)
    loads = np.stack([ctl[0] * lam, ctl[1] * lam, np.full_like(lam, ctl[2])], axis=1)
    return observation.observe(model, z, loads)


def sign_changes(lam_min: np.ndarray) -> list[int]:
    """Indices i where λ_min changes sign from state i to i + 1 (|λ_min| < STABILITY_TOL
    counts as zero, a non-finite one, contact-locked, as positive)."""
    s = np.where(
        np.isfinite(lam_min), np.sign(np.where(np.abs(lam_min) < STABILITY_TOL, 0, lam_min)), 1
    )
    return [i for i in range(len(s) - 1) if s[i] * s[i + 1] < 0]


def locate(
    model: Model,
    ctl: np.ndarray,
    za: np.ndarray,
    la: float,
    zb: np.ndarray,
    lb: float,
    obs: object,
    i: int,
    method: Corrector,
    weight: float,
) -> tuple[np.ndarray, float, float] | None:
    """Locate the sign change of λ_min between two path states by multisection on the
    secant hyperplanes between them.

    Returns the end of the final bracket on the start's side of the change (its coordinates
    and Λ: the last stable state before a loss of stability) and the location's tolerance in
    Λ: the bracket's width along the secant times the secant's change of Λ (the corrected
    Λ need not be monotone in the bracket near a kink of a trilinear law, so the Λ of the
    far end is no bound), or None."""
    nq = model.n_coordinates
    f_a = float(np.asarray(obs.min_eigenvalue)[i])  # type: ignore[attr-defined]
    lo, hi = 0.0, 1.0
    best: tuple[np.ndarray, float, float] | None = None
    for _ in range(12):
        alpha = np.linspace(lo, hi, MULTISECTION_POINTS + 2)[1:-1]
        dz, dl = zb - za, lb - la
        row_z = np.zeros_like(za)
        row_z[:nq] = dz[:nq]
        row_l = weight**2 * dl
        zp = za[None, :] + alpha[:, None] * dz[None, :]
        lp = la + alpha * dl
        rho = zp @ row_z + row_l * lp
        zc, lc, ok = _correct(model, ctl, zp, lp, row_z, row_l, rho, method)
        if not ok.any():
            return best
        zc, lc = zc[ok], lc[ok]
        o = observe_states(model, zc, ctl, lc)
        a_ok = alpha[ok]
        same = np.sign(o.min_eigenvalue) == np.sign(f_a)
        # bracket: last point with the start's sign, first with the other
        k = int(np.argmin(same)) if not same.all() else len(same)
        new_lo = a_ok[k - 1] if k > 0 else lo
        new_hi = a_ok[k] if k < len(same) else hi
        width = float((new_hi - new_lo) * abs(lb - la))
        # the bracket's end on the start's side (a loss of stability keeps a stable state)
        if k > 0:
            best = (zc[k - 1], float(lc[k - 1]), width)
        elif best is None:
            best = (zc[0], float(lc[0]), width)
        else:
            best = (best[0], best[1], width)
        lo, hi = new_lo, new_hi
        if hi - lo < method.event_tolerance:
            break
    return best


def _correct(
    model: Model,
    ctl: np.ndarray,
    zp: np.ndarray,
    lp: np.ndarray,
    row_z: np.ndarray,
    row_l: float,
    rho: np.ndarray,
    method: Corrector,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Correct predictors (zp, Λp) onto the path on the hyperplanes (row_z, row_l)·x = ρ:
    (z, Λ, converged) of each."""
    zp = np.ascontiguousarray(zp, dtype=float)
    k = zp.shape[0]
    z, lam, ok = np.zeros_like(zp), np.zeros(k), np.zeros(k, dtype=np.bool_)
    lanes.run_rows(
        path_loop.correct_rows,
        k,
        model.system().data,
        zp,
        np.asarray(lp, dtype=float),
        np.asarray(ctl, dtype=float),
        np.append(row_z, row_l),
        np.asarray(rho, dtype=float),
        method.atol,
        method.max_iterations,
        z,
        lam,
        ok,
    )
    return z, lam, ok


def insert(
    z: np.ndarray,
    load_parameter: np.ndarray,
    tang: np.ndarray,
    steps: np.ndarray,
    its: np.ndarray,
    inserted: list[tuple[int, np.ndarray, float]],
) -> tuple[np.ndarray, ...]:
    """The path's arrays with each located state (i, z, Λ) inserted after state i, and the
    flags of the inserted rows."""
    zs, ls, ts, ss, ii, fl = [], [], [], [], [], []
    at = {i: (zi, li) for i, zi, li in inserted}
    for k in range(len(load_parameter)):
        zs.append(z[k])
        ls.append(load_parameter[k])
        ts.append(tang[k])
        ss.append(steps[k])
        ii.append(its[k])
        fl.append(False)
        if k in at:
            zs.append(at[k][0])
            ls.append(at[k][1])
            ts.append(0.5 * (tang[k] + tang[k + 1]))
            ss.append(0.0)
            ii.append(0)
            fl.append(True)
    return (
        np.asarray(zs),
        np.asarray(ls),
        np.asarray(ts),
        np.asarray(ss),
        np.asarray(ii),
        np.asarray(fl, bool),
    )
