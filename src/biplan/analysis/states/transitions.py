"""State-transition graph and pathways (SI "state transition diagram").

Stable states are nodes; two states are joined by an undirected edge when their fold-state bits
differ in exactly one fold (Hamming distance one). A pathway between two states is a shortest
path of the graph — by number of fold switches, or, when the edges carry energy barriers
(:func:`biplan.analysis.states.barriers.annotate_barriers`), by the total barrier climbed in the
direction of travel.

:func:`paper_pathways` finds the paper's pathways p1–p3 (:data:`PAPER_PATHWAYS`) in a graph;
:func:`pathway_steps` describes each step of a pathway (fold, barrier, departure force).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import networkx as nx
import numpy as np

from biplan._errors import ConfigError
from biplan.analysis.states.barriers import NudgedElasticBand, edge_barriers
from biplan.analysis.states.catalogue import StateCatalogue
from biplan.analysis.states.departure import DepartureStatus, departure_force
from biplan.model.assembly import Model

__all__ = [
    "PAPER_PATHWAYS",
    "PathwayStep",
    "annotate_barriers",
    "annotate_departures",
    "barrier_weight",
    "paper_pathways",
    "pathway",
    "pathway_steps",
    "transition_graph",
    "unannotated_edges",
    "without_departure",
]

#: The paper's pathways (SI transition section): p1 2A → 66, p2 2A → 1B, p3 66 → 00.
PAPER_PATHWAYS = {"p1": ("2A", "66"), "p2": ("2A", "1B"), "p3": ("66", "00")}


def transition_graph(catalogue: StateCatalogue) -> nx.Graph:
    """Graph of the stable states with Hamming-1 edges.

    Node keys are the state names; node attributes: label, bits (string), energy [N·mm], u_z,
    u_r [mm], theta [rad], Theta, n_open_helical, n_open_circular. Edge attribute ``fold``: the
    bit (0 = free end) in which the two states differ, ``fold_set``/``fold_index`` of it (the
    index from 0 at the base, :class:`~biplan.geometry.FoldRef`) and ``fold_name``, its name in
    the result files and figures (``"helical 2"``, ``"circular 1|2"``: modules from 1).
    """
    g = nx.Graph()
    for row, state in zip(catalogue.rows(), catalogue.states, strict=True):
        attrs = {k: v for k, v in row.items() if k not in ("name", "seeds")}
        g.add_node(state.name, **attrs)
    states = catalogue.states
    fold_names = [catalogue.model.layout.fold_name(f) for f in catalogue.folds]
    for i, j, bit in _single_fold_pairs([s.bits for s in states]):
        fold = catalogue.folds[bit]
        g.add_edge(
            states[i].name, states[j].name, fold=bit, fold_set=fold.set, fold_index=fold.index,
            fold_name=fold_names[bit],
        )  # fmt: skip
    return g


def _single_fold_pairs(bits: list[tuple[int, ...]]) -> list[tuple[int, int, int]]:
    """(i, j, bit) for every pair i < j of bit tuples that differ in exactly one bit, in the
    order (i, then j, then bit): each tuple's neighbours are looked up by flipping each bit of
    its integer code in the sorted codes, so the cost is O(k n log k) for k tuples of n ≤ 62
    bits, not O(k² n)."""
    if not bits:
        return []
    n = len(bits[0])
    if n > 62:  # the searches' limit (seeding.MAX_FOLDS): codes are int64
        raise ValueError(f"{n} bits: at most 62")
    weights = np.int64(1) << np.arange(n - 1, -1, -1, dtype=np.int64)
    codes = np.asarray(bits, dtype=np.int64).reshape(len(bits), n) @ weights
    order = np.argsort(codes, kind="stable")
    sorted_codes = codes[order]
    found_i, found_j, found_bit = [], [], []
    for bit in range(n):
        flipped = codes ^ weights[bit]
        lo = np.searchsorted(sorted_codes, flipped, side="left")
        hi = np.searchsorted(sorted_codes, flipped, side="right")
        count = hi - lo
        i = np.repeat(np.arange(len(codes)), count)
        start = np.repeat(lo - np.cumsum(count) + count, count)
        j = order[start + np.arange(i.size)]
        later = j > i
        found_i.append(i[later])
        found_j.append(j[later])
        found_bit.append(np.full(int(later.sum()), bit))
    i, j, b = (np.concatenate(v) for v in (found_i, found_j, found_bit))
    by = np.lexsort((b, j, i))
    return list(zip(i[by].tolist(), j[by].tolist(), b[by].tolist(), strict=True))


def barrier_weight(u: str, v: str, data: dict[str, Any], graph: nx.Graph) -> float:
    """Barrier [N·mm] climbed going from ``u`` to ``v``: E_saddle − E_u (an edge attribute)."""
    if "saddle_energy" not in data:
        raise ConfigError(
            "weight", "barrier", "a graph annotated with barriers (annotate_barriers)"
        )
    return max(float(data["saddle_energy"]) - float(graph.nodes[u]["energy"]), 0.0)


def _weight(graph: nx.Graph, weight: str | None) -> Callable[[str, str, dict], float] | None:
    if weight is None:
        return None
    if weight == "barrier":
        return lambda u, v, d: barrier_weight(u, v, d, graph)
    raise ConfigError("weight", weight, "None (fold switches) or 'barrier'")


def pathway(
    graph: nx.Graph,
    start: str,
    target: str,
    all_paths: bool = False,
    weight: str | None = None,
) -> list[str] | list[list[str]]:
    """Shortest transition pathway between two states.

    Parameters
    ----------
    graph : networkx.Graph
        From :func:`transition_graph`.
    start, target : str
        State names (hex labels, e.g. ``"2A"``).
    all_paths : bool
        Return every shortest path (a list of paths) instead of one.
    weight : {None, "barrier"}
        ``None``: fewest fold switches; ``"barrier"``: least total barrier climbed in the
        direction of travel (needs barrier attributes on the edges).

    Raises
    ------
    ConfigError
        Unknown state, or no pathway between the two (different connected components).
    """
    for name, value in (("start", start), ("target", target)):
        if value not in graph:
            raise ConfigError(name, value, f"a stable state: {', '.join(sorted(graph.nodes))}")
    w = _weight(graph, weight)
    try:
        if all_paths:
            return [list(p) for p in nx.all_shortest_paths(graph, start, target, weight=w)]
        return list(nx.shortest_path(graph, start, target, weight=w))
    except nx.NetworkXNoPath:
        raise ConfigError(
            "target", target, f"a state connected to {start} by single-fold transitions"
        ) from None


def paper_pathways(graph: nx.Graph) -> tuple[list[list[str]], list[str]]:
    """The pathways of :data:`PAPER_PATHWAYS` that ``graph`` holds (fewest fold switches)
    and their names (``"p1: 2A→66"``); those whose states are missing or not connected are
    left out."""
    paths: list[list[str]] = []
    names: list[str] = []
    for name, (a, b) in PAPER_PATHWAYS.items():
        if a in graph and b in graph:
            try:
                found = pathway(graph, a, b)
            except ConfigError:  # not connected by single-fold transitions
                continue
            paths.append([str(n) for n in found])
            names.append(f"{name}: {a}→{b}")
    return paths, names


@dataclass(frozen=True)
class PathwayStep:
    """One step of a pathway: the fold that switches and what it costs.

    Attributes
    ----------
    start, end : str
        The states (names) before and after the step.
    fold_name : str
        The fold that switches (``"helical 2"``, ``"circular 1|2"``; modules from 1).
    barrier : float
        Barrier [N·mm] climbed from ``start``: E_saddle − E_start (NaN without barriers).
    mep_status : str
        Status of the edge's minimum-energy path (``"?"`` without barriers).
    departure_force : float or None
        End force [N] at which ``start`` loses stability on a force ramp (NaN when it does
        not); None when it was not computed from ``start``.
    departure : DepartureStatus or None
        How that ramp ended (``FOUND``: at ``departure_force``); None when not computed.
    """

    start: str
    end: str
    fold_name: str
    barrier: float
    mep_status: str
    departure_force: float | None
    departure: DepartureStatus | None = None

    def departure_text(self) -> str:
        """The departure in words (empty when it was not computed): its force, or why there
        is none."""
        if self.departure_force is None:
            return ""
        if self.departure is None or self.departure is DepartureStatus.FOUND:
            return f"departure force {self.departure_force:.4g} N"
        return f"no departure force: {self.departure.message}"


def pathway_steps(graph: nx.Graph, path: Sequence[str]) -> list[PathwayStep]:
    """The steps of a pathway ``path`` (state names) of ``graph``, from the edge attributes
    :func:`annotate_barriers` stores."""
    steps = []
    for u, v in itertools.pairwise(path):
        d = graph.edges[u, v]
        ours = d.get("forward_from") == u and "departure_force" in d
        status = d.get("departure_status")
        steps.append(
            PathwayStep(
                start=u,
                end=v,
                fold_name=d["fold_name"],
                barrier=d.get("saddle_energy", math.nan) - graph.nodes[u]["energy"],
                mep_status=d.get("mep_status", "?"),
                departure_force=d["departure_force"] if ours else None,
                departure=DepartureStatus(status) if ours and status is not None else None,
            )
        )
    return steps


def without_departure(graph: nx.Graph, paths: Iterable[Sequence[str]]) -> list[tuple[str, str]]:
    """The steps (start, end) of ``paths`` whose edge has its barrier from ``start`` but no
    departure force yet (:func:`annotate_departures`), each once, in the order of the paths."""
    return [
        (u, v)
        for u, v in _steps_of(paths)
        if graph.edges[u, v].get("forward_from") == u and "departure_force" not in graph.edges[u, v]
    ]


def annotate_departures(
    graph: nx.Graph, model: Model, catalogue: StateCatalogue, steps: Iterable[tuple[str, str]]
) -> nx.Graph:
    """Store the departure of each step (start, end) on its edge (in place):
    ``departure_force`` [N] (the end force at which ``start`` loses stability on a force ramp
    toward ``end``, NaN when it does not), ``departure_status`` (a
    :class:`~biplan.analysis.states.departure.DepartureStatus` value) and
    ``departure_lands``."""
    for u, v in steps:
        dep = departure_force(model, catalogue.state(u).z, catalogue.state(v).z)
        data = graph.edges[u, v]
        data["departure_force"] = float(dep.force)
        data["departure_status"] = dep.status.value
        data["departure_lands"] = bool(dep.lands_in_target)
    return graph


def unannotated_edges(graph: nx.Graph, paths: Iterable[Sequence[str]]) -> list[tuple[str, str]]:
    """The steps (start, end) of ``paths`` whose edge carries no barrier yet, each once, in
    the order of the paths."""
    return [e for e in _steps_of(paths) if "saddle_energy" not in graph.edges[e]]


def _steps_of(paths: Iterable[Sequence[str]]) -> list[tuple[str, str]]:
    """The steps (start, end) of ``paths``, each once, in the order of the paths."""
    return list(dict.fromkeys(e for p in paths for e in itertools.pairwise(p)))


def annotate_barriers(
    graph: nx.Graph,
    model: Model,
    catalogue: StateCatalogue,
    edges: Iterable[tuple[str, str]] | None = None,
    neb: NudgedElasticBand | None = None,
    departure: bool = False,
) -> nx.Graph:
    """Compute the minimum-energy path of edges and store it on them (in place).

    Edge attributes: ``saddle_energy`` [N·mm], ``barrier_forward``/``barrier_backward``
    [N·mm] from the edge's first/second node (``forward_from`` names the first),
    ``mep_status``, ``n_negative`` (negative reduced-Hessian eigenvalues at the saddle) and,
    with ``departure=True``, ``departure_force`` [N] (the end force at which ``forward_from``
    loses stability on a force ramp, NaN when it does not), ``departure_status`` and
    ``departure_lands`` (:func:`annotate_departures`).

    Parameters
    ----------
    edges : iterable of (name, name), optional
        Default: every edge of the graph.
    """
    todo = list(graph.edges) if edges is None else [tuple(e) for e in edges]
    pairs = [(catalogue.state(u).z, catalogue.state(v).z) for u, v in todo]
    for (u, v), mep in zip(todo, edge_barriers(model, pairs, neb), strict=True):
        data = graph.edges[u, v]
        data.update(
            forward_from=u,
            saddle_energy=float(mep.saddle_energy),
            barrier_forward=float(mep.barrier_forward),
            barrier_backward=float(mep.barrier_backward),
            mep_status=mep.status.name,
            n_negative=int(mep.n_negative),
        )
        if departure:
            annotate_departures(graph, model, catalogue, [(u, v)])
    return graph
