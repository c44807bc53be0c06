"""Fit of the fully bistable fold laws to the paper's Fig. 4 by search (MODEL §17.1.4).

The paper gives no laws for its four-module fully bistable MFT but reports what they produce
(34 stable states; 00, 2A, 1B, 66 stable; 66 and 1B at u_z/l₀ = 0.9 and Θ = 0.67; slope levels
in thirds; a bimodal elongation distribution). :func:`search_laws` searches the two trilinear
laws for them in stages, each streamed to its own chunk store so that a killed search resumes:

* ``stage-0`` — a space-filling design of :attr:`SearchPlan.samples` law sets over a
  :class:`~biplan.analysis.states.law_search.LawBox` (scrambled Sobol or Latin hypercube);
* ``stage-1`` … ``stage-R`` — local refinement: around each of :attr:`SearchPlan.parents`
  centres (:func:`~biplan.analysis.states.law_front.parents` of everything so far),
  :attr:`SearchPlan.per_parent` law sets in a cube of half-width :attr:`SearchPlan.radius`
  (unit-cube coordinates of the box), halved every round;
* ``slice`` (optional) — a grid over the two coefficients that explain most of the variance
  of the count over stage 0 (:func:`~biplan.analysis.states.law_front.influence`), through the
  lexicographically best law set (the count figure).

Every stage's law sets are determined by the plan and the records before it, so a resumed
search evaluates the same sets. The records of all stages go to ``records.csv``, the Pareto
front to ``front.csv`` and the slice to ``slice.csv``.
"""

from __future__ import annotations

import csv
import hashlib
import json
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from biplan._errors import ConfigError, check_integer, check_range
from biplan.analysis.states.catalogue import Enumeration
from biplan.analysis.states.law_front import (
    OBJECTIVES,
    influence,
    lexicographic,
    objectives,
    parents,
    pareto_front,
)
from biplan.analysis.states.law_records import LawRecords
from biplan.analysis.states.law_search import (
    PARAMETERS,
    LawBox,
    LawRun,
    Sampler,
    neighbourhood,
    run_law_sets,
    sample,
)

if TYPE_CHECKING:
    from biplan.analysis.scaleout import Runner
    from biplan.model.tube import Tube

__all__ = ["SearchPlan", "SearchResult", "search_laws"]

#: ``progress(stage, done, total)``: law sets of a stage done so far.
Progress = Callable[[str, int, int], object]


@dataclass(frozen=True)
class SearchPlan:
    """How large each stage of :func:`search_laws` is.

    Attributes
    ----------
    samples : int
        Law sets of the global stage (a power of two for Sobol).
    sampler : Sampler
    seed : int
        Seed of every design (stage r uses ``seed + 1000 r + parent``).
    rounds : int
        Local refinement rounds (0: none).
    parents : int
        Centres per round.
    per_parent : int
        Law sets per centre (a power of two for Sobol).
    radius : float
        Half-width of the first round's cubes in unit-cube coordinates, in (0, 0.5].
    slice_points : int
        Points per axis of the count slice (0: none).
    chunk : int
        Law sets per chunk (the unit of resumption and of a runner's work).
    """

    samples: int = 4096
    sampler: Sampler = Sampler.SOBOL
    seed: int = 20261206
    rounds: int = 4
    parents: int = 8
    per_parent: int = 32
    radius: float = 0.08
    slice_points: int = 24
    chunk: int = 16

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "sampler", Sampler(self.sampler))
        except ValueError:
            raise ConfigError(
                "sampler", self.sampler, " or ".join(repr(s.value) for s in Sampler)
            ) from None
        check_integer("seed", self.seed, low=0)
        check_integer("rounds", self.rounds, low=0, high=16)
        check_integer("parents", self.parents, low=1)
        check_integer("slice_points", self.slice_points, low=0, high=200)
        if 0 < self.slice_points < 2:
            raise ConfigError(
                "slice_points", self.slice_points, "0 (no slice) or an integer in [2, 200]"
            )
        check_integer("chunk", self.chunk, low=1)
        check_range("radius", self.radius, low=0.0, high=0.5, high_open=False)
        for name in ("samples", "per_parent"):
            n = check_integer(name, getattr(self, name), low=1)
            if self.sampler is Sampler.SOBOL and (n < 2 or n & (n - 1)):
                raise ConfigError(
                    name, n, "a power of two ≥ 2 for the Sobol sampler (e.g. 32, 1024, 4096)"
                )

    @property
    def size(self) -> int:
        """Law sets of the whole search, slice included."""
        return self.samples + self.rounds * self.parents * self.per_parent + self.slice_points**2


@dataclass(frozen=True)
class SearchResult:
    """All records of a search.

    Attributes
    ----------
    box : LawBox
    plan : SearchPlan
    records : LawRecords
        Global and refinement stages (not the slice), in stage order.
    stage : ndarray (n,)
        Stage of each row (0 global, r refinement round r).
    objectives : ndarray (n, 5)
        :data:`~biplan.analysis.states.law_front.OBJECTIVES`.
    front : ndarray
        Row indices of the Pareto front, in lexicographic order.
    slice : LawRecords or None
        The count slice (row-major over ``slice_axes``), or None.
    slice_axes : tuple
        (name, values) of the slice's two coefficients (first varies slowest).
    influence : ndarray (10,)
        η² of the count for each coefficient over the global stage.
    """

    box: LawBox
    plan: SearchPlan
    records: LawRecords
    stage: np.ndarray
    objectives: np.ndarray
    front: np.ndarray
    slice: LawRecords | None = None
    slice_axes: tuple[tuple[str, np.ndarray], ...] = ()
    influence: np.ndarray = field(default_factory=lambda: np.zeros(len(PARAMETERS)))

    @property
    def best(self) -> int:
        """Row of the lexicographically best law set."""
        return int(lexicographic(self.objectives)[0])


