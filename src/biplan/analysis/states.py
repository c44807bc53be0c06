"""Enumeration of the stable states of a multistable MFT (SI "state transition diagram", MODEL §15).

:func:`enumerate_states` seeds every combination of closed/open bistable folds (2ⁿ seeds for n
bistable folds; 128 for the four-module fully bistable tube), relaxes all of them in one batched
(``vmap``) computation (:mod:`biplan.solvers._relaxkernel`: a kinematic seed toward the target
fold openings, a modified-Newton descent of the energy at zero end load with the base clamped,
and the exact KKT solve), classifies each fold by the phase that occupies the greater part of
its length, keeps the equilibria whose reduced Hessian is positive definite and removes
duplicates by coordinates. Equilibria with the same bits but different coordinates stay
distinct states.

Every seed's outcome is kept (:class:`SeedOutcome`): the state it reached, whether its bits
are the seed's own, or why it was rejected (unstable equilibrium with its eigenvalue, failed
solve). Nothing is merged silently.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan._errors import ConfigError, ConvergenceError, check_integer, check_range
from biplan._jax import jnp
from biplan.analysis.labels import bistable_folds, bits_to_label, label_to_bits
from biplan.analysis.stability import Verdict, classify
from biplan.assembly import Load, Model, phase_fractions
from biplan.geometry import FoldRef
from biplan.solvers._relaxkernel import relax_seed
from biplan.solvers.newton import Newton, Solution, Status, solve_equilibrium
from biplan.solvers.observe import STABILITY_TOL, observe_batch

if TYPE_CHECKING:
    from biplan.analysis.catalogue import StateCatalogue

__all__ = [
    "Enumeration",
    "SeedOutcome",
    "StableState",
    "enumerate_states",
    "fold_vector_index",
    "relax_state",
    "state_bits",
]

#: Largest number of bistable folds enumerated exhaustively (2¹⁸ seeds).
MAX_FOLDS = 18


@dataclass(frozen=True)
class Enumeration:
    """Settings of the seeded relaxation.

    Parameters
    ----------
    penalty_stiffness : float
        k_p [N/mm] of the guide and contact penalties of the descent (the final KKT solve is
        exact; k_p only sets how close the descent lands).
    max_iterations : int
        Most modified-Newton descent iterations per seed.
    newton : Newton
        Settings of the final KKT Newton solve (atol is the equilibrium tolerance).
    chunk : int
        Seeds per batched call (fixed shape: one compilation for every chunk). The batched
        while-loops run in lock-step, so a chunk costs its slowest seed: 16 enumerates the
        four-module tube in 1.45 s warm against 2.96 s for one chunk of 128 (8 is no faster;
        ``docs/performance.md``).
    duplicate_tolerance : float
        Two equilibria are the same state when max |Δq| is below this [mm, rad].
    stability_tolerance : float
        λ_min of the reduced Hessian above this [N/mm] is stable.
    """

    penalty_stiffness: float = 1e4
    max_iterations: int = 300
    newton: Newton = field(default_factory=Newton)
    chunk: int = 16
    duplicate_tolerance: float = 1e-5
    stability_tolerance: float = STABILITY_TOL

    def __post_init__(self) -> None:
        check_range("Enumeration.penalty_stiffness", self.penalty_stiffness, low=0.0)
        check_range("Enumeration.duplicate_tolerance", self.duplicate_tolerance, low=0.0)
        check_range("Enumeration.stability_tolerance", self.stability_tolerance, low=0.0)
        for name in ("max_iterations", "chunk"):
            v = check_integer(f"Enumeration.{name}", getattr(self, name), low=1)
            object.__setattr__(self, name, v)


@dataclass(frozen=True)
class StableState:
    """A distinct stable equilibrium at zero end load.

    ``bits`` are the fold states (free end first, :func:`~biplan.analysis.labels.bistable_folds`),
    ``name`` is the label, made unique with a suffix (``1B.2``) when two distinct states share
    bits. Lengths in mm, θ in rad, energy in N·mm, eigenvalue in N/mm.
    """

    name: str
    label: str
    bits: tuple[int, ...]
    q: np.ndarray
    z: np.ndarray
    energy: float
    u_z: float
    u_r: float
    theta: float
    min_eigenvalue: float
    phase_fraction: np.ndarray  # (N + Nc, 3): closed, spinodal, open
    seeds: tuple[str, ...]


@dataclass(frozen=True)
class SeedOutcome:
    """What one seed relaxed to.

    ``outcome`` is ``"stable"`` (``state`` names the state), ``"unstable"`` (an equilibrium
    with λ_min ≤ tolerance), or ``"failed"`` (no converged equilibrium; ``message`` says why).
    """

    seed: str
    seed_bits: tuple[int, ...]
    reached_bits: tuple[int, ...]
    outcome: str
    state: str | None
    min_eigenvalue: float
    residual: float
    message: str

    @property
    def matches_seed(self) -> bool:
        """Whether the equilibrium has the seed's own fold states."""
        return self.reached_bits == self.seed_bits


