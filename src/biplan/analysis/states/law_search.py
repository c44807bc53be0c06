"""Search over the two trilinear laws of a fully bistable tube: sampling and evaluation.

A *law set* is the ten coefficients of :data:`PARAMETERS` — (k1, k2, k3) [N/mm²] and
(w1, w2) [mm] of the helical and of the circular law (every fold of a set gets the same law).
:class:`LawBox` bounds them (linear or log-uniform per coefficient); :func:`sample` draws a
scrambled Sobol or Latin-hypercube design from the box (``scipy.stats.qmc``) and
:func:`neighbourhood` a local one around a point. :func:`evaluate_law_set` runs the exhaustive
state search (:func:`~biplan.analysis.states.search.enumerate_states`) on the base tube with
those laws and records what the paper's Fig. 4 and SI S11–S12 speak of
(:class:`~biplan.analysis.states.law_records.LawRecords`): the count, which of 00, 2A, 1B, 66
are stable, the slope levels, the slope peak, the number of elongation peaks, u_z/l₀, u_r/l₀
and Θ of 66 and 1B, and what the seed of 66 reached. :func:`run_law_sets` evaluates many sets
chunk by chunk (:func:`~biplan.analysis.maps.sweeps.run_chunks`: in this process or on a
runner of :mod:`biplan.analysis.scaleout`, finished chunks streamed to a sink and reloaded on
resume).

A set whose laws are not a valid bistable pair (w1 ≥ w2, or F2 = k1 w1 + k2 (w2 − w1) ≥ 0:
one well) gets status ``INVALID`` without a search; a search that raises gets ``FAILED``.
Nothing is dropped.
"""

from __future__ import annotations

import enum
import functools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from biplan._errors import BiplanError, ConfigError, check_finite, check_integer, check_range
from biplan.analysis.states.catalogue import Enumeration, Outcome, SeedOutcome, StateCatalogue
from biplan.analysis.states.law_records import PAIR, PAPER_STATES, LawRecords, LawStatus
from biplan.laws import TrilinearLaw

if TYPE_CHECKING:
    from biplan.analysis.maps.sweeps import ChunkSink
    from biplan.analysis.scaleout import Runner
    from biplan.model.tube import Tube

__all__ = [
    "PARAMETERS",
    "LawBox",
    "LawRun",
    "Sampler",
    "evaluate_law_set",
    "laws_of",
    "neighbourhood",
    "run_law_sets",
    "sample",
    "with_laws",
]

#: The ten coefficients of a law set, in the order of every ``values`` row.
PARAMETERS = tuple(
    f"{s}.{c}" for s in ("helical", "circular") for c in ("k1", "k2", "k3", "w1", "w2")
)
_UNITS = ("N/mm²",) * 3 + ("mm",) * 2


class Sampler(enum.Enum):
    """Space-filling design of the global stage (``scipy.stats.qmc``)."""

    SOBOL = "sobol"
    LATIN_HYPERCUBE = "latin-hypercube"


