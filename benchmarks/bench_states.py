"""Benchmark: stable-state enumeration (issue "stable states", speed targets).

* N = 4 fully bistable tube, 2⁷ = 128 seeds: batched (``vmap``) enumeration, cold and warm,
  against a Python loop over the same relaxations (the same pure ``relax_seed`` jitted for one
  seed and called once per seed) run in the same process.
* N = 8 (2¹⁵ = 32,768 seeds) with ``--n8``: warm time and cost per seed (a new layout: its
  kernels compile once, reported as cold time).

Usage::

    .venv/bin/python benchmarks/bench_states.py [--n8] [--loop-seeds 32]

Targets: N = 4 ≤ 1 s warm; N = 8 ≤ 60 s on 2 cores, cost per seed roughly flat in N.
"""

from __future__ import annotations

import argparse
import functools
import time

import numpy as np

import biplan
from biplan._jax import jax, jnp
from biplan.analysis.labels import bistable_folds
from biplan.analysis.states import Enumeration, _seed_targets, enumerate_states
from biplan.solvers._relaxkernel import relax_seed


def timed(fn, *args, **kwargs):  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def batched(n_modules: int) -> tuple[float, float, int, int]:
    model = biplan.Model(biplan.designs.fully_bistable(n_modules=n_modules))
    cat, cold = timed(enumerate_states, model)
    cat, warm = timed(enumerate_states, model)
    return cold, warm, len(cat.seeds), len(cat)


def python_loop(n_seeds: int) -> float:
    """Seconds per seed of a Python loop of single-seed jitted relaxations (N = 4)."""
    model = biplan.Model(biplan.designs.fully_bistable())
    settings = Enumeration()
    _, target, mask = _seed_targets(model, bistable_folds(model.tube))
    fn = jax.jit(functools.partial(relax_seed, model.layout))
    args = (
        jnp.asarray(settings.penalty_stiffness),
        jnp.asarray(settings.max_iterations),
        settings.newton.settings(),
    )
    fn(model.params, jnp.asarray(target[0]), jnp.asarray(mask[0]), *args).z.block_until_ready()
    t0 = time.perf_counter()
    for i in range(n_seeds):
        out = fn(model.params, jnp.asarray(target[i]), jnp.asarray(mask[i]), *args)
        out.z.block_until_ready()
    return (time.perf_counter() - t0) / n_seeds


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--n8", action="store_true", help="also run N = 8 (32,768 seeds)")
    parser.add_argument("--loop-seeds", type=int, default=32)
    args = parser.parse_args()
    cold, warm, n_seeds, n_states = batched(4)
    per_loop = python_loop(args.loop_seeds)
    print(
        f"N=4: {n_seeds} seeds -> {n_states} states; batched cold {cold:.1f} s, warm {warm:.2f} s"
        f" ({1e3 * warm / n_seeds:.2f} ms/seed)"
    )
    print(
        f"N=4: Python loop of jitted single-seed relaxations: {1e3 * per_loop:.2f} ms/seed "
        f"-> {per_loop * n_seeds:.2f} s for all seeds; batched speed-up "
        f"{per_loop * n_seeds / warm:.1f}x"
    )
    if args.n8:
        cold8, warm8, n8, s8 = batched(8)
        print(
            f"N=8: {n8} seeds -> {s8} states; cold {cold8:.0f} s, warm {warm8:.1f} s "
            f"({1e3 * warm8 / n8:.2f} ms/seed; N=4: {1e3 * warm / n_seeds:.2f} ms/seed)"
        )


if __name__ == "__main__":
    np.set_printoptions(precision=4)
    main()
