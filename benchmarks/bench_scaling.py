"""How the core's cost grows with the number of modules N: cold start and warm step cost.

Run:  .venv/bin/python benchmarks/bench_scaling.py [--sizes 3 6 12 24 48] [--fully 4 8]
      [--oracle-max 24] [--timeout 600] [--pieces]

For each N, a fresh process with an empty JAX cache and trace store (a tube never seen):

* ``reference``: import → Model → :func:`biplan.relaxed_reference` (wall seconds, cold);
* ``first path``: the displacement-controlled arclength path to U = 0.2·N mm (through phase 1
  of the semi-bistable laws), cold, including its per-state observation;
* ``warm step``: the same path again in the same process (best of three), wall time /
  accepted states [ms]: the corrector, the per-state observation (stability) and the
  Python around them;
* the same three numbers with the whole-tube autodiff assembly (:mod:`biplan.model.oracle`)
  patched into the solvers, in the same run (the baseline; up to ``--oracle-max`` modules).

Semi-bistable: the SI Table laws and geometry with N modules on a base fold. Fully bistable:
``designs.fully_bistable(n_modules=N)`` (provisional laws). Prints one row per (design, N,
assembly) and the local/oracle ratios. ``--pieces`` instead times each piece of the
assembly under its own ``jax.jit`` at ``--sizes`` (element terms, chain term, KKT Jacobian,
oracle Jacobian, Jacobian + LU): compile seconds and run milliseconds.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

CHILD = r"""
import json, sys, time
t0 = time.perf_counter()
import numpy as np
import biplan
if {oracle}:
    from biplan.model import lagrangian, oracle as _oracle
    from biplan.analysis.maps import design_map
    for mod in (lagrangian, design_map):
        for name in ("residual", "kkt_jacobian"):
            if hasattr(mod, name):
                setattr(mod, name, getattr(_oracle, name))
    lagrangian.state_data = _oracle.state_data
n, design = {n}, "{design}"
if design == "semi":
    t = biplan.designs.semi_bistable()
    tube = biplan.Tube.uniform(radius=2.0, pitch=3.6, helical_angle=60.0, n_modules=n,
        helical=t.helical_laws[0], circular=t.circular_laws[0], base_fold=True)
else:
    tube = biplan.designs.fully_bistable(n_modules=n)
model = biplan.Model(tube)
ref = biplan.relaxed_reference(model)
t1 = time.perf_counter()
control = biplan.Control.displacement(0.2 * n)
path = biplan.trace_path(model, biplan.ArcLength(), ref, control)
t2 = time.perf_counter()
warm = []
for _ in range(3):
    t3 = time.perf_counter()
    path = biplan.trace_path(model, biplan.ArcLength(), ref, control)
    warm.append(time.perf_counter() - t3)
states = len(path.load_parameter)
from biplan.solvers.events import observe_states
z = np.stack([model.pack(*model.split(s.z)) for s in [ref]] * states)
ctl = np.asarray(control.coefficients(model))
obs = []
for _ in range(3):
    t5 = time.perf_counter()
    observe_states(model, z, ctl, path.load_parameter)
    obs.append(time.perf_counter() - t5)
print(json.dumps(dict(observe_ms=1e3 * min(obs) / states, reference=t1 - t0, path=t2 - t1, warm_ms=1e3 * min(warm) / states,
    states=states, status=path.status.name, n_unknowns=model.n_unknowns,
    peak=float(np.max(path.force)))))
"""


PIECES = r"""
import json, os, time
import numpy as np
import biplan
from biplan.model import assembly as asm, elements as E, lagrangian, oracle as _oracle
from biplan._compile.setup import jax, jnp
n = {n}
t = biplan.designs.semi_bistable()
tube = biplan.Tube.uniform(radius=2.0, pitch=3.6, helical_angle=60.0, n_modules=n,
    helical=t.helical_laws[0], circular=t.circular_laws[0], base_fold=True)
