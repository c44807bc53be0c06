"""What a state search spends on files: the chunk store and the transition graph.

* **Chunk store** (``biplan.io.sweepstore.ChunkStore.save``): one finished chunk of the
  ten-module fully bistable search (128 seeds: z, outcomes, observables), written as a NumPy
  archive, against the same chunk written as a netCDF file by xarray (the format the store
  wrote before), in the same process.
* **GraphML** (``biplan.io.graphml.write_graphml``): the transition graph of the fully
  bistable tube of ``--modules`` modules, written by the streamed writer against
  ``networkx.write_graphml`` (the baseline), the same file byte for byte.

* **After the search** (``--run DIR --config TOML``): the stages of ``biplan states`` after
  the seeds, on the finished chunks of an earlier run in ``DIR`` (``DIR/seeds``): the catalogue
  of every seed (``enumerate_states`` on the loaded chunks, their loading apart), the
  transition graph, the data files and the figures, written to ``DIR/bench``.

Run:  .venv/bin/python benchmarks/bench_state_files.py [--modules 8] [--repeats 20]
      .venv/bin/python benchmarks/bench_state_files.py --run states10 --config fb10.toml
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import networkx as nx
import numpy as np

import biplan
from biplan.analysis.states.search import enumerate_states
from biplan.analysis.states.transitions import transition_graph
from biplan.io.graphml import write_graphml
from biplan.io.netcdf import write_netcdf
from biplan.io.sweepstore import ChunkStore


def _chunk() -> dict[str, np.ndarray]:
    """Arrays of the shapes of one N = 10 chunk (:func:`biplan.analysis.states.seeding.evaluate`)."""
    rng = np.random.default_rng(0)
    k = 128
    return {
        "seed": np.arange(k, dtype=np.int64),
        "z": rng.standard_normal((k, 102)),
        "status": np.zeros(k, dtype=np.int64),
        "residual": rng.random(k),
        "reached": rng.integers(0, 2, (k, 19)),
        "min_eigenvalue": rng.random(k),
        "energy": rng.random(k),
        "u_z": rng.random(k),
        "u_r": rng.random(k),
        "theta": rng.random(k),
        "phase_fraction": rng.random((k, 29, 3)),
    }


def _netcdf_chunk(result: dict[str, np.ndarray], path: Path) -> None:
    import xarray as xr

    dims = {n: ("point", *(f"{n}_{k}" for k in range(1, a.ndim))) for n, a in result.items()}
    write_netcdf(xr.Dataset({n: (dims[n], a) for n, a in result.items()}), path)


def _best(fn, repeats: int) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times), statistics.median(times)


def after_search(run: Path, config: Path) -> None:
    """Time the stages of ``biplan states`` after the seeds, on a finished run's chunks."""
    from biplan.analysis.states import seeding
    from biplan.analysis.states.search import enumerate_states
    from biplan.io.states import seed_store, write_state_files
    from biplan.plot.states import write_state_figures

    model = biplan.Model(biplan.load_config(config))
    t0 = time.perf_counter()
    sink = seed_store(model, run, seeding.Search.EXHAUSTIVE, confirm=True, resume=True)
    loaded = time.perf_counter() - t0
    if sink is None or sink.reused < sink.n_chunks:
        raise SystemExit(f"{run}/seeds does not hold a finished exhaustive search of {config}")
    t0 = time.perf_counter()
    catalogue = enumerate_states(model, sink=sink, confirm=True)
    stages = {"chunks loaded": loaded, "catalogue": time.perf_counter() - t0}
    z = np.concatenate([sink.load(c)["z"] for c in range(sink.n_chunks)])
    t0 = time.perf_counter()
    seeding.merge_rows(z[:, : model.layout.n_coordinates], np.isfinite(z).all(axis=1), 1e-5)
    stages["merge of the seeds (part of the catalogue)"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    graph = transition_graph(catalogue)
    stages["transition graph"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    write_state_files(catalogue, graph, run / "bench")
    stages["data files"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    write_state_figures(catalogue, graph, run / "bench")
    stages["figures"] = time.perf_counter() - t0
    print(f"{len(catalogue)} states from {len(catalogue.seeds)} seeds")
    for name, seconds in stages.items():
        print(f"  {name:44s} {seconds:6.2f} s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modules", type=int, default=8, help="fully bistable modules (graph)")
    parser.add_argument("--repeats", type=int, default=20, help="chunk writes of each kind")
    parser.add_argument("--run", type=Path, help="a finished `biplan states` output directory")
    parser.add_argument("--config", type=Path, help="its tube configuration (TOML)")
    args = parser.parse_args()
    if args.run is not None or args.config is not None:
        if args.run is None or args.config is None:
            parser.error("--run and --config go together")
        after_search(args.run, args.config)
        return
    result = _chunk()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        store = ChunkStore(folder / "store", {"bench": 1}, args.repeats + 1, resume=False)
        counter = iter(range(10**9))
        npz = _best(lambda: store.save(next(counter), result), args.repeats)
        ncdf = _best(lambda: _netcdf_chunk(result, folder / "chunk.nc"), args.repeats)
        print(
            f"chunk of 128 seeds (N = 10): archive {npz[0] * 1e3:.2f} ms best, "
            f"{npz[1] * 1e3:.2f} median; netCDF {ncdf[0] * 1e3:.1f} ms best, "
            f"{ncdf[1] * 1e3:.1f} median; ratio {ncdf[1] / npz[1]:.0f}x"
        )
        t0 = time.perf_counter()
        graph = transition_graph(
            enumerate_states(biplan.Model(biplan.designs.fully_bistable(n_modules=args.modules)))
        )
        print(
            f"N = {args.modules}: {graph.number_of_nodes()} states, "
            f"{graph.number_of_edges()} edges ({time.perf_counter() - t0:.1f} s to enumerate)"
        )
        for _ in range(2):
            t0 = time.perf_counter()
            ours = write_graphml(graph, folder / "ours.graphml")
            t_ours = time.perf_counter() - t0
            t0 = time.perf_counter()
            nx.write_graphml(graph, folder / "nx.graphml")
            t_nx = time.perf_counter() - t0
            same = ours.read_bytes() == (folder / "nx.graphml").read_bytes()
            print(
                f"GraphML ({ours.stat().st_size / 1e6:.1f} MB): streamed {t_ours:.2f} s, "
                f"networkx {t_nx:.2f} s, ratio {t_nx / t_ours:.1f}x, same bytes: {same}"
            )


if __name__ == "__main__":
    main()
