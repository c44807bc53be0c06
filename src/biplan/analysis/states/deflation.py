"""Deflation: equilibria that no binary fold-state seed reaches (Farrell, Birkisson & Funke 2015).

Given the known equilibria q_1 … q_m at zero end load, the KKT residual r(z) (MODEL §11,
contact by the smoothed Fischer–Burmeister function) is multiplied by the deflation operator::

    M(q) = Π_i ( 1 / ‖q − q_i‖^p + σ )

so that the known states are no longer roots of M r while every other root of r is. Newton on M
r is the package's Newton on the deflated residual: with d = −J⁻¹ r the undeflated Newton step
and η = log M, its step is d / (1 − ∇η · d_q) (Sherman–Morrison). It runs compiled on the
model's System at rest (:func:`biplan.solvers.deflated_loop.deflated_newton`, Numba). Each run
starts from a random perturbation of a known state (or from the midpoint of two), is damped by
backtracking on ½‖M r‖² (Levenberg–Marquardt where that fails), and stops when the *undeflated*
residual is below the tolerance. A new root joins the deflation set at once, so no root is found
twice. Every root is then classified by its reduced Hessian (MODEL §12) and described by the
phase fractions of its folds — a fold that is neither fully closed nor fully open is *partially
transformed*."""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from biplan._compile.numba_cache import kernel_array
from biplan._errors import ConfigError, check_integer, check_range
from biplan.analysis.stability import classify
from biplan.model.assembly import Load, Model
from biplan.model.system import System
from biplan.solvers import deflated_loop as compiled_loop
from biplan.solvers import observation
from biplan.solvers.iteration import newton_settings
from biplan.solvers.newton import make_solution
from biplan.solvers.status import Status

__all__ = ["Deflation", "DeflationResult", "Equilibrium", "deflate"]

Array = Any

#: Phase fraction above which a fold counts as fully on one branch.
WHOLE_FOLD = 0.999


@dataclass(frozen=True)
class Deflation:
    """Configured deflated Newton search.

    Parameters
    ----------
    power : float
        Exponent p of the deflation operator, ≥ 1.
    shift : float
        Shift σ ≥ 0 (σ > 0 keeps M bounded far from the known states).
    n_perturbations : int
        Random starts around every known state, ≥ 0.
    perturbation : float
        Standard deviation of the start perturbation of every coordinate [mm or rad], > 0.
    max_midpoints : int
        Starts at midpoints of pairs of known states (closest pairs first), ≥ 0.
    seed : int
        Seed of the random perturbations.
    tolerance : float
        Convergence when ‖r‖∞ of the undeflated system is below this, > 0.
    max_steps : int
        Newton steps per run, ≥ 1.
    distinct : float
        Roots closer than this in max-norm of q are the same [mm or rad], > 0.
    max_rotation : float
        Roots with an element rotation |φ| above this [rad] are kinematically inadmissible
        (elements folded through each other on a far branch of the guide equations): they are
        counted, not reported. In (0, π].
    """

    power: float = 2.0
    shift: float = 1.0
    n_perturbations: int = 8
    perturbation: float = 0.1
    max_midpoints: int = 64
    seed: int = 0
    tolerance: float = 1e-9
    max_steps: int = 50
    distinct: float = 1e-5
    max_rotation: float = np.pi / 4

    def __post_init__(self) -> None:
        check_range("Deflation.power", self.power, low=1.0, low_open=False)
        check_range("Deflation.shift", self.shift, low=0.0, low_open=False)
        for name in ("perturbation", "tolerance", "distinct"):
            check_range(f"Deflation.{name}", getattr(self, name), low=0.0)
        check_range(
            "Deflation.max_rotation", self.max_rotation, low=0.0, high=np.pi, high_open=False
        )
        for name, low in (("n_perturbations", 0), ("max_midpoints", 0), ("max_steps", 1)):
            v = check_integer(f"Deflation.{name}", getattr(self, name), low=low)
            object.__setattr__(self, name, v)
        if isinstance(self.seed, bool) or not isinstance(self.seed, numbers.Integral):
            raise ConfigError("Deflation.seed", self.seed, "an integer")
        object.__setattr__(self, "seed", int(self.seed))


@dataclass(frozen=True)
class Equilibrium:
    """A new equilibrium found by deflation (zero end load).

    Attributes
    ----------
    z : ndarray
        Packed state [q, λ, λ_∂, μ].
    q : ndarray
        Coordinates (n_q,).
    energy : float
        Π [N·mm].
    residual : float
        ‖r‖∞ of the undeflated KKT system.
    stable : bool
        Positive-definite reduced Hessian (λ_min > 1e-8).
    min_eigenvalue : float
        Smallest reduced-Hessian eigenvalue (+inf when contact-locked).
    n_negative : int
        Number of negative reduced-Hessian eigenvalues (saddle index).
    phase_fraction : ndarray (n_folds, 3)
        Closed, spinodal and open fraction of each fold's length.
    bits : tuple of int
        Majority phase of every fold, helical then circular (1 open, 0 closed).
    partial : tuple of int
        Indices of the partially transformed folds (neither fully closed nor fully open).
    start : str
        The start that reached it: ``"perturbation of k"`` or ``"midpoint of i, j"``.
    """

    z: np.ndarray = field(repr=False)
    q: np.ndarray = field(repr=False)
    energy: float
    residual: float
    stable: bool
    min_eigenvalue: float
    n_negative: int
    phase_fraction: np.ndarray = field(repr=False)
    bits: tuple[int, ...]
    partial: tuple[int, ...]
    start: str


