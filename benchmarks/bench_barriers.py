"""Benchmark: energy barriers of the four-module fully bistable tube (constrained CI-NEB).

Times, on the stable states of ``designs.fully_bistable()`` at zero load (seeded relaxation of
the 2^7 fold-state combinations):

* one edge, cold (first call: JIT compilation or the persistent-cache load) and warm;
* every Hamming-1 edge, warm (sequential, one compiled band kernel);
* one pass of NEB forces over a band, compiled ``vmap`` versus a NumPy loop over the images
  calling the model's per-image jitted kernels (energy gradient, constraint Jacobians) and
  NumPy's pseudo-inverse — the plain baseline of the same arithmetic;
* deflation from the stable states (new equilibria, how many stable).

Run: ``.venv/bin/python benchmarks/bench_barriers.py [STATES.npz]``
"""

from __future__ import annotations

import itertools
import sys
import time
from pathlib import Path

import numpy as np

import biplan
from biplan._compile.setup import jnp
from biplan.analysis.states.barriers import NudgedElasticBand, edge_barriers, minimum_energy_path
from biplan.analysis.states.deflation import deflate

# the JAX band forces the compiled band replaced: the tests' oracle
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from jax_oracle.neb import band_forces


def stable_states(model: biplan.Model, path: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Packed states (k, n_z) and fold bits (k, n_folds) of the stable states: enumerated
    (``biplan.analysis.states.search.enumerate_states``), or read from an ``.npz`` with ``z`` and
    ``bits`` (to skip the enumeration's compilation)."""
    if path is not None:
        data = np.load(path)
        return data["z"], data["bits"].astype(int)
    from biplan.analysis.states.search import enumerate_states

    catalogue = enumerate_states(model)
    z = np.stack([s.z for s in catalogue.states])
    bits = np.array([s.bits for s in catalogue.states], dtype=int)
    return z, bits


def numpy_forces(model: biplan.Model, q: np.ndarray, spring: float) -> np.ndarray:
    """Baseline: projected gradients image by image (per-image kernels, NumPy linear algebra)."""
    ng = model.n_guides
    grads, rows_all, energies = [], [], []
    for x in q:
        grad = model.gradient(x)
        gap = model.contact_gaps(x)
        rows = np.concatenate([model.constraint_jacobian(x), -model.contact_jacobian(x)])
        rows[ng:][gap >= 1e-6] = 0.0
        mult = np.linalg.pinv(rows.T, rcond=1e-10) @ -grad
        grads.append(grad + rows.T @ mult)
        rows_all.append(rows)
        energies.append(model.energy(x))
    f = np.zeros_like(q)
    for i in range(1, len(q) - 1):
        tau = q[i + 1] - q[i - 1]
        tau -= np.linalg.pinv(rows_all[i], rcond=1e-10) @ (rows_all[i] @ tau)
        tau /= np.linalg.norm(tau)
        g = grads[i]
        dn, dp = np.linalg.norm(q[i + 1] - q[i]), np.linalg.norm(q[i] - q[i - 1])
        f[i] = -(g - (g @ tau) * tau) + spring * (dn - dp) * tau
    return f


def main() -> None:
    import sys

    model = biplan.Model(biplan.designs.fully_bistable())
    t0 = time.perf_counter()
    z, bits = stable_states(model, sys.argv[1] if len(sys.argv) > 1 else None)
    print(f"stable states: {len(z)} ({time.perf_counter() - t0:.1f} s incl. compilation)")
    pairs = [
        (i, j)
        for i, j in itertools.combinations(range(len(z)), 2)
        if int(np.sum(bits[i] != bits[j])) == 1
    ]
    print(f"Hamming-1 edges: {len(pairs)}")
    neb = NudgedElasticBand(n_images=12)
    a, b = pairs[-1]
    t0 = time.perf_counter()
    minimum_energy_path(model, z[a], z[b], neb)
    cold = time.perf_counter() - t0
    t0 = time.perf_counter()
    mep = minimum_energy_path(model, z[a], z[b], neb)
    warm = time.perf_counter() - t0
    print(f"one edge: cold {cold:.2f} s, warm {warm:.3f} s ({mep.iterations} FIRE iterations)")

    t0 = time.perf_counter()
    meps = edge_barriers(model, [(z[i], z[j]) for i, j in pairs], neb)
    total = time.perf_counter() - t0
    print(f"all {len(pairs)} edges warm: {total:.2f} s ({total / len(pairs):.3f} s per edge)")
    n_ok = sum(m.converged for m in meps)
    print(f"converged first-order saddles: {n_ok}/{len(meps)}")
    print("edge (bits as the state catalogue gives them)  barrier fw / bw [N·mm]")
    for (i, j), m in zip(pairs, meps, strict=True):
        print(
            f"  {''.join(map(str, bits[i]))} -> {''.join(map(str, bits[j]))}  "
            f"{m.barrier_forward:9.5f} {m.barrier_backward:9.5f}  n_neg={m.n_negative}  "
            f"{m.status.value}"
        )

    # per-iteration force evaluation: compiled vmap vs NumPy loop over images
    import functools

    from biplan._compile.setup import jax

    fn = jax.jit(
        functools.partial(band_forces, model.layout),
        static_argnums=(),
    )
    band = jnp.asarray(mep.q)
    args = (model.params, band, jnp.asarray(0.5), jnp.asarray(1e-6), jnp.asarray(True))
    jax.block_until_ready(fn(*args))
    reps = 50
    t0 = time.perf_counter()
    for _ in range(reps):
        jax.block_until_ready(fn(*args))
    t_vmap = (time.perf_counter() - t0) / reps
    numpy_forces(model, mep.q, 0.5)
    t0 = time.perf_counter()
    for _ in range(5):
        numpy_forces(model, mep.q, 0.5)
    t_np = (time.perf_counter() - t0) / 5
    print(
        f"NEB forces of a 12-image band: vmap {1e3 * t_vmap:.2f} ms, NumPy loop "
        f"{1e3 * t_np:.2f} ms ({t_np / t_vmap:.0f}x)"
    )

    t0 = time.perf_counter()
    res = deflate(model, z)
    print(
        f"deflation: {res.n_new} new equilibria ({res.n_stable} stable, "
        f"{res.n_inadmissible} inadmissible) from {res.n_runs} runs, "
        f"{time.perf_counter() - t0:.1f} s"
    )
    for e in res.equilibria:
        print(
            f"  E={e.energy:.4f} stable={e.stable} n_neg={e.n_negative} bits={e.bits} "
            f"partial folds={e.partial} ({e.start})"
        )


if __name__ == "__main__":
    main()