m = biplan.Model(tube); L = m.layout; p = m.params
z = jnp.asarray(np.full(m.n_unknowns, 0.01)); load = asm.Load(1.3, 0.0, 0.0).for_jax()
nq, ng = L.n_coordinates, m.n_guides
pieces = dict(
    elements=lambda zz: E.local_terms(L, p, zz[:nq], zz[nq:nq + ng], zz[nq + ng:-1]),
    chain=lambda zz: E.chain_terms(L, p.geometry, zz[:nq]),
    jacobian=lambda zz: lagrangian.kkt_jacobian(L, p, zz, load),
    oracle_jacobian=lambda zz: _oracle.kkt_jacobian(L, p, zz, load),
    jacobian_and_lu=lambda zz: jax.scipy.linalg.lu_factor(lagrangian.kkt_jacobian(L, p, zz, load)),
)
out = {{}}
for name, f in pieces.items():
    t0 = time.perf_counter(); jf = jax.jit(f); jax.block_until_ready(jf(z)); t1 = time.perf_counter()
    for _ in range(50):
        jax.block_until_ready(jf(z))
    out[name] = (t1 - t0, 1e3 * (time.perf_counter() - t1) / 50)
print(json.dumps(out))
"""


def pieces(n: int) -> dict:
    """Compile [s] and run [ms] times of the assembly's pieces, each under its own jit."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, BIPLAN_JAX_CACHE=cache, BIPLAN_TRACE_STORE="off")
        env.pop("BIPLAN_FAST_COMPILE", None)
        out = subprocess.run(
            [sys.executable, "-c", PIECES.format(n=n)],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
        return json.loads(out.stdout.strip().splitlines()[-1])


def run(n: int, design: str, oracle: bool, timeout: float) -> dict | None:
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, BIPLAN_JAX_CACHE=cache, BIPLAN_TRACE_STORE="off")
        env.pop("BIPLAN_FAST_COMPILE", None)
        code = CHILD.format(n=n, design=design, oracle=oracle)
        try:
            out = subprocess.run(
                [sys.executable, "-c", code],
                env=env,
                capture_output=True,
                text=True,
                timeout=timeout,
                check=True,
            )
        except subprocess.TimeoutExpired:
            return None
        return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[3, 6, 12, 24, 48])
    ap.add_argument("--fully", type=int, nargs="*", default=[4, 8])
    ap.add_argument("--oracle-max", type=int, default=24)
    ap.add_argument("--timeout", type=float, default=600.0)
    ap.add_argument(
        "--pieces",
        action="store_true",
        help="only time the assembly's pieces (compile s / run ms) at --sizes",
    )
    args = ap.parse_args()
    if args.pieces:
        for n in args.sizes:
            row = ", ".join(f"{k} {c:.1f} s / {r:.3f} ms" for k, (c, r) in pieces(n).items())
            print(f"N = {n}: {row}", flush=True)
        return
    head = f"{'design':6} {'N':>3} {'n_z':>5} {'assembly':8} {'ref s':>7} {'path s':>7} {'states':>6} {'warm ms/step':>12}  peak F"
    print(head)
    cases = [("semi", n) for n in args.sizes] + [("fully", n) for n in args.fully]
    for design, n in cases:
        rows = {}
        for oracle in (False, True):
            if oracle and n > args.oracle_max:
                continue
            r = run(n, design, oracle, args.timeout)
            name = "oracle" if oracle else "local"
            rows[name] = r
            if r is None:
                print(f"{design:6} {n:>3} {'':>5} {name:8} did not finish in {args.timeout:.0f} s")
                continue
            print(
                f"{design:6} {n:>3} {r['n_unknowns']:>5} {name:8} {r['reference']:7.1f} "
                f"{r['path']:7.1f} {r['states']:>6} {r['warm_ms']:12.2f}  {r['peak']:.6f} "
                f"{r['status']}  (observation {r['observe_ms']:.2f} ms/state)",
                flush=True,
            )
        if rows.get("local") and rows.get("oracle"):
            lo, orc = rows["local"], rows["oracle"]
            print(
                f"{'':6} {n:>3} ratio oracle/local: cold {(orc['reference'] + orc['path']) / (lo['reference'] + lo['path']):.2f}x, "
                f"warm step {orc['warm_ms'] / lo['warm_ms']:.2f}x",
                flush=True,
            )


if __name__ == "__main__":
    main()
