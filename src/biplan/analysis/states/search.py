"""Enumeration of the stable states of a multistable MFT (SI "state transition diagram", MODEL §15).

:func:`enumerate_states` seeds combinations of closed/open bistable folds — all 2ⁿ of them
(:attr:`Search.EXHAUSTIVE`; 128 for the four-module fully bistable tube) or those reached by
single-fold changes from the all-closed one (:attr:`Search.NEIGHBOURHOOD`;
:mod:`biplan.analysis.states.seeding`) — relaxes them in parallel on the model's compiled system
(:mod:`biplan.solvers.relax_loop`: a kinematic seed toward the target fold openings, a
modified-Newton descent of the energy at zero end load with the base clamped, and the exact
KKT solve), classifies each fold by the phase that occupies the greater part of its length,
keeps the equilibria whose reduced Hessian is positive definite and merges duplicates: two
equilibria are one state when max |Δq| < ``Enumeration.duplicate_tolerance``
(:func:`~biplan.analysis.states.seeding.merge_rows`). Equilibria with the same bits but
different coordinates stay distinct states.

Every seed's outcome is kept (:class:`SeedOutcome`): the state it reached, whether its bits
are the seed's own, or why it was rejected (unstable equilibrium with its eigenvalue, failed
solve). Nothing is merged silently.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan._errors import ConfigError, ConvergenceError
from biplan.analysis.stability import Verdict, classify
from biplan.analysis.states import seeding
from biplan.analysis.states.catalogue import (
    Enumeration,
    Outcome,
    SeedOutcome,
    StableState,
    StateCatalogue,
)
from biplan.analysis.states.labels import (
    bistable_folds,
    bits_to_label,
    bits_to_labels,
    label_to_bits,
    require_bistable_folds,
)
from biplan.analysis.states.seeding import Search, fold_vector_index, relax_seeds, seed_targets
from biplan.model.assembly import Load, Model
from biplan.solvers import fractions
from biplan.solvers.newton import Solution, Status, solve_equilibrium

if TYPE_CHECKING:
    from biplan.analysis.maps.sweeps import ChunkSink
    from biplan.analysis.scaleout import Runner

__all__ = [
    "Search",
    "enumerate_states",
    "fold_vector_index",
    "relax_state",
    "state_bits",
]


def state_bits(model: Model, q: np.ndarray) -> tuple[int, ...]:
    """Fold-state bits of coordinates ``q`` (free end first,
    :func:`~biplan.analysis.states.labels.bistable_folds`): 1 where the open branch occupies more of
    the fold's length than the closed one (SI, "Construction of a state transition diagram")."""
    frac = fractions.phase_fractions(model.system().data, np.asarray(q, dtype=float))
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
        Hexadecimal state label (:mod:`biplan.analysis.states.labels`), e.g. ``"1B"``.
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
    folds = require_bistable_folds(model.tube)
    bits = label_to_bits(label, len(folds))
    target, mask = seed_targets(model, folds, np.array([bits], dtype=int))
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
    *,
    search: Search = Search.EXHAUSTIVE,
    sink: ChunkSink | None = None,
    confirm: bool = False,
    runner: Runner | None = None,
) -> StateCatalogue:
    """The stable states reached from fold-state seeds (SI Sec. transitions).

    Parameters
    ----------
    model : Model
        A tube with at least one bistable fold.
    settings : Enumeration, optional
    progress : callable, optional
        Called as ``progress(done, total)`` as seeds finish.
    search : Search
        All 2ⁿ seeds (default), or the neighbourhood search (:mod:`biplan.analysis.states.seeding`).
    sink : ChunkSink, optional
        Exhaustive search: finished chunks of seeds are saved to it, and chunks it already
        holds are loaded instead of relaxed (:class:`biplan.io.sweepstore.ChunkStore`: a run
        that was killed resumes).
    confirm : bool
        Run an exhaustive search of more than :data:`~biplan.analysis.states.seeding.CONFIRM_SEEDS`
        seeds (otherwise refused with a cost estimate, before any work).
    runner : Runner, optional
        Exhaustive search: where the chunks run (:mod:`biplan.analysis.scaleout`, e.g.
        ``dask_runner()`` for a local cluster or ``dask_runner("tcp://host:8786")``);
        default this process. The states are the same either way.

    Returns
    -------
    StateCatalogue
        ``seeds`` holds every seed tried, in seed order.
    """

    settings = settings or Enumeration()
    if not isinstance(search, Search):
        raise ConfigError("search", search, " or ".join(repr(s.value) for s in Search))
    folds = require_bistable_folds(model.tube)
    seeding.check_size(len(folds), model.tube.n_modules, search, confirm)
    start = time.perf_counter()
    if search is Search.EXHAUSTIVE:
        res = seeding.exhaustive(model, folds, settings, sink, progress, runner)
    else:
        res = seeding.neighbourhood(model, folds, settings, progress)
    z = res["z"]
    converged, stable = seeding.outcome_masks(res, settings.stability_tolerance)
    nq = model.layout.n_coordinates
    state_of = seeding.merge_rows(z[:, :nq], stable, settings.duplicate_tolerance)
    unstable_of = seeding.merge_rows(z[:, :nq], converged & ~stable, settings.duplicate_tolerance)
    reps = np.flatnonzero(state_of == np.arange(len(z)))
    reached_rows = [tuple(b) for b in np.asarray(res["reached"]).tolist()]
    labels = bits_to_labels(np.asarray(res["reached"])[reps]) if reps.size else []
    names = _names(labels)
    name_of = dict(zip(reps.tolist(), names, strict=True))
    label_of = dict(zip(reps.tolist(), labels, strict=True))
    seeds_of: dict[int, list[str]] = {int(r): [] for r in reps}
    outcomes = []
    all_seed_bits = seeding.seed_bits(res["seed"], len(folds))
    seed_labels = bits_to_labels(all_seed_bits)
    seed_bit_rows = [tuple(b) for b in all_seed_bits.tolist()]
    eigenvalues = np.asarray(res["min_eigenvalue"], dtype=float).tolist()
    residuals = np.asarray(res["residual"], dtype=float).tolist()
    stable_rows, converged_rows, state_rows = stable.tolist(), converged.tolist(), state_of.tolist()
    for i in range(len(z)):
        eig = eigenvalues[i]
        common: dict[str, Any] = {
            "seed": seed_labels[i],
            "seed_bits": seed_bit_rows[i],
            "reached_bits": reached_rows[i],
            "min_eigenvalue": eig,
            "residual": residuals[i],
        }
        if stable_rows[i]:
            seeds_of[state_rows[i]].append(common["seed"])
            outcome = SeedOutcome(
                **common, outcome=Outcome.STABLE, state=name_of[state_rows[i]], message=""
            )
        elif converged_rows[i]:
            message = f"equilibrium with λ_min = {eig:.3g} N·mm ≤ {settings.stability_tolerance:g}"
            outcome = SeedOutcome(**common, outcome=Outcome.UNSTABLE, state=None, message=message)
        else:
            code = int(res["status"][i])
            message = Status(code).message if code in (0, 1, 2, 3) else ""
            if code == Status.CONVERGED.value and np.isnan(eig):
                message = (
                    "equilibrium whose stability could not be evaluated (its reduced Hessian or "
                    "its active constraints' SVD is not finite)"
                )
            outcome = SeedOutcome(**common, outcome=Outcome.FAILED, state=None, message=message)
        outcomes.append(outcome)
    built = tuple(
        StableState(
            name=name_of[int(i)],
            label=label_of[int(i)],
            bits=reached_rows[i],
            q=z[i, :nq].copy(),
            z=z[i].copy(),
            energy=float(res["energy"][i]),
            u_z=float(res["u_z"][i]),
            u_r=float(res["u_r"][i]),
            theta=float(res["theta"][i]),
            min_eigenvalue=float(res["min_eigenvalue"][i]),
            phase_fraction=res["phase_fraction"][i].copy(),
            seeds=tuple(seeds_of[int(i)]),
        )
        for i in reps
    )
    unstable = np.flatnonzero(unstable_of == np.arange(len(z)))
    return StateCatalogue(
        model=model,
        folds=folds,
        states=built,
        seeds=tuple(outcomes),
        unstable_z=z[unstable].reshape(-1, z.shape[1]),
        unstable_eigenvalues=res["min_eigenvalue"][unstable].astype(float),
        settings=settings,
        elapsed=time.perf_counter() - start,
    )


def _names(labels: list[str]) -> list[str]:
    """Unique state names: the label, suffixed ``.2``, ``.3``… for repeated bits."""
    seen: dict[str, int] = {}
    names = []
    for label in labels:
        seen[label] = seen.get(label, 0) + 1
        names.append(label if seen[label] == 1 else f"{label}.{seen[label]}")
    return names