def fold_vector_index(model: Model, fold: FoldRef) -> int:
    """Index of a fold in the (helical, then circular) fold vectors of the kernels."""
    return fold.index if fold.set == "helical" else model.tube.n_modules + fold.index


def _seed_targets(
    model: Model, folds: tuple[FoldRef, ...], seeds: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(seeds, target openings, mask): every 2ⁿ bit combination unless ``seeds`` are given."""
    tube = model.tube
    laws = list(tube.helical_laws) + list(tube.circular_laws)
    if seeds is None:
        seeds = np.array(list(itertools.product((0, 1), repeat=len(folds))), dtype=int)
    target = np.zeros((len(seeds), len(laws)))
    mask = np.zeros(len(laws))
    for bit, fold in enumerate(folds):
        i = fold_vector_index(model, fold)
        wells = laws[i].wells()
        target[:, i] = np.where(seeds[:, bit] == 1, wells[-1], wells[0])
        mask[i] = 1.0
    return seeds, target, np.broadcast_to(mask, target.shape).copy()


def relax_seeds(
    model: Model,
    target: np.ndarray,
    mask: np.ndarray,
    settings: Enumeration,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Batched relaxation of seeds (rows of ``target``/``mask``): (z, status, residual).

    Seeds go through the compiled kernel in fixed chunks of ``settings.chunk`` (the last one
    padded), so every chunk reuses one compilation; ``progress(done, total)`` is called after
    each chunk.
    """
    fn = relax_seed.compiled(model.layout)
    stiffness = jnp.asarray(float(settings.penalty_stiffness))
    iterations = jnp.asarray(settings.max_iterations)
    newton = settings.newton.settings()
    k, chunk = len(target), settings.chunk
    zs, status, residual = [], [], []
    for lo in range(0, k, chunk):
        hi = min(lo + chunk, k)
        pad = chunk - (hi - lo)
        t = np.concatenate([target[lo:hi], np.repeat(target[hi - 1 : hi], pad, axis=0)])
        m = np.concatenate([mask[lo:hi], np.repeat(mask[hi - 1 : hi], pad, axis=0)])
        out = fn(model.params, jnp.asarray(t), jnp.asarray(m), stiffness, iterations, newton)
        zs.append(np.asarray(out.z)[: hi - lo])
        status.append(np.asarray(out.status)[: hi - lo])
        residual.append(np.asarray(out.residual)[: hi - lo])
        if progress is not None:
            progress(hi, k)
    return np.concatenate(zs), np.concatenate(status), np.concatenate(residual)


def state_bits(model: Model, q: np.ndarray) -> tuple[int, ...]:
    """Fold-state bits of coordinates ``q`` (free end first,
    :func:`~biplan.analysis.labels.bistable_folds`): 1 where the open branch occupies more of
    the fold's length than the closed one (SI, "Construction of a state transition diagram")."""
    frac = np.asarray(phase_fractions(model.layout, model.params, jnp.asarray(q)))
    index = [fold_vector_index(model, f) for f in bistable_folds(model.tube)]
    return tuple(int(frac[i, 2] > frac[i, 0]) for i in index)


def relax_state(
    model: Model, label: str, settings: Enumeration | None = None, *, atol: float = 1e-12
) -> Solution:
    """The stable state ``label`` at zero end load, relaxed from its own seed.

    The seed with the label's bits goes through the enumeration's relaxation
    (:func:`relax_seeds`, the same compiled kernel), then Newton polishes it to ‖r‖∞ < ``atol``.

    Parameters
    ----------
    model : Model
        A tube with bistable folds.
    label : str
        Hexadecimal state label (:mod:`biplan.analysis.labels`), e.g. ``"1B"``.
    settings : Enumeration, optional
    atol : float
        Residual tolerance of the returned equilibrium [N, mm].

    Returns
    -------
    Solution
        Converged, stable, with the label's bits.

    Raises
    ------
    ConfigError
        A tube without bistable folds, or a label that is not one of its states' labels.
    ConvergenceError
        The seed's relaxation failed, or reached an unstable equilibrium or other fold states.
    """
    settings = settings or Enumeration()
    folds = bistable_folds(model.tube)
    if not folds:
        raise ConfigError("model", model.tube.name, "a tube with at least one bistable fold law")
    bits = label_to_bits(label, len(folds))
    _, target, mask = _seed_targets(model, folds, np.array([bits], dtype=int))
    z, status, _ = relax_seeds(model, target, mask, settings)
    if int(status[0]) != Status.CONVERGED.value or not np.all(np.isfinite(z[0])):
        raise ConvergenceError(f"state {label}: the relaxation of its seed did not converge")
    sol = solve_equilibrium(model, replace(settings.newton, atol=atol), z[0], Load.of_force(0.0))
    if not sol.converged:
        raise ConvergenceError(f"state {label}: Newton from the relaxed seed: {sol.message}")
    reached = state_bits(model, sol.q)
    if reached != bits:
        raise ConvergenceError(
            f"state {label}: its seed relaxed to {bits_to_label(reached)} (not stable as {label})"
        )
    verdict = classify(model, sol).verdict
    if verdict is not Verdict.STABLE:
        raise ConvergenceError(f"state {label}: its equilibrium is {verdict.value}, not stable")
    return sol


def enumerate_states(
    model: Model,
    settings: Enumeration | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> StateCatalogue:
    """All stable states reached from the 2ⁿ binary fold-state seeds (SI Sec. transitions).

    Parameters
    ----------
    model : Model
        A tube with at least one bistable fold.
    settings : Enumeration, optional
    progress : callable, optional
        Called as ``progress(done, total)`` after every chunk of seeds.

    Returns
    -------
    StateCatalogue
    """
    from biplan.analysis.catalogue import StateCatalogue

    settings = settings or Enumeration()
    folds = bistable_folds(model.tube)
    if not folds:
        raise ConfigError("model", model.tube.name, "a tube with at least one bistable fold law")
    if len(folds) > MAX_FOLDS:
        raise ConfigError("model", f"{len(folds)} bistable folds", f"at most {MAX_FOLDS}")
    start = time.perf_counter()
    seeds, target, mask = _seed_targets(model, folds)
    z, status, residual = relax_seeds(model, target, mask, settings, progress)
    n = len(z)
    zeros = np.zeros(n)
    obs = observe_batch(model.layout, model.params, z, Load(zeros, zeros, zeros))
    fold_index = [fold_vector_index(model, f) for f in folds]
    frac = obs.phase_fraction[:, fold_index, :]
    reached = (frac[:, :, 2] > frac[:, :, 0]).astype(int)
    converged = (status == Status.CONVERGED.value) & np.isfinite(residual)
    converged &= np.all(np.isfinite(z), axis=1)
    nq = model.layout.n_coordinates
    tol = settings.stability_tolerance

    states: list[dict] = []
    unstable: list[np.ndarray] = []
    unstable_eigs: list[float] = []
    outcomes: list[SeedOutcome] = []
    for i in range(n):
        seed_bits = tuple(int(b) for b in seeds[i])
        bits = tuple(int(b) for b in reached[i])
        eig = float(obs.min_eigenvalue[i])
        common: dict[str, Any] = {
            "seed": bits_to_label(seed_bits),
            "seed_bits": seed_bits,
            "reached_bits": bits,
            "min_eigenvalue": eig,
            "residual": float(residual[i]),
        }
        if not converged[i]:
            message = Status(int(status[i])).message if int(status[i]) in (0, 1, 2, 3) else ""
            outcomes.append(SeedOutcome(**common, outcome="failed", state=None, message=message))
            continue
        if not eig > tol:
            if not any(
                np.max(np.abs(z[i, :nq] - u[:nq])) < settings.duplicate_tolerance for u in unstable
            ):
                unstable.append(z[i])
                unstable_eigs.append(eig)
            outcomes.append(
                SeedOutcome(
                    **common,
                    outcome="unstable",
                    state=None,
                    message=f"equilibrium with λ_min = {eig:.3g} N/mm ≤ {tol:g}",
                )
            )
            continue
        match = next(
            (
                j
                for j, s in enumerate(states)
                if np.max(np.abs(s["z"][:nq] - z[i, :nq])) < settings.duplicate_tolerance
            ),
            None,
        )
        if match is None:
            states.append({"z": z[i], "i": i, "bits": bits, "seeds": []})
            match = len(states) - 1
        states[match]["seeds"].append(common["seed"])
        outcomes.append(SeedOutcome(**common, outcome="stable", state=str(match), message=""))

    built: list[StableState] = []
    seen: dict[str, int] = {}
    for s in states:
        i = s["i"]
        label = bits_to_label(s["bits"])
        seen[label] = seen.get(label, 0) + 1
        name = label if seen[label] == 1 else f"{label}.{seen[label]}"
        built.append(
            StableState(
                name=name,
                label=label,
                bits=s["bits"],
                q=z[i, :nq].copy(),
                z=z[i].copy(),
                energy=float(obs.energy[i]),
                u_z=float(obs.u_z[i]),
                u_r=float(obs.u_r[i]),
                theta=float(obs.theta[i]),
                min_eigenvalue=float(obs.min_eigenvalue[i]),
                phase_fraction=obs.phase_fraction[i].copy(),
                seeds=tuple(s["seeds"]),
            )
        )
    names = [b.name for b in built]
    outcomes = [
        o if o.state is None else SeedOutcome(**{**o.__dict__, "state": names[int(o.state)]})
        for o in outcomes
    ]
    return StateCatalogue(
        model=model,
        folds=folds,
        states=tuple(built),
        seeds=tuple(outcomes),
        unstable_z=np.asarray(unstable).reshape(-1, z.shape[1]),
        unstable_eigenvalues=np.asarray(unstable_eigs, dtype=float),
        settings=settings,
        elapsed=time.perf_counter() - start,
    )