@dataclass(frozen=True)
class LawBox:
    """Bounds of the ten coefficients of :data:`PARAMETERS`.

    Parameters
    ----------
    low, high : tuple of float
        Bounds per coefficient [N/mm², mm], ``low < high``; k1, k3, w1, w2 bounds > 0 and
        k2 bounds < 0 (a trilinear law's ranges), and for each fold set some w1 < w2 inside the
        box (``low[w1] < high[w2]``).
    log : tuple of bool
        Sample a coefficient log-uniformly (positive ranges only); default all linear.

    Raises
    ------
    ConfigError
        Naming the coefficient, its bounds and the valid range, before any work.
    """

    low: tuple[float, ...]
    high: tuple[float, ...]
    log: tuple[bool, ...] = (False,) * len(PARAMETERS)

    def __post_init__(self) -> None:
        n = len(PARAMETERS)
        for name in ("low", "high", "log"):
            if len(getattr(self, name)) != n:
                raise ConfigError(
                    f"bounds.{name}", getattr(self, name), f"{n} entries ({', '.join(PARAMETERS)})"
                )
        low = tuple(
            check_finite(f"bounds {p} low", v) for p, v in zip(PARAMETERS, self.low, strict=True)
        )
        high = tuple(
            check_finite(f"bounds {p} high", v) for p, v in zip(PARAMETERS, self.high, strict=True)
        )
        for p, lo, hi, unit in zip(PARAMETERS, low, high, _UNITS * 2, strict=True):
            if not lo < hi:
                raise ConfigError(f"bounds {p}", (lo, hi), f"low < high [{unit}]")
            if p.endswith("k2"):
                check_range(
                    f"bounds {p} high", hi, high=0.0, unit=unit + " (spinodal branch: k2 < 0)"
                )
            else:
                check_range(f"bounds {p} low", lo, low=0.0, unit=unit)
        for s in ("helical", "circular"):
            w1, w2 = PARAMETERS.index(f"{s}.w1"), PARAMETERS.index(f"{s}.w2")
            if not low[w1] < high[w2]:
                raise ConfigError(
                    f"bounds {s}.w1, {s}.w2",
                    (low[w1], high[w2]),
                    "low of w1 < high of w2 [mm] (w1 < w2 possible)",
                )
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)
        object.__setattr__(self, "log", tuple(bool(v) for v in self.log))

    @classmethod
    def around(
        cls,
        helical: TrilinearLaw,
        circular: TrilinearLaw,
        spread: float = 0.6,
        log: Sequence[str] = (),
    ) -> LawBox:
        """Every coefficient of two laws ± ``spread`` (a fraction, in (0, 1)); ``log``: the
        coefficients sampled log-uniformly."""
        spread = check_range("spread", spread, low=0.0, high=1.0)
        unknown = [p for p in log if p not in PARAMETERS]
        if unknown:
            raise ConfigError("log", unknown, f"names among {', '.join(PARAMETERS)}")
        centre = np.array([*helical.coefficients, *circular.coefficients])
        a, b = centre * (1 - spread), centre * (1 + spread)
        return cls(
            tuple(np.minimum(a, b).tolist()),
            tuple(np.maximum(a, b).tolist()),
            tuple(p in log for p in PARAMETERS),
        )

    def with_bounds(self, name: str, low: float, high: float, log: bool | None = None) -> LawBox:
        """The box with one coefficient's bounds (and scale) replaced."""
        if name not in PARAMETERS:
            raise ConfigError("bounds", name, f"one of {', '.join(PARAMETERS)}")
        i = PARAMETERS.index(name)
        lo, hi, lg = list(self.low), list(self.high), list(self.log)
        lo[i], hi[i] = low, high
        if log is not None:
            lg[i] = log
        return LawBox(tuple(lo), tuple(hi), tuple(lg))

    def to_unit(self, values: np.ndarray) -> np.ndarray:
        """Coefficients (n, 10) → unit-cube coordinates (n, 10)."""
        lo, hi, lg = np.array(self.low), np.array(self.high), np.array(self.log)
        v = np.asarray(values, dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(lg, np.log(v / lo) / np.log(hi / lo), (v - lo) / (hi - lo))

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Unit-cube coordinates (n, 10) → coefficients (n, 10)."""
        lo, hi, lg = np.array(self.low), np.array(self.high), np.array(self.log)
        u = np.asarray(u, dtype=float)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(lg, lo * (hi / lo) ** u, lo + u * (hi - lo))

    def describe(self) -> dict[str, list[object]]:
        """name → [low, high, "log" | "linear"] (JSON)."""
        return {
            p: [lo, hi, "log" if lg else "linear"]
            for p, lo, hi, lg in zip(PARAMETERS, self.low, self.high, self.log, strict=True)
        }


def _unit_design(sampler: Sampler, n: int, seed: int) -> np.ndarray:
    from scipy.stats import qmc

    d = len(PARAMETERS)
    if sampler is Sampler.SOBOL:
        return qmc.Sobol(d, scramble=True, seed=seed).random_base2(int(np.log2(n)))
    return qmc.LatinHypercube(d, seed=seed).random(n)


def _check_design(sampler: Sampler | str, n: int, seed: int) -> Sampler:
    try:
        sampler = Sampler(sampler)
    except ValueError:
        raise ConfigError("sampler", sampler, " or ".join(repr(s.value) for s in Sampler)) from None
    check_integer("seed", seed, low=0)
    if sampler is Sampler.SOBOL:
        check_integer("samples", n, low=2, note=" that is a power of two (Sobol balance)")
        if n & (n - 1):
            raise ConfigError(
                "samples", n, "a power of two ≥ 2 for the Sobol sampler (e.g. 1024, 2048, 4096)"
            )
    else:
        check_integer("samples", n, low=1)
    return sampler


def sample(
    box: LawBox, n: int, sampler: Sampler | str = Sampler.SOBOL, seed: int = 0
) -> np.ndarray:
    """``n`` law sets (n, 10) filling ``box``: scrambled Sobol (``n`` a power of two) or a
    Latin hypercube, seeded."""
    sampler = _check_design(sampler, n, seed)
    return box.from_unit(_unit_design(sampler, n, seed))


def neighbourhood(
    box: LawBox,
    centre: np.ndarray,
    n: int,
    radius: float,
    sampler: Sampler | str = Sampler.SOBOL,
    seed: int = 0,
) -> np.ndarray:
    """``n`` law sets around ``centre`` (10,): a design in the cube of half-width ``radius``
    (unit-cube coordinates of ``box``, in (0, 0.5]) about it, shifted to stay inside the box."""
    sampler = _check_design(sampler, n, seed)
    radius = check_range("radius", radius, low=0.0, high=0.5, high_open=False)
    c = box.to_unit(np.asarray(centre, dtype=float).reshape(1, -1))[0]
    if not np.all(np.isfinite(c)):
        raise ConfigError("centre", centre, "a law set inside the box")
    lo = np.clip(np.clip(c, 0, 1) - radius, 0.0, 1.0 - 2 * radius)
    return box.from_unit(lo + 2 * radius * _unit_design(sampler, n, seed))


def laws_of(values: Sequence[float]) -> tuple[TrilinearLaw, TrilinearLaw] | None:
    """(helical, circular) laws of a row of :data:`PARAMETERS`, or None when they are not a
    valid pair of bistable laws."""
    v = [float(x) for x in values]
    try:
        h = TrilinearLaw((v[0], v[1], v[2]), (v[3], v[4]))
        c = TrilinearLaw((v[5], v[6], v[7]), (v[8], v[9]))
    except ConfigError:
        return None
    return (h, c) if h.is_bistable and c.is_bistable else None


def with_laws(base: Tube, values: Sequence[float]) -> Tube | None:
    """``base`` with every helical and circular law replaced (None: not a bistable pair)."""
    laws = laws_of(values)
    if laws is None:
        return None
    h, c = laws
    return replace(
        base,
        helical_laws=(h,) * len(base.helical_laws),
        circular_laws=(c,) * len(base.circular_laws),
        name=f"{base.name.split(' (')[0]} (law search)",
    )


def evaluate_law_set(
    base: Tube, values: Sequence[float], settings: Enumeration | None = None
) -> LawRecords:
    """The record (one row) of a law set: the exhaustive state search of ``base`` with the
    laws of ``values`` (:data:`PARAMETERS`) and what it says about the paper's Fig. 4
    (:class:`~biplan.analysis.states.law_records.LawRecords`)."""
    from biplan.analysis.states.hierarchy import count_peaks, hierarchy
    from biplan.analysis.states.search import enumerate_states
    from biplan.model.assembly import Model

    start = time.perf_counter()
    row = LawRecords.empty(1)
    row.values[0] = values
    laws = laws_of(values)
    if laws is not None:
        row.helical_well[0], row.circular_well[0] = laws[0].wells()[1], laws[1].wells()[1]
    tube = with_laws(base, values)
    if tube is None:
        row.status[0] = LawStatus.INVALID.value
        return row
    try:
        catalogue = enumerate_states(Model(tube), settings or Enumeration())
    except BiplanError:
        row.status[0] = LawStatus.FAILED.value
        row.seconds[0] = time.perf_counter() - start
        return row
    h = hierarchy(catalogue)
    rows = {r["label"]: r for r in reversed(catalogue.rows())}  # the first of a label wins
    l0 = tube.initial_length
    row.status[0] = LawStatus.OK.value
    row.n_states[0] = len(catalogue)
    row.n_labels[0] = len({s.label for s in catalogue.states})
    row.named[0] = [label in rows for label in PAPER_STATES]
    hel = np.asarray(h["slope_branch"].values, dtype=int)
    row.max_open_helical[0] = int(hel.max()) if hel.size else -1
    k, th = np.asarray(h["branch"].values), np.abs(np.asarray(h["mean_Theta"].values))
    row.thirds_error[0] = (
        float(np.max(np.abs(th[k > 0] - k[k > 0] / 3))) if np.any(k > 0) else np.inf
    )
    counts = np.asarray(h["count_Theta"].values)
    if counts.size and counts.max() > 0:
        row.slope_peak[0] = abs(float(h["Theta_bin"].values[int(np.argmax(counts))]))
    row.n_u_z_peaks[0] = count_peaks(np.asarray(h["count_u_z"].values))
    for j, label in enumerate(PAIR):
        if label in rows:
            r = rows[label]
            row.u_z_rel[0, j], row.u_r_rel[0, j] = r["u_z"] / l0, r["u_r"] / l0
            row.Theta[0, j] = r["Theta"]
    seed = _seed_of(catalogue, PAIR[0])
    if seed is not None and seed.outcome is not Outcome.FAILED:
        row.seed_66_reached[0] = int("".join(map(str, seed.reached_bits)), 2)
    row.n_failed_seeds[0] = sum(s.outcome is Outcome.FAILED for s in catalogue.seeds)
    row.n_unstable_seeds[0] = sum(s.outcome is Outcome.UNSTABLE for s in catalogue.seeds)
    row.seconds[0] = time.perf_counter() - start
    return row


def _seed_of(catalogue: StateCatalogue, label: str) -> SeedOutcome | None:
    """The outcome of the seed with ``label``'s bits (None: not a label of this tube)."""
    from biplan.analysis.states.labels import label_to_bits

    try:
        bits = label_to_bits(label, len(catalogue.folds))
    except ConfigError:
        return None
    return next((s for s in catalogue.seeds if s.seed_bits == bits), None)


def _evaluate_chunk(
    base: Tube, values: np.ndarray, settings: Enumeration, indices: np.ndarray
) -> dict[str, np.ndarray]:
    """The records of the law sets ``values[indices]`` as arrays (what a worker runs)."""
    return LawRecords.concatenate(
        [evaluate_law_set(base, values[int(i)], settings) for i in indices]
    ).to_arrays()


@dataclass(frozen=True)
class LawRun:
    """How :func:`run_law_sets` runs: law sets per chunk and the enumeration's settings."""

    chunk: int = 16
    enumeration: Enumeration = field(default_factory=Enumeration)

    def __post_init__(self) -> None:
        object.__setattr__(self, "chunk", check_integer("chunk", self.chunk, low=1))


def run_law_sets(
    base: Tube,
    values: np.ndarray,
    run: LawRun | None = None,
    *,
    sink: ChunkSink | None = None,
    runner: Runner | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> LawRecords:
    """The records of every law set of ``values`` (n, 10), in order.

    Parameters
    ----------
    base : Tube
        The tube whose helical and circular laws are replaced (geometry, options, modules).
    values : ndarray (n, 10)
        Law sets (:data:`PARAMETERS`; N/mm², mm).
    run : LawRun, optional
    sink : ChunkSink, optional
        Finished chunks are saved to it and chunks it holds are loaded, not recomputed
        (``biplan.io.sweepstore.ChunkStore``: a killed search resumes).
    runner : Runner, optional
        Where the chunks run (:mod:`biplan.analysis.scaleout`); default this process.
    progress : callable, optional
        ``progress(done, total)`` law sets, after the loaded chunks and after every chunk.
    """
    from biplan.analysis.maps.sweeps import run_chunks

    run = run or LawRun()
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[1] != len(PARAMETERS) or not np.all(np.isfinite(values)):
        raise ConfigError("values", values.shape, f"finite law sets, shape (n, {len(PARAMETERS)})")
    chunks = [
        np.arange(lo, min(lo + run.chunk, len(values))) for lo in range(0, len(values), run.chunk)
    ]
    task = functools.partial(_evaluate_chunk, base, values, run.enumeration)
    done = run_chunks(task, chunks, runner=runner, sink=sink, progress=progress)
    return LawRecords.concatenate([LawRecords.from_arrays(done[c]) for c in range(len(chunks))])
