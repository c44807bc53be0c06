"""Size and write time of the explorer page of a state catalogue (``biplan explore``).

Measures the four-module catalogue of ``biplan states`` (``tests/data/states4``: 66 states,
the page ``biplan explore`` writes) and a synthetic catalogue of the eight-module fully
bistable tube (15 bistable folds; ``--states`` fold states, default 2,000, "thousands" as the
enumeration of N = 8 gives, taken from an 11-fold subcube so that each has up to 11
single-fold neighbours): its configurations are random small
coordinates and its energies and endpoints random numbers — the page's size and the time to
write it depend on the number of states, edges and mesh points, not on the values.
Enumerating the eight-module tube itself (2¹⁵ seeds) takes hours on two cores.

    .venv/bin/python benchmarks/bench_explorer.py [--states 2000]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import networkx as nx
import numpy as np
import xarray as xr

import biplan
from biplan.plot.explorer import catalogue_page, write_page
from biplan.plot.explorer.source import explorer_page, read_explorable

ROOT = Path(__file__).resolve().parents[1]


def synthetic_catalogue(n_states: int, seed: int = 3) -> tuple[xr.Dataset, biplan.Model, nx.Graph]:
    """A catalogue-shaped dataset of ``n_states`` states of the 8-module tube and its graph."""
    rng = np.random.default_rng(seed)
    model = biplan.Model(biplan.designs.fully_bistable(n_modules=8))
    n_bits = 15
    # the first n_states codes of the subcube of the 11 lowest bits (the 4 highest closed):
    # about as many single-fold neighbours per state as a real catalogue, at most 11
    codes = np.arange(n_states)
    bits = [format(int(c), f"0{n_bits}b") for c in codes]
    names = [format(int(c), "04X") for c in codes]
    helical = [0, 2, 4, 6, 8, 10, 12, 14]  # free end first: H8 C7|8 H7 … H1
    n_open_helical = [sum(b[i] == "1" for i in helical) for b in bits]
    nq = model.n_coordinates
    q = rng.normal(0.0, 0.02, (n_states, nq))
    q[:, 3 * 8 :] = rng.uniform(0.1, 0.6, (n_states, nq - 24))
    theta = rng.normal(0.0, 0.1, n_states)
    ds = xr.Dataset(
        {
            "bits": ("state", bits),
            "label": ("state", names),
            "energy": ("state", rng.uniform(0, 10, n_states)),
            "min_eigenvalue": ("state", rng.uniform(0.1, 10, n_states)),
            "u_z": ("state", rng.uniform(0, 10, n_states)),
            "u_r": ("state", rng.normal(0, 1, n_states)),
            "theta": ("state", theta),
            "Theta": ("state", theta / np.abs(theta).max()),
            "n_open_helical": ("state", n_open_helical),
            "q": (("state", "coordinate"), q),
        },
        coords={"state": names},
        attrs={"kind": "states", "initial_length": float(model.tube.initial_length)},
    )
    graph = nx.Graph()
    for name, b in zip(names, bits, strict=True):
        graph.add_node(name, bits=b)
    index = {int(c): name for c, name in zip(codes, names, strict=True)}
    for c, name in zip(codes, names, strict=True):
        for k in range(n_bits):
            other = int(c) ^ (1 << k)
            if other > c and other in index:
                saddle = float(ds["energy"].values[names.index(name)] + rng.uniform(0.1, 2))
                graph.add_edge(name, index[other], fold_name=f"bit {k}", saddle_energy=saddle)
    return ds, model, graph


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=2000, help="at most 2048")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "n4.html"
        source = ROOT / "tests" / "data" / "states4" / "states.nc"
        t0 = time.perf_counter()
        write_page(explorer_page(read_explorable(source), source), out)
        print(
            f"N = 4, 66 states (biplan states): {out.stat().st_size / 2**20:.2f} MiB, "
            f"{time.perf_counter() - t0:.1f} s"
        )
        ds, model, graph = synthetic_catalogue(args.states)
        out = Path(tmp) / "n8.html"
        t0 = time.perf_counter()
        write_page(catalogue_page(ds, model, graph, source="synthetic"), out)
        print(
            f"N = 8, {args.states} states, {graph.number_of_edges()} edges (synthetic): "
            f"{out.stat().st_size / 2**20:.2f} MiB, {time.perf_counter() - t0:.1f} s"
        )


if __name__ == "__main__":
    main()
