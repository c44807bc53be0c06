"""Seeds of a state search, their relaxation, and the two searches (MODEL §15).

A seed is a bit vector over the bistable folds (free end first,
:func:`~biplan.analysis.states.labels.bistable_folds`): 0 seeds a fold at its closed well, 1 at its
open well. Seed i has the bits of i written in binary with the first fold as the most
significant bit (the order of ``itertools.product((0, 1), repeat=n)``).

* :attr:`Search.EXHAUSTIVE` relaxes all 2ⁿ seeds, in chunks of ``Enumeration.chunk``, in
  this process or on a runner of :mod:`biplan.analysis.scaleout` (a Dask cluster: the chunks
  of a worker that dies are run again elsewhere); each finished chunk can go to a
  :class:`~biplan.analysis.maps.sweeps.ChunkSink` (the sweep store), so a killed run resumes at the
  first unfinished chunk.
* :attr:`Search.NEIGHBOURHOOD` starts from the all-closed seed and, round after round,
  relaxes the Hamming-1 neighbours (one fold flipped) of the fold states reached so far that
  have not been tried, until a round finds nothing new. It finds every state connected to
  the all-closed one by single-fold changes — the connected component of the transition graph
  — at a cost that grows with the number of states reached, not with 2ⁿ.

Every seed goes through the same compiled relaxation
(:func:`biplan.solvers.relax_loop.relax_seeds`) and the same observation, so a seed's result
does not depend on the search that tried it.
"""

from __future__ import annotations

import contextlib
import enum
import functools
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan._errors import ConfigError
from biplan.geometry import FoldRef
from biplan.model.assembly import Model
from biplan.model.tube import Tube
from biplan.solvers import lanes, observation, relax_loop
from biplan.solvers.status import Status

if TYPE_CHECKING:
    from biplan.analysis.maps.sweeps import ChunkSink
    from biplan.analysis.states.catalogue import Enumeration

__all__ = [
    "CONFIRM_SEEDS",
    "MAX_FOLDS",
    "SECONDS_PER_SEED",
    "Search",
    "cost_estimate",
    "evaluate",
    "evaluate_chunk",
    "exhaustive",
    "fold_vector_index",
    "merge_rows",
    "neighbourhood",
    "outcome_masks",
    "relax_seeds",
    "seed_bits",
    "seed_targets",
    "thread_count",
]

#: Seeds whose equilibria agree to this [mm, rad] (max norm) share one observation: the
#: polish converges to 10⁻⁹, so two seeds that reached one equilibrium agree far closer.
SHARED_OBSERVATION = 1e-8
#: Seeds above which a search runs only when confirmed (``confirm=True``, ``--yes``).
CONFIRM_SEEDS = 2**16
#: Wall time per seed and thread [s] is about this × N² for N modules (compiled relaxation
#: and observation, fully bistable tubes, warm kernels, on the 2-core development machine:
#: 2048 seeds of N = 6 in 2.5 s and 32768 of N = 8 in 35 s on two threads; docs/performance.md).
SECONDS_PER_SEED = 4.0e-5

Progress = Callable[[int, int], None]


class Search(enum.Enum):
    """Which seeds a state enumeration relaxes (module docstring)."""

    EXHAUSTIVE = "exhaustive"
    NEIGHBOURHOOD = "neighbourhood"


#: Most bistable folds of each search. Exhaustive: 2²⁰ seeds (N = 10 has 19 folds), every
#: seed's result held in memory at the end (the N = 10 run peaked at 4.8 GB); neighbourhood:
#: seed indices are 64-bit integers.
MAX_FOLDS = {Search.EXHAUSTIVE: 20, Search.NEIGHBOURHOOD: 62}


def fold_vector_index(model: Model, fold: FoldRef) -> int:
    """Index of a fold in the (helical, then circular) fold vectors of the kernels."""
    return fold.index if fold.set == "helical" else model.tube.n_modules + fold.index


