"""``biplan compile [--jobs N]``: compile this installation's kernels once, in parallel.

Numba compiles a kernel on its first call and caches it for this installation
(:mod:`biplan._compile.numba_cache`); one process compiles one function at a time, so a user
who runs every command compiles the kernels one after another. :data:`WORKLOADS` are small
runs of the drivers that together call every compiled entry point once, on the designs the
commands use; :func:`compile_all` runs :data:`FIRST` (the one Newton and the construction of a
``System``, which every other workload calls first) with only :data:`BESIDE_FIRST` (the inertia
rows, which the Newton links) beside it, then the others in ``--jobs`` processes at once, and
the command prints each workload's time. A kernel already cached is
loaded, not compiled: a second run takes seconds. Exits 1 when a workload failed.
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Annotated

import typer
from rich.console import Console

from biplan._errors import check_integer
from biplan.cli._checks import options_named

__all__ = ["BESIDE_FIRST", "FIRST", "WORKLOADS", "WorkloadTime", "compile_all", "compile_kernels"]


def _equilibrium() -> None:
    """The one Newton (force and displacement control), the System and the kinematics of
    figures of two designs, and the System of a tube long enough for the banded solve (its
    Jacobian pattern)."""
    from biplan import Load, Model, Newton, designs, relaxed_reference, solve_equilibrium

    for tube in (designs.semi_bistable(), designs.fully_bistable()):
        model = Model(tube)
        model.system().evaluate(model.pack(model.zeros()))  # the assembly before the Newton
        ref = relaxed_reference(model)
        solve_equilibrium(model, Newton(), ref, Load.of_displacement(0.5))
        solve_equilibrium(model, Newton(), ref, Load.of_force(0.5))
        model.kinematics(ref.q)  # what figures draw
    Model(designs.fully_bistable(n_modules=12)).system()


def _inertia() -> None:
    """The inertia rows of a time step (:func:`biplan.model.system.inertia.add_inertia`), as
    the one Newton calls them: compiled beside the first workload's assembly, so that the
    Newton finds both in the cache."""
    import numpy as np

    from biplan import Model, designs
    from biplan.model.system.inertia import add_inertia

    system = Model(designs.semi_bistable()).system()
    n_q, n_z = system.sizes[0], system.n_unknowns
    data = np.concatenate([[1.0, 1.0, 1e-3], np.zeros(3 * n_q)])
    add_inertia(system.data, np.zeros(n_q), data, np.zeros(n_z), np.zeros((n_z, n_z)), True)


def _path() -> None:
    """The arclength path through the first snap, its events and observations."""
    from biplan import ArcLength, Control, Model, designs, relaxed_reference, trace_path

    model = Model(designs.semi_bistable())
    trace_path(model, ArcLength(), relaxed_reference(model), Control.force(2.5))


def _dynamics() -> None:
    """A few generalized-α steps of the paper's force ramp (the inertia rows, the step loop)."""
    from biplan import GeneralizedAlpha, Model, designs, integrate, relaxed_reference

    model = Model(designs.semi_bistable())
    integrate(model, GeneralizedAlpha(), relaxed_reference(model), t_end=0.05)


def _states() -> None:
    """The exhaustive state search (seed relaxation, observation at rest), the band between
    two states and deflation."""
    from biplan import Model, designs
    from biplan.analysis.states.barriers import minimum_energy_path
    from biplan.analysis.states.deflation import Deflation, deflate
    from biplan.analysis.states.search import enumerate_states

    model = Model(designs.fully_bistable(n_modules=2))
    catalogue = enumerate_states(model)
    first, last = catalogue.states[0], catalogue.states[-1]
    minimum_energy_path(model, first.z, last.z)
    deflate(model, [s.z for s in catalogue.states], Deflation(n_perturbations=1, max_midpoints=1))


def _maps() -> None:
    """One point of the design map (force ramp) and of the stability map."""
    from biplan import designs
    from biplan.analysis.maps.design_map import ResponseEvaluator
    from biplan.analysis.maps.stability_map import StabilityEvaluator
    from biplan.analysis.maps.sweeps import Grid, sweep

    design = designs.semi_bistable()
    sweep(design, Grid.of(b=[0.5], C=[1.0]), ResponseEvaluator(), chunk_size=1)
    sweep(design, Grid.of(C=[1.0], displacement=[0.1]), StabilityEvaluator(), chunk_size=1)