def _digest(values: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(values, dtype=float).tobytes()).hexdigest()


def search_laws(
    base: Tube,
    box: LawBox,
    plan: SearchPlan,
    out: Path,
    *,
    resume: bool = False,
    runner: Runner | None = None,
    progress: Progress | None = None,
    enumeration: Enumeration | None = None,
) -> SearchResult:
    """Search the helical and circular laws of ``base`` (module docstring).

    Parameters
    ----------
    base : Tube
        The fully bistable tube (geometry, modules, readings) whose laws are searched.
    box : LawBox
    plan : SearchPlan
    out : Path
        Output directory: ``stage-*/`` chunk stores, ``records.csv``, ``front.csv``.
    resume : bool
        Reuse the finished chunks of an earlier run of the same search in ``out``.
    runner : Runner, optional
        Where chunks run (:mod:`biplan.analysis.scaleout`); default this process.
    progress : callable, optional
        ``progress(stage, done, total)``.
    enumeration : Enumeration, optional
        Settings of each state search.

    Raises
    ------
    ConfigError
        ``out`` is a file, or holds stages of a search and ``resume`` is false, or ``resume``
        meets a different search; before any work.
    """
    from biplan.io.config import dump_config
    from biplan.io.sweepstore import ChunkStore

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ConfigError("out", str(out), "a directory (this is a file)")
    if not resume and out.is_dir() and any(out.glob("stage-*/manifest.json")):
        raise ConfigError(
            "out", str(out), "a directory without an earlier search, or --resume to continue"
        )
    run = LawRun(plan.chunk, enumeration or Enumeration())
    common = {"tube": dump_config(base), "box": box.describe(), "run": repr(run)}

    def stage(name: str, values: np.ndarray) -> LawRecords:
        n_chunks = -(-len(values) // plan.chunk)
        description = {**common, "stage": name, "values": _digest(values), "n": len(values)}
        store = ChunkStore(out / f"stage-{name}", description, n_chunks, resume)
        report = None if progress is None else (lambda d, t: progress(name, d, t))
        return run_law_sets(base, values, run, sink=store, runner=runner, progress=report)

    parts = [stage("0", sample(box, plan.samples, plan.sampler, plan.seed))]
    stages = [np.zeros(plan.samples, dtype=int)]
    for r in range(1, plan.rounds + 1):
        so_far = LawRecords.concatenate(parts)
        centres = parents(objectives(so_far), plan.parents)
        if centres.size == 0:
            break
        radius = plan.radius / 2 ** (r - 1)
        values = np.vstack(
            [
                neighbourhood(
                    box,
                    so_far.values[c],
                    plan.per_parent,
                    radius,
                    plan.sampler,
                    plan.seed + 1000 * r + j,
                )
                for j, c in enumerate(centres)
            ]
        )
        parts.append(stage(str(r), values))
        stages.append(np.full(len(values), r))
    records = LawRecords.concatenate(parts)
    obj = objectives(records)
    global_rows = records.take(slice(0, plan.samples))
    eta = influence(
        box.to_unit(global_rows.values), np.where(global_rows.ok, global_rows.n_states, np.nan)
    )
    result = SearchResult(
        box, plan, records, np.concatenate(stages), obj, pareto_front(obj), influence=eta
    )
    if plan.slice_points:
        result = _with_slice(result, stage)
    write_tables(result, out)
    return result


def _with_slice(
    result: SearchResult, stage: Callable[[str, np.ndarray], LawRecords]
) -> SearchResult:
    """The result with the count slice through its best law set over the two most influential
    coefficients."""
    i, j = (int(k) for k in np.argsort(-result.influence, kind="stable")[:2])
    n = result.plan.slice_points
    grid = result.box.from_unit(np.repeat(np.linspace(0, 1, n)[:, None], len(PARAMETERS), axis=1))
    axes = ((PARAMETERS[i], grid[:, i]), (PARAMETERS[j], grid[:, j]))
    values = np.repeat(result.records.values[result.best][None], n * n, axis=0)
    values[:, i] = np.repeat(axes[0][1], n)
    values[:, j] = np.tile(axes[1][1], n)
    return replace(result, slice=stage("slice", values), slice_axes=axes)


def write_tables(result: SearchResult, out: Path) -> list[Path]:
    """``records.csv`` (every law set: stage, row, coefficients, record, objectives),
    ``front.csv`` (the Pareto front, lexicographic order), ``slice.csv`` (the slice's points,
    row-major) and ``plan.json`` in ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    rows = result.records.rows(PARAMETERS)
    for k, row in enumerate(rows):
        row.update(
            {name: float(x) for name, x in zip(OBJECTIVES, result.objectives[k], strict=True)}
        )
    written = []
    for name, index in (("records.csv", np.arange(len(rows))), ("front.csv", result.front)):
        path = out / name
        with path.open("w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            writer.writerow(["stage", "row", *rows[0]] if rows else ["stage", "row"])
            for i in index.tolist():
                writer.writerow([int(result.stage[i]), i, *rows[i].values()])
        written.append(path)
    if result.slice is not None:
        path = out / "slice.csv"
        with path.open("w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            cells = result.slice.rows(PARAMETERS)
            writer.writerow(["point", *cells[0]])
            writer.writerows([k, *row.values()] for k, row in enumerate(cells))
        written.append(path)
    plan = {**asdict(result.plan), "sampler": result.plan.sampler.value}
    text = json.dumps({"plan": plan, "box": result.box.describe()}, indent=1)
    (out / "plan.json").write_text(text, encoding="utf-8")
    return written
