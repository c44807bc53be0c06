"""What a request will cost, estimated before the work from measurements.

Every number here was measured on the project's 2-core machine (no accelerator, float64 JAX on
CPU; ``docs/performance.md``, "Sizes"). The estimates are orders of magnitude, meant for the
warning a user reads before a long run, never for scheduling.

* A tube of N modules: the cold start (the model's kernels compiled, the relaxed reference
  solved) and a warm displacement-controlled step (Newton, 2–6 iterations, with the stability
  check), interpolated log-log between the measured sizes (:data:`MEASURED_TUBES`) and
  extrapolated along the last measured slope. The dense linear algebra of a step (the KKT
  LU, the stability check's eigenvalues) makes a step grow as about N³ beyond 100 modules,
  and compiling the kernels grows with N too (one-hot placement constants of O(N² · n_q)
  values: 224 MB at N = 1000, where compiling the reference solve did not finish in 10 min).
* :data:`MAX_MODULES` is the largest tube a configuration file may ask for
  (``geometry.n_modules``; the Python API builds any size): about the largest measured
  (384 modules: 5 min to start, 54 s per step); beyond it the estimates are extrapolations
  and the compile time runs away. Above :data:`LARGE_MODULES` (the largest example,
  ``examples/long_tube_48.toml``: a step under 0.2 s) loading a configuration warns with the
  estimated cost.
* A map point (:data:`MAP_POINT_RATE`, points per second on one thread for the paper's
  six-module design, scaled by the step cost of larger tubes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = [
    "LARGE_MODULES",
    "MAP_POINT_RATE",
    "MAX_MODULES",
    "MEASURED_TUBES",
    "TubeCost",
    "duration",
    "map_seconds",
    "tube_cost",
]

#: (N, cold start [s], warm step [s]) of the semi-bistable design's layout with N modules,
#: measured in the same hour (``docs/performance.md``, "Sizes"): the cold start builds the
#: model, compiles and relaxes the reference and compiles the displacement sweep in a fresh
#: process with an empty compilation cache; the step is one warm step of a
#: displacement-controlled sweep in phase 1 (Newton, 2–6 iterations, and the stability check).
MEASURED_TUBES = (
    (6, 62.0, 0.0068),
    (48, 73.0, 0.163),
    (96, 106.0, 1.22),
    (192, 150.0, 8.46),
    (384, 319.0, 54.0),
)
#: Loading a configuration of more modules than this warns with the estimated cost.
LARGE_MODULES = 48
#: The most modules a configuration file may ask for.
MAX_MODULES = 400
#: Map points per second on one thread (warm, six-module design, in-process, while the
#: machine's other core was busy) by evaluator name: the force-ramp design map in chunks of
#: 16 (64 points in 0.31 s), the stability map in chunks of whole rows (4 × 32 points,
#: U/l₀ ≤ 0.32, in 2.7 s), both on the compiled System (``NUMBA_NUM_THREADS=1``), the
#: first-instability map (9 points in 5.3 s).
MAP_POINT_RATE = {"force_ramp_response": 200.0, "stability_count": 45.0, "first_instability": 1.7}


@dataclass(frozen=True)
class TubeCost:
    """Estimated cost of a tube: ``cold_start`` [s] (compile and relax the reference) and
    ``step`` [s] (one warm solved state)."""

    cold_start: float
    step: float


def _loglog(n: float, column: int) -> float:
    """Log-log interpolation of a column of :data:`MEASURED_TUBES` at ``n`` modules."""
    xs = [math.log(row[0]) for row in MEASURED_TUBES]
    ys = [math.log(row[column]) for row in MEASURED_TUBES]
    x = math.log(max(n, 1.0))
    k = 1
    while k < len(xs) - 1 and x > xs[k]:
        k += 1
    if x < xs[0]:
        return math.exp(ys[0])
    slope = (ys[k] - ys[k - 1]) / (xs[k] - xs[k - 1])
    return math.exp(ys[k - 1] + slope * (x - xs[k - 1]))


def tube_cost(n_modules: int) -> TubeCost:
    """The estimated :class:`TubeCost` of a tube of ``n_modules`` modules."""
    return TubeCost(_loglog(n_modules, 1), _loglog(n_modules, 2))


def map_seconds(quantity: str, n_points: int, n_modules: int, threads: int) -> float | None:
    """Estimated wall time [s] of a map of ``n_points`` points of the evaluator ``quantity``
    on ``threads`` threads, warm; None for an evaluator without a measured rate."""
    rate = MAP_POINT_RATE.get(quantity)
    if rate is None:
        return None
    scale = tube_cost(n_modules).step / tube_cost(6).step
    return n_points * scale / (rate * max(threads, 1))


def duration(seconds: float) -> str:
    """A duration in words: "0.31 s", "40 s", "12 min", "5.6 h", "3.2 days"."""
    if seconds < 10:
        return f"{seconds:.2g} s"
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 90 * 60:
        return f"{seconds / 60:.0f} min"
    if seconds < 48 * 3600:
        return f"{seconds / 3600:.2g} h"
    return f"{seconds / 86400:.2g} days"