@dataclass(frozen=True)
class DeflationResult:
    """Outcome of :func:`deflate`.

    Attributes
    ----------
    equilibria : tuple of Equilibrium
        The new equilibria, in the order found.
    n_new, n_stable : int
        How many new equilibria, and how many of them are stable.
    n_runs, n_converged : int
        Deflated Newton runs started, and how many reached a root.
    n_inadmissible : int
        Distinct roots rejected for an element rotation above ``max_rotation``.
    """

    equilibria: tuple[Equilibrium, ...]
    n_new: int
    n_stable: int
    n_runs: int
    n_converged: int
    n_inadmissible: int

    @property
    def stable(self) -> tuple[Equilibrium, ...]:
        return tuple(e for e in self.equilibria if e.stable)


#: Step halvings of the deflated line search.
BACKTRACKS = 8


def _deflated_newton(
    system: System, z0: np.ndarray, roots: list[np.ndarray], cfg: Deflation
) -> tuple[np.ndarray, float, bool]:
    """(z, ‖r‖∞ undeflated, converged) of one deflated Newton run from z0 on the System at
    rest (:func:`biplan.solvers.deflated_loop.deflated_newton`)."""
    settings = newton_settings(cfg.tolerance, cfg.max_steps, BACKTRACKS, 1e-4, 0)
    z, code, res, _ = compiled_loop.deflated_newton(
        system.data,
        kernel_array(z0, float),
        np.stack(roots),
        float(cfg.power),
        float(cfg.shift),
        settings,
    )
    res = float(res)
    return z, res, int(code) == Status.CONVERGED.value and res < cfg.tolerance


def _starts(model: Model, known: np.ndarray, cfg: Deflation) -> list[tuple[np.ndarray, str]]:
    rng = np.random.default_rng(cfg.seed)
    out: list[tuple[np.ndarray, str]] = []
    for k, qk in enumerate(known):
        for _ in range(cfg.n_perturbations):
            out.append(
                (qk + cfg.perturbation * rng.standard_normal(qk.shape), f"perturbation of {k}")
            )
    pairs = [
        (float(np.linalg.norm(known[i] - known[j])), i, j)
        for i in range(len(known))
        for j in range(i + 1, len(known))
    ]
    for _, i, j in sorted(pairs)[: cfg.max_midpoints]:
        out.append((0.5 * (known[i] + known[j]), f"midpoint of {i}, {j}"))
    return out


def deflate(
    model: Model, known_z: np.ndarray | list, deflation: Deflation | None = None
) -> DeflationResult:
    """Find equilibria at zero end load other than the known ones, by deflated Newton.

    Parameters
    ----------
    model : Model
    known_z : array_like (m, n_z) or (m, n_q)
        Known equilibria (packed states or coordinates), e.g. the enumerated stable states.
    deflation : Deflation, optional
        Defaults to ``Deflation()``.

    Returns
    -------
    DeflationResult
        The new equilibria (each with residual below ``deflation.tolerance``), classified.
    """
    cfg = Deflation() if deflation is None else deflation
    if not isinstance(cfg, Deflation):
        raise ConfigError("deflation", type(cfg).__name__, "a Deflation")
    nq = model.n_coordinates
    known = np.atleast_2d(np.asarray(known_z, dtype=float))
    if known.shape[1] not in (nq, model.n_unknowns) or not np.all(np.isfinite(known)):
        raise ConfigError("known_z", known.shape, f"(m, {nq}) or (m, {model.n_unknowns})")
    known = known[:, :nq]
    roots = [q.copy() for q in known]
    found: list[tuple[np.ndarray, float, str]] = []
    starts = _starts(model, known, cfg)
    n_conv = n_bad = 0
    n_mod = model.layout.n_modules
    rotations = np.concatenate([3 * np.arange(n_mod) + 1, 3 * np.arange(n_mod) + 2])
    system = model.system()
    for q0, label in starts:
        z, res, ok = _deflated_newton(system, model.pack(q0), roots, cfg)
        if not ok:
            continue
        n_conv += 1
        if any(np.max(np.abs(z[:nq] - r)) < cfg.distinct for r in roots):
            continue
        roots.append(z[:nq].copy())
        if np.max(np.abs(z[rotations])) > cfg.max_rotation:
            n_bad += 1
            continue
        found.append((z, res, label))
    equilibria = _classify(model, system, found) if found else ()
    return DeflationResult(
        equilibria=equilibria,
        n_new=len(equilibria),
        n_stable=sum(e.stable for e in equilibria),
        n_runs=len(starts),
        n_converged=n_conv,
        n_inadmissible=n_bad,
    )


def _classify(
    model: Model, system: System, found: list[tuple[np.ndarray, float, str]]
) -> tuple[Equilibrium, ...]:
    z = np.stack([f[0] for f in found])
    obs = observation.observe(model, z)
    out = []
    for k, (zk, res, label) in enumerate(found):
        sol = make_solution(
            model, zk, Load.of_force(0.0), Status.CONVERGED, res, 0, system.state(zk)
        )
        verdict = classify(model, sol)
        phase = np.asarray(obs.phase_fraction[k])
        bits = tuple(int(b) for b in phase[:, 2] > phase[:, 0])
        partial = tuple(int(i) for i in np.flatnonzero(phase.max(axis=1) < WHOLE_FOLD))
        out.append(
            Equilibrium(
                z=zk,
                q=zk[: model.n_coordinates].copy(),
                energy=float(sol.energy),
                residual=float(res),
                stable=verdict.stable,
                min_eigenvalue=float(verdict.min_eigenvalue),
                n_negative=int(np.sum(verdict.eigenvalues < -1e-8)),
                phase_fraction=phase,
                bits=bits,
                partial=partial,
                start=label,
            )
        )
    return tuple(out)