def seed_bits(indices: np.ndarray, n_folds: int) -> np.ndarray:
    """Bits (k, n_folds) of seeds ``indices`` (first fold most significant)."""
    shifts = np.arange(n_folds - 1, -1, -1, dtype=np.int64)
    return ((np.asarray(indices, dtype=np.int64)[:, None] >> shifts) & 1).astype(int)


def _seed_index(bits: np.ndarray) -> np.ndarray:
    n = bits.shape[-1]
    return (np.asarray(bits, dtype=np.int64) << np.arange(n - 1, -1, -1, dtype=np.int64)).sum(-1)


def outcome_masks(res: dict[str, np.ndarray], tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """(converged, stable) per seed of :func:`evaluate`'s result: a finite equilibrium whose
    solve converged and whose stability was evaluated (λ_min not NaN; +∞ is a contact-locked
    state), and among those the ones with λ_min > ``tolerance`` [N·mm per unit q²]."""
    converged = (res["status"] == Status.CONVERGED.value) & np.isfinite(res["residual"])
    converged &= np.all(np.isfinite(res["z"]), axis=1) & ~np.isnan(res["min_eigenvalue"])
    return converged, converged & (res["min_eigenvalue"] > tolerance)


def cost_estimate(n_seeds: int, n_modules: int, threads: int = 1) -> str:
    """A one-line estimate of the wall time of relaxing ``n_seeds`` seeds of an
    ``n_modules``-module tube in one process on ``threads`` threads (:data:`SECONDS_PER_SEED`)."""
    seconds = n_seeds * SECONDS_PER_SEED * n_modules**2 / threads
    if seconds < 120:
        return f"about {seconds:.0f} s"
    if seconds < 7200:
        return f"about {seconds / 60:.0f} min"
    return f"about {seconds / 3600:.1f} h"


def seed_targets(
    model: Model, folds: tuple[FoldRef, ...], bits: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(target openings, mask), (k, N + Nc) each, of seeds with ``bits`` (k, n_folds)."""
    tube = model.tube
    laws = list(tube.helical_laws) + list(tube.circular_laws)
    target = np.zeros((len(bits), len(laws)))
    mask = np.zeros(len(laws))
    for bit, fold in enumerate(folds):
        i = fold_vector_index(model, fold)
        wells = laws[i].wells()
        target[:, i] = np.where(bits[:, bit] == 1, wells[-1], wells[0])
        mask[i] = 1.0
    return target, np.broadcast_to(mask, target.shape).copy()


def relax_seeds(
    model: Model,
    target: np.ndarray,
    mask: np.ndarray,
    settings: Enumeration,
    progress: Progress | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Relaxation of seeds (rows of ``target``/``mask``): (z, status, residual).

    The seeds of a block of ``settings.chunk`` relax in parallel on the model's compiled
    system (:func:`biplan.solvers.relax_loop.relax_seeds`); ``progress(done, total)`` is
    called after each block.
    """
    newton = settings.newton
    method = newton.loop_settings()
    data = model.system().data
    n_z = model.n_unknowns
    k, chunk = len(target), settings.chunk
    zs, status, residual = [], [], []
    for lo in range(0, k, chunk):
        hi = min(lo + chunk, k)
        n = hi - lo
        z, s = np.empty((n, n_z)), np.empty(n, dtype=np.int64)
        r, its = np.empty(n), np.empty(n, dtype=np.int64)
        lanes.run_rows(
            relax_loop.relax_rows,
            n,
            data,
            np.ascontiguousarray(target[lo:hi], dtype=float),
            np.ascontiguousarray(mask[lo:hi], dtype=float),
            float(settings.penalty_stiffness),
            int(settings.max_iterations),
            method,
            z,
            s,
            r,
            its,
        )
        zs.append(z)
        status.append(s)
        residual.append(r)
        if progress is not None:
            progress(hi, k)
    return np.concatenate(zs), np.concatenate(status), np.concatenate(residual)


def merge_rows(q: np.ndarray, keep: np.ndarray, tolerance: float) -> np.ndarray:
    """For each row i of ``q`` with ``keep[i]``: the first kept row r ≤ i, in row order, that
    is a representative and has max |q_r − q_i| < tolerance (i itself when none); −1 for rows
    not kept.

    The rows go in blocks of :data:`_BLOCK`. A row of a block is first compared with the
    representatives of the earlier blocks, then (if none is close) with the earlier such rows
    of its block, whose representatives are settled in row order. Candidates come from a
    sorted projection p = q·w (fixed signed weights, Σ|w| = 1: rows within the tolerance in
    the max norm are within it in p) and are screened by three more projections before the
    full comparison (:func:`_close_pairs`). Each row meets the representatives near it, not
    every row near it, so a state reached by most of the seeds costs no more than any other:
    0.7–0.9 s for the 5·10⁵ seeds of N = 10 (``benchmarks/bench_state_files.py --run``).
    """
    out = np.full(len(q), -1, dtype=np.int64)
    rows = np.flatnonzero(keep)
    if rows.size == 0:
        return out
    x = np.asarray(q[rows], dtype=float)
    rng = np.random.default_rng(0)
    shape = (x.shape[1], _PROJECTIONS)
    w = rng.uniform(0.5, 1.5, shape) * rng.choice((-1.0, 1.0), shape)  # signed: spread out
    p = x @ (w / np.abs(w).sum(axis=0))
    rep_of = np.arange(rows.size)
    reps = np.zeros(0, dtype=np.int64)  # representatives so far, sorted by p[:, 0]
    for b0 in range(0, rows.size, _BLOCK):
        block = np.arange(b0, min(b0 + _BLOCK, rows.size))
        a, c = _close_pairs(x, p, block, reps, tolerance)
        first = np.full(block.size, rows.size)
        np.minimum.at(first, a - b0, c)
        found = first < rows.size
        rep_of[block[found]] = first[found]
        open_rows = block[~found]  # no earlier representative close: settled in the block
        by_p = open_rows[np.argsort(p[open_rows, 0], kind="stable")]
        a, c = _close_pairs(x, p, open_rows, by_p, tolerance)
        earlier = c < a
        a, c = a[earlier], c[earlier]
        by_row = np.lexsort((c, a))
        _settle(rep_of, a[by_row].tolist(), c[by_row].tolist())
        new = by_p[rep_of[by_p] == by_p]  # sorted by p[:, 0], as reps
        at = np.searchsorted(p[reps, 0], p[new, 0], side="right")
        reps = np.insert(reps, at, new)
    out[rows] = rows[rep_of]
    return out


#: Rows per block of :func:`merge_rows`, and the projections that screen candidate pairs.
_BLOCK = 2048
_PROJECTIONS = 4


def _settle(rep_of: np.ndarray, a: list[int], c: list[int]) -> None:
    """Pairs (a, c) of close rows, c < a, ordered by a then c: in row order, a joins its first
    close representative (rep_of[c] == c), if any."""
    k, n = 0, len(a)
    while k < n:
        row, found = a[k], -1
        while k < n and a[k] == row:
            if found < 0 and rep_of[c[k]] == c[k]:
                found = c[k]
            k += 1
        if found >= 0:
            rep_of[row] = found


def _close_pairs(
    x: np.ndarray, p: np.ndarray, rows: np.ndarray, candidates: np.ndarray, tolerance: float
) -> tuple[np.ndarray, np.ndarray]:
    """Every (a, c), a in ``rows`` and c in ``candidates`` (sorted by p[:, 0]), with
    max |x_c − x_a| < tolerance: c within the tolerance of a in p[:, 0] (a window of the
    sorted candidates), then in each other projection (weights Σ|w| = 1, so
    |Δp| ≤ max |Δx|), then in every coordinate."""
    sorted_p = p[candidates, 0]
    lo = np.searchsorted(sorted_p, p[rows, 0] - tolerance, side="left")
    hi = np.searchsorted(sorted_p, p[rows, 0] + tolerance, side="right")
    size = hi - lo
    a = np.repeat(rows, size)
    start = np.repeat(lo - np.cumsum(size) + size, size)
    c = candidates[start + np.arange(a.size)]
    for k in range(1, p.shape[1]):
        near = np.abs(p[c, k] - p[a, k]) <= tolerance
        a, c = a[near], c[near]
    close = np.max(np.abs(x[c] - x[a]), axis=1, initial=0.0) < tolerance
    return a[close], c[close]


def evaluate(
    model: Model,
    folds: tuple[FoldRef, ...],
    indices: np.ndarray,
    settings: Enumeration,
    progress: Progress | None = None,
) -> dict[str, np.ndarray]:
    """Relax and observe seeds ``indices`` (seeds whose equilibria agree to
    :data:`SHARED_OBSERVATION` are observed once): per seed (leading axis) ``seed``, ``z``,
    ``status``, ``residual`` [N, mm], ``reached`` (fold bits of the equilibrium),
    ``min_eigenvalue`` [N·mm per unit q²], ``energy`` [N·mm], ``u_z``, ``u_r`` [mm],
    ``theta`` [rad], ``phase_fraction`` (N + Nc, 3)."""
    indices = np.asarray(indices, dtype=np.int64)
    target, mask = seed_targets(model, folds, seed_bits(indices, len(folds)))
    with _threads(thread_count(settings)):
        z, status, residual = relax_seeds(model, target, mask, settings, progress)
        finite = np.all(np.isfinite(z), axis=1)
        rep = merge_rows(z[:, : model.layout.n_coordinates], finite, SHARED_OBSERVATION)
        rep = np.where(finite, rep, np.arange(len(z)))
        observed = np.flatnonzero(rep == np.arange(len(z)))
        obs = observation.observe(model, z[observed])
    position = np.zeros(len(z), dtype=np.int64)
    position[observed] = np.arange(len(observed))
    obs = type(obs)(*(np.asarray(v)[position[rep]] for v in obs))
    frac = obs.phase_fraction[:, [fold_vector_index(model, f) for f in folds], :]
    return {
        "seed": indices,
        "z": z,
        "status": np.asarray(status, dtype=np.int64),
        "residual": np.asarray(residual, dtype=float),
        "reached": (frac[:, :, 2] > frac[:, :, 0]).astype(np.int64),
        "min_eigenvalue": np.asarray(obs.min_eigenvalue, dtype=float),
        "energy": np.asarray(obs.energy, dtype=float),
        "u_z": np.asarray(obs.u_z, dtype=float),
        "u_r": np.asarray(obs.u_r, dtype=float),
        "theta": np.asarray(obs.theta, dtype=float),
        "phase_fraction": np.asarray(obs.phase_fraction, dtype=float),
    }


def _concatenate(parts: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


@functools.lru_cache(maxsize=4)
def _model(tube: Tube) -> Model:
    return Model(tube)


def evaluate_chunk(tube: Tube, settings: Enumeration, indices: np.ndarray) -> dict[str, np.ndarray]:
    """:func:`evaluate` of seeds ``indices`` of ``tube``'s bistable folds: what a worker runs
    (picklable arguments; the model is built once per process)."""
    from biplan.analysis.states.labels import bistable_folds

    model = _model(tube)
    return evaluate(model, bistable_folds(tube), indices, settings)


def thread_count(settings: Enumeration) -> int:
    """Threads of an in-process search: ``settings.threads``, or one per available core."""
    from biplan.analysis.scaleout import available_cores

    return settings.threads or available_cores()


@contextlib.contextmanager
def _threads(n: int) -> Iterator[None]:
    """The compiled lanes (:mod:`biplan.solvers.lanes`) on at most ``n`` threads in the block."""
    with lanes.limited(max(1, n)):
        yield


def _chunks(indices: np.ndarray, size: int) -> list[np.ndarray]:
    return [indices[lo : lo + size] for lo in range(0, len(indices), size)]


def exhaustive(
    model: Model,
    folds: tuple[FoldRef, ...],
    settings: Enumeration,
    sink: ChunkSink | None = None,
    progress: Progress | None = None,
    runner: Any = None,
) -> dict[str, np.ndarray]:
    """Every seed, chunk by chunk (:func:`evaluate`): chunks already in ``sink`` are loaded,
    the others computed by ``runner`` (:mod:`biplan.analysis.scaleout`; default this process,
    the seeds of a chunk on :func:`thread_count` threads) and saved to ``sink`` as they
    finish; the result is in seed order either way."""
    from biplan.analysis.maps.sweeps import run_chunks

    chunks = _chunks(np.arange(2 ** len(folds)), settings.chunk)
    if runner is None:  # this process: chunk after chunk, the seeds of each in parallel
        task: Any = functools.partial(evaluate, model, folds, settings=settings)
    else:
        task = functools.partial(evaluate_chunk, model.tube, settings)
    results = run_chunks(task, chunks, runner=runner, sink=sink, progress=progress)
    return _concatenate([results[c] for c in range(len(chunks))])


def neighbourhood(
    model: Model,
    folds: tuple[FoldRef, ...],
    settings: Enumeration,
    progress: Progress | None = None,
) -> dict[str, np.ndarray]:
    """Seeds reached from the all-closed seed through Hamming-1 neighbours of the fold states
    of stable equilibria (module docstring); results in seed order. ``progress(done, total)``
    counts seeds tried against seeds known so far. Each round's seeds run in chunks, the seeds
    of a chunk on :func:`thread_count` threads."""
    from biplan.analysis.maps.sweeps import run_chunks

    n = len(folds)
    flips = np.eye(n, dtype=np.int64)
    tried: set[int] = set()
    frontier = np.array([0], dtype=np.int64)
    parts = []
    task = functools.partial(evaluate, model, folds, settings=settings)
    while frontier.size:
        chunks = _chunks(frontier, settings.chunk)
        done = run_chunks(task, chunks)
        part = _concatenate([done[c] for c in range(len(chunks))])
        parts.append(part)
        tried.update(int(i) for i in frontier)
        _, stable = outcome_masks(part, settings.stability_tolerance)
        reached = np.unique(part["reached"][stable], axis=0)
        neighbours = _seed_index((reached[:, None, :] ^ flips[None]).reshape(-1, n))
        frontier = np.array(sorted(set(neighbours.tolist()) - tried), dtype=np.int64)
        if progress is not None:
            progress(len(tried), len(tried) + frontier.size)
    out = _concatenate(parts)
    order = np.argsort(out["seed"], kind="stable")
    return {k: v[order] for k, v in out.items()}


def check_size(n_folds: int, n_modules: int, search: Search, confirm: bool) -> None:
    """Refuse, before any work, a search too large to run (:data:`MAX_FOLDS`) or too large to
    run unasked (with its cost estimate)."""
    limit = MAX_FOLDS[search]
    if n_folds > limit:
        raise ConfigError(
            "model", f"{n_folds} bistable folds", f"at most {limit} for the {search.value} search"
        )
    seeds = 2**n_folds
    if search is Search.EXHAUSTIVE and seeds > CONFIRM_SEEDS and not confirm:
        from biplan.analysis.scaleout import available_cores

        threads = available_cores()
        raise ConfigError(
            "search",
            f"exhaustive over {n_folds} bistable folds ({seeds:,} seeds)",
            f"at most {CONFIRM_SEEDS:,} seeds unless confirmed (confirm=True, --yes): "
            f"{cost_estimate(seeds, n_modules, threads)} in one process on {threads} threads; "
            "or the neighbourhood search",
        )
