"""Stability of a constrained equilibrium by the reduced Hessian (main "Equilibrium Stability";
MODEL.md §12).

At a converged state the active set is the guides, the contacts that carry load (λ_∂ > 1e-6
with w_∂ < 1e-4; MODEL CHOICE S1 treats weakly active ones, λ_∂ ≈ 0, as inactive unless
``ModelOptions.weak_contacts_active``) and, under displacement control, the prescribed end
displacement. With A their Jacobian and N an orthonormal basis of its null space (SVD, rank
tolerance 1e-9 σ_max)::

    H_r = Nᵀ K N,     K = ∇²_q L  (Lagrangian Hessian incl. multiplier curvature, CHOICE S2)

The state is stable when λ_min(H_r) > tol, unstable when < −tol, critical otherwise. A state
with an empty null space (contact-locked) is stable.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from biplan._errors import ConfigError
from biplan.model.assembly import Model
from biplan.solvers.newton import Solution

__all__ = [
    "ACTIVE_GAP",
    "ACTIVE_MULTIPLIER",
    "Stability",
    "Verdict",
    "active_constraint_jacobian",
    "classify",
    "null_space",
    "reduced_hessian",
]

#: A contact is active when its multiplier exceeds this [N] and its gap is below ACTIVE_GAP [mm].
ACTIVE_MULTIPLIER = 1e-6
ACTIVE_GAP = 1e-4


class Verdict(enum.Enum):
    """Stability verdict of an equilibrium."""

    STABLE = "stable"
    UNSTABLE = "unstable"
    CRITICAL = "critical"


@dataclass(frozen=True)
class Stability:
    """Result of :func:`classify`.

    Attributes
    ----------
    verdict : Verdict
    eigenvalues : ndarray
        Eigenvalues of H_r in ascending order (empty when contact-locked).
    min_eigenvalue : float
        Smallest eigenvalue (+inf when contact-locked).
    n_active_contacts : int
    dof : int
        Dimension of the admissible perturbation space (columns of N).
    """

    verdict: Verdict
    eigenvalues: np.ndarray
    min_eigenvalue: float
    n_active_contacts: int
    dof: int

    @property
    def stable(self) -> bool:
        return self.verdict is Verdict.STABLE


def _check(model: Model, solution: Solution) -> None:
    if not isinstance(solution, Solution):
        raise ConfigError("solution", type(solution).__name__, "a biplan Solution")
    if solution.z.shape != (model.n_unknowns,):
        raise ConfigError("solution", solution.z.shape, "a Solution of this model")


def active_contacts(model: Model, solution: Solution) -> np.ndarray:
    """Boolean mask of the active contact conditions (MODEL CHOICE S1)."""
    gaps = solution.data.gaps
    closed = gaps < ACTIVE_GAP
    if model.options.weak_contacts_active:
        return closed
    return closed & (solution.contact_multipliers > ACTIVE_MULTIPLIER)


def active_constraint_jacobian(model: Model, solution: Solution) -> np.ndarray:
    """A = ∂c_active/∂q: guides, active contacts and (displacement control) the end constraint."""
    _check(model, solution)
    jc = solution.data.constraint_jacobian
    ng = model.n_guides
    rows = [jc[:ng]]
    mask = active_contacts(model, solution)
    if mask.any():
        rows.append(jc[ng : ng + model.n_contacts][mask])
    if solution.load.is_displacement_controlled:
        rows.append(jc[-1:])
    return np.concatenate(rows, axis=0)


def null_space(a: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """Orthonormal basis (n, n − rank) of the null space of ``a`` by SVD (of R, a = Q R,
    when LAPACK's SVD returns NaN vectors: :func:`biplan.solvers.observation.right_singular`)."""
    n = a.shape[1]
    if a.shape[0] == 0:
        return np.eye(n)
    _, sigma, vt = np.linalg.svd(a)
    if np.all(np.isfinite(a)) and not np.all(np.isfinite(vt)):
        _, sigma, vt = np.linalg.svd(np.linalg.qr(a, mode="r"))
    rank = int(np.sum(sigma > rtol * max(sigma.max(initial=0.0), 1e-300)))
    return vt[rank:].T.copy()


def reduced_hessian(
    model: Model, solution: Solution, basis: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(H_r, N): the reduced Hessian and the null-space basis it was built on.

    Parameters
    ----------
    basis : ndarray, optional
        A basis of the null space to use instead of the SVD one (any basis gives the same
        verdict; an orthonormal one gives the same eigenvalues).
    """
    _check(model, solution)
    k = solution.data.lagrangian_hessian
    n = null_space(active_constraint_jacobian(model, solution)) if basis is None else basis
    h = n.T @ k @ n
    return 0.5 * (h + h.T), n


def classify(model: Model, solution: Solution, tol: float = 1e-8) -> Stability:
    """Stability verdict of a converged equilibrium (main "Equilibrium Stability").

    Raises
    ------
    ConfigError
        If ``solution`` did not converge (its stability is meaningless).
    """
    _check(model, solution)
    if not solution.converged:
        raise ConfigError("solution", solution.status.name, "a converged Solution")
    h, n = reduced_hessian(model, solution)
    n_active = int(active_contacts(model, solution).sum())
    if n.shape[1] == 0:
        return Stability(Verdict.STABLE, np.zeros(0), float("inf"), n_active, 0)
    eig = np.linalg.eigvalsh(h)
    lo = float(eig[0])
    verdict = Verdict.STABLE if lo > tol else Verdict.UNSTABLE if lo < -tol else Verdict.CRITICAL
    return Stability(verdict, eig, lo, n_active, n.shape[1])