#: The workloads by name; :data:`FIRST` runs before the others (with :data:`BESIDE_FIRST`
#: beside it), which start in this order, the longest first (cold, AMD EPYC 2-core machine:
#: states 92 s, path 64 s, dynamics 56 s, maps 34 s), so that two processes finish together.
WORKLOADS: dict[str, Callable[[], None]] = {
    "equilibrium": _equilibrium,
    "inertia": _inertia,
    "states": _states,
    "path": _path,
    "dynamics": _dynamics,
    "maps": _maps,
}
FIRST = "equilibrium"
#: Runs beside :data:`FIRST` where two processes may: a subtree of the one Newton that the
#: first workload's assembly does not compile.
BESIDE_FIRST = "inertia"


@dataclass(frozen=True)
class WorkloadTime:
    """One workload run: its name, wall time [s] and error (``None`` when it ran)."""

    name: str
    seconds: float
    error: str | None = None


def _run(name: str) -> WorkloadTime:
    """Run one workload in this (worker) process, as biplan's own processes compile."""
    from biplan._compile.numba_cache import use_own_opt_level
    from biplan._compile.setup import limit_blas_threads
    from biplan.model.system import quiet_compile_notice

    limit_blas_threads()
    use_own_opt_level()
    quiet_compile_notice()  # the command says that it compiles, not each workload
    start = time.perf_counter()
    try:
        WORKLOADS[name]()
    except Exception as exc:  # reported with its workload; the others go on
        return WorkloadTime(name, time.perf_counter() - start, f"{type(exc).__name__}: {exc}")
    return WorkloadTime(name, time.perf_counter() - start)


def compile_all(jobs: int) -> Iterator[WorkloadTime]:
    """Compile (or load) every kernel: :data:`FIRST` in a new process (and
    :data:`BESIDE_FIRST` in another, for ``jobs`` > 1), then the other workloads in ``jobs``
    processes at once (``jobs`` ≥ 1); yields each workload's time as it finishes. Every
    workload runs in a process of its own (``spawn``), so this process compiles nothing."""
    context = multiprocessing.get_context("spawn")
    first = [FIRST, BESIDE_FIRST] if jobs > 1 else [FIRST]
    rest = [name for name in WORKLOADS if name not in first]
    with ProcessPoolExecutor(max_workers=len(first), mp_context=context) as pool:
        futures = [pool.submit(_run, name) for name in first]
        for done in as_completed(futures):
            yield done.result()
    with ProcessPoolExecutor(max_workers=min(jobs, len(rest)), mp_context=context) as pool:
        futures = [pool.submit(_run, name) for name in rest]
        for done in as_completed(futures):
            yield done.result()


def compile_kernels(
    jobs: Annotated[
        int,
        typer.Option(
            "--jobs",
            help="Processes compiling at once after the shared Newton (default: the cores "
            "this process may run on).",
        ),
    ] = 0,
) -> None:
    """Compile every kernel of this installation now (once; later runs load them)."""
    from biplan._compile.numba_cache import cache_dir
    from biplan.analysis.scaleout import available_cores

    with options_named({"jobs": "--jobs"}):
        jobs = check_integer("jobs", jobs, low=0) or available_cores()
    err = Console(stderr=True)
    err.print(
        f"biplan: compiling the kernels of this installation, loading those already cached "
        f"({len(WORKLOADS)} workloads: {FIRST} first"
        f"{f' with {BESIDE_FIRST} beside it' if jobs > 1 else ''}, then {jobs} process"
        f"{'es' if jobs > 1 else ''} at once; cache {cache_dir()})"
    )
    start = time.perf_counter()
    failed = []
    for done in compile_all(jobs):
        if done.error is None:
            err.print(f"  {done.name:<12} {done.seconds:7.1f} s")
        else:
            failed.append(done.name)
            err.print(f"  [red]{done.name:<12} failed after {done.seconds:.1f} s: {done.error}")
    err.print(f"compiled in {time.perf_counter() - start:.1f} s (wall)")
    if failed:
        raise typer.Exit(1)
