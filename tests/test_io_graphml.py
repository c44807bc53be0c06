"""The streamed GraphML writer against networkx's: the same file, byte for byte."""

from __future__ import annotations

import copy
from pathlib import Path

import networkx as nx
import numpy as np
import pytest

from biplan.analysis.states.search import enumerate_states
from biplan.analysis.states.transitions import transition_graph
from biplan.io.graphml import write_graphml


def _networkx_file(graph: nx.Graph, path: Path) -> bytes:
    """networkx's file of ``graph`` with the writer's value rules: None left out, values of
    other types than str, int, float, bool written as their str."""
    g = copy.deepcopy(graph)
    for data in (
        [g.graph] + [d for _, d in g.nodes(data=True)] + [d for *_, d in g.edges(data=True)]
    ):
        for key, value in list(data.items()):
            if value is None:
                del data[key]
            elif not isinstance(value, str | int | float | bool):
                data[key] = str(value)
    nx.write_graphml(g, path)
    return path.read_bytes()


def _synthetic() -> nx.Graph:
    g = nx.Graph(id="g<1>", title='a "b" & c', count=3)
    g.add_node("a&b", label="x<y>", flag=True, value=0.1, n=7, f64=np.float64(2.5))
    g.add_node(3, flag=False, value=-1e-300, i64=np.int64(4), none=None)
    g.add_node("empty")
    g.add_node('q"\n\t', label="tab\there\nline", value=float("nan"))
    g.add_edge("a&b", 3, fold=1, name="helical 1", w=np.inf)
    g.add_edge(3, "empty")
    g.add_edge("empty", 'q"\n\t', fold=2, extra=(1, 2))
    return g


@pytest.mark.parametrize(
    "graph",
    [_synthetic(), nx.Graph(), nx.path_graph(3), nx.Graph(note="only a graph attribute")],
    ids=["types-and-escapes", "empty", "no-attributes", "graph-attribute"],
)
def test_the_file_networkx_writes(graph: nx.Graph, tmp_path: Path) -> None:
    ours = write_graphml(graph, tmp_path / "ours" / "g.graphml").read_bytes()
    assert ours == _networkx_file(graph, tmp_path / "nx.graphml")
    back = nx.read_graphml(tmp_path / "ours" / "g.graphml")
    assert back.number_of_nodes() == graph.number_of_nodes()
    assert back.number_of_edges() == graph.number_of_edges()


def test_a_transition_graph_as_networkx_writes_it(model4, tmp_path: Path) -> None:
    graph = transition_graph(enumerate_states(model4))
    assert graph.number_of_edges() > 0
    ours = write_graphml(graph, tmp_path / "t.graphml").read_bytes()
    assert ours == _networkx_file(graph, tmp_path / "nx.graphml")


@pytest.mark.parametrize("graph", [nx.DiGraph([(1, 2)]), nx.MultiGraph([(1, 2)])])
def test_directed_and_multigraphs_are_refused(graph: nx.Graph, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="undirected simple graphs"):
        write_graphml(graph, tmp_path / "g.graphml")
    assert not (tmp_path / "g.graphml").exists()
