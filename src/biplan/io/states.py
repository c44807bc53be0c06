"""The files of a stable-state enumeration (``biplan states``), its figures aside.

* :func:`seed_store` — the chunk store of an exhaustive search in ``DIR/seeds`` (a killed
  search resumes from it), after the request's size is checked;
* :func:`write_state_files` — into ``DIR``:

  - ``states.csv`` — one row per distinct stable equilibrium
    (:data:`~biplan.analysis.states.catalogue.CSV_COLUMNS`; mm, rad, N·mm, N·mm per unit q²);
  - ``seeds.csv`` — one row per seed (:data:`SEED_COLUMNS`): its bits, the bits it reached,
    stable/unstable/failed, the state, the smallest eigenvalue, the residual, the message;
  - ``states.nc`` — the catalogue as a labelled dataset (coordinates q of every state; the
    tube's configuration in ``attrs["config"]``, read back by :mod:`biplan.io.catalogue`);
  - ``hierarchy.nc`` — slope branches, sub-branches, distributions
    (:func:`~biplan.analysis.states.hierarchy.hierarchy`, Fig. 4 C);
  - ``transitions.graphml`` — the Hamming-1 transition graph (with its barriers when
    annotated).

The figures (``transitions.png``, ``endpoint_space.png``, ``distributions.png``) are written by
:func:`biplan.plot.states.write_state_figures`.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import TYPE_CHECKING

from biplan.analysis.states import seeding
from biplan.analysis.states.catalogue import CSV_COLUMNS, Enumeration
from biplan.analysis.states.hierarchy import hierarchy
from biplan.analysis.states.labels import require_bistable_folds
from biplan.io.config import dump_config
from biplan.io.graphml import write_graphml
from biplan.io.netcdf import write_netcdf
from biplan.io.sweepstore import ChunkStore

if TYPE_CHECKING:
    import networkx as nx

    from biplan.analysis.states.catalogue import SeedOutcome, StateCatalogue
    from biplan.model.assembly import Model

__all__ = ["SEED_COLUMNS", "STATE_DATA_FILES", "seed_store", "write_state_files"]

#: The files :func:`write_state_files` writes, in order.
STATE_DATA_FILES = ("states.csv", "seeds.csv", "states.nc", "hierarchy.nc", "transitions.graphml")
#: Columns of ``seeds.csv``.
SEED_COLUMNS = (
    "seed",
    "seed_bits",
    "reached_bits",
    "outcome",
    "state",
    "min_eigenvalue",
    "residual",
    "message",
)


def seed_store(
    model: Model, out: Path, search: seeding.Search, *, confirm: bool, resume: bool
) -> ChunkStore | None:
    """The chunk store of an exhaustive search in ``out/seeds`` (None for the neighbourhood
    search, which is not streamed to disk), after the search's size is checked
    (:func:`~biplan.analysis.states.seeding.check_size`).

    Parameters
    ----------
    model : Model
    out : Path
        Output directory of the enumeration.
    search : Search
    confirm : bool
        Run an exhaustive search of more than
        :data:`~biplan.analysis.states.seeding.CONFIRM_SEEDS` seeds.
    resume : bool
        Keep the finished chunks of a killed search of the same tube.

    Raises
    ------
    ConfigError
        ``config``: a tube without bistable folds; ``model``/``search``: a search too large
        (:func:`~biplan.analysis.states.seeding.check_size`); ``out``/``--resume``: a directory
        of another run (:class:`~biplan.io.sweepstore.ChunkStore`).
    """
    n_folds = len(require_bistable_folds(model.tube, "config"))
    seeding.check_size(n_folds, model.tube.n_modules, search, confirm)
    if search is not seeding.Search.EXHAUSTIVE:
        return None
    settings = Enumeration()
    description = {
        "config": dump_config(model.tube),
        "settings": repr(settings),
        "search": search.value,
    }
    n_chunks = -(-(2**n_folds) // settings.chunk)
    return ChunkStore(out / "seeds", description, n_chunks, resume)


def write_state_files(catalogue: StateCatalogue, graph: nx.Graph, out: Path) -> list[Path]:
    """Write :data:`STATE_DATA_FILES` of a catalogue and its transition graph into ``out``
    (created); returns the paths."""
    out.mkdir(parents=True, exist_ok=True)
    files = [out / name for name in STATE_DATA_FILES]
    with open(files[0], "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(CSV_COLUMNS))
        writer.writeheader()
        writer.writerows(catalogue.rows())
    with open(files[1], "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(SEED_COLUMNS)
        w.writerows(_seed_row(s) for s in catalogue.seeds)
    ds = catalogue.to_dataset()
    ds.attrs["config"] = dump_config(catalogue.model.tube)
    write_netcdf(ds, files[2])
    write_netcdf(hierarchy(catalogue), files[3])
    write_graphml(graph, files[4])
    return files


def _seed_row(s: SeedOutcome) -> list[object]:
    """The ``seeds.csv`` row of a seed record."""
    bits = ("".join(map(str, s.seed_bits)), "".join(map(str, s.reached_bits)))
    return [s.seed, *bits, s.outcome.value, s.state or "", s.min_eigenvalue, s.residual,
            s.message]  # fmt: skip
