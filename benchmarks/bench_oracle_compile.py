"""What one JAX oracle of the test suite costs: tracing and lowering, XLA compiling, running.

Run:  BIPLAN_JAX_CACHE=off .venv/bin/python benchmarks/bench_oracle_compile.py [--eager]

The function is the assembly oracle of ``tests/test_assembly_oracle.py`` on the semi-bistable
design: the KKT residual, the KKT Jacobian and the state data, each from the local assembly
(:mod:`biplan.model.lagrangian`) and from the whole-tube autodiff (:mod:`biplan.model.oracle`),
in one ``jax.jit``. Printed: the number of operations traced, the seconds of tracing and
lowering, of XLA compiling under the test suite's cheap pipeline
(:data:`biplan._compile.setup.CHEAP_PIPELINE`), the same with each of XLA's algebraic
simplifier, CSE and instruction fusion disabled, and with XLA's default pipeline, and one run.
``--eager`` also times the same functions run op by op (``jax.disable_jit``: each operation
compiles on its own, about a minute). Set ``BIPLAN_JAX_CACHE=off``: a persistent-cache hit
would time a read instead of a compile.
"""

from __future__ import annotations

import argparse
import time

import biplan
from biplan._compile.setup import CHEAP_PIPELINE, jax, jnp
from biplan.model import lagrangian, oracle
from biplan.model.params import Load

VARIANTS = {
    "cheap pipeline (the suite's)": {},
    "  without the algebraic simplifier": {"xla_disable_hlo_passes": "algsimp"},
    "  without CSE": {"xla_disable_hlo_passes": "cse"},
    "  without instruction fusion": {"xla_disable_hlo_passes": "cpu-instruction-fusion"},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--eager", action="store_true", help="also run op by op (slow)")
    args = parser.parse_args()
    model = biplan.Model(biplan.designs.semi_bistable())
    layout, p = model.layout, model.params
    load = Load(1.3, 0.0, 0.0).for_jax()
    z = jnp.zeros(model.n_unknowns) + 0.01

    def all_three(p, z, load):  # type: ignore[no-untyped-def]
        return tuple(
            (a(layout, p, z, load), b(layout, p, z, load))
            for a, b in (
                (lagrangian.residual, oracle.residual),
                (lagrangian.kkt_jacobian, oracle.kkt_jacobian),
                (lagrangian.state_data, oracle.state_data),
            )
        )

    t0 = time.perf_counter()
    lowered = jax.jit(all_three).lower(p, z, load)
    lowering = time.perf_counter() - t0
    n_ops = len(jax.make_jaxpr(all_three)(p, z, load).jaxpr.eqns)
    print(f"semi-bistable assembly oracle: {n_ops} operations (outer jaxpr)")
    print(f"trace and lower: {lowering:.2f} s")
    for name, extra in VARIANTS.items():
        t0 = time.perf_counter()
        compiled = lowered.compile(compiler_options={**CHEAP_PIPELINE, **extra})
        print(f"XLA compile, {name}: {time.perf_counter() - t0:.2f} s")
    t0 = time.perf_counter()
    lowered.compile()
    print(f"XLA compile, XLA's default pipeline: {time.perf_counter() - t0:.2f} s")
    t0 = time.perf_counter()
    jax.block_until_ready(compiled(p, z, load))
    print(f"one run: {(time.perf_counter() - t0) * 1e3:.1f} ms")
    if args.eager:
        with jax.disable_jit():
            t0 = time.perf_counter()
            jax.block_until_ready(all_three(p, z, load))
            print(f"op by op, first call: {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
