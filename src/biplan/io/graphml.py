"""GraphML files of transition graphs, written without an XML tree.

:func:`write_graphml` writes the file that ``networkx.write_graphml`` writes for the same
graph, byte for byte (``tests/test_io_graphml.py``): the same keys (``d0``, ``d1``, … in the
order networkx creates them, listed newest first), types (``string``, ``long``, ``double``,
``boolean``; ``float`` for a NumPy float64), escaping and indentation. networkx builds the whole
document as an XML element tree, indents it and serialises it: 1.9–2.1 s for the 7,986 states
and 46,343 edges of the eight-module fully bistable tube, against 0.25–0.34 s here, where each
node and edge is formatted once (``benchmarks/bench_state_files.py``; the ten-module graph,
165 MB, takes about 4 s).

Attribute values that GraphML cannot hold are written as their ``str`` (a string attribute);
``None`` values are left out.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import networkx as nx
import numpy as np

__all__ = ["write_graphml"]

_HEAD = (
    "<?xml version='1.0' encoding='utf-8'?>\n"
    '<graphml xmlns="http://graphml.graphdrawing.org/xmlns" '
    'xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" '
    'xsi:schemaLocation="http://graphml.graphdrawing.org/xmlns '
    'http://graphml.graphdrawing.org/xmlns/1.0/graphml.xsd">\n'
)
#: GraphML type of each Python type a value keeps (networkx's table; others become strings).
_TYPES: dict[type, str] = {
    str: "string",
    int: "long",
    float: "double",
    bool: "boolean",
    np.float64: "float",
}
_BATCH = 4096


def _attribute(text: str) -> str:
    """``text`` escaped for an XML attribute value (as ElementTree escapes it)."""
    for char, entity in (("&", "&amp;"), ("<", "&lt;"), (">", "&gt;"), ('"', "&quot;")):
        if char in text:
            text = text.replace(char, entity)
    for char, entity in (("\r", "&#13;"), ("\n", "&#10;"), ("\t", "&#09;")):
        if char in text:
            text = text.replace(char, entity)
    return text


def _text(text: str) -> str:
    """``text`` escaped for XML character data (as ElementTree escapes it)."""
    for char, entity in (("&", "&amp;"), ("<", "&lt;"), (">", "&gt;")):
        if char in text:
            text = text.replace(char, entity)
    return text


def _items(data: dict[Any, Any]) -> Iterator[tuple[str, str, Any]]:
    """(name, GraphML type, value) of the attributes that are written."""
    for key, value in data.items():
        if value is None:
            continue
        kind = _TYPES.get(type(value))
        if kind is None:
            value, kind = str(value), "string"
        yield str(key), kind, value


class _Keys:
    """The ``<key>`` declarations, created in networkx's order: graph, nodes, edges."""

    def __init__(self) -> None:
        self.ids: dict[tuple[str, str, str], str] = {}

    def id(self, name: str, kind: str, scope: str) -> str:
        key = (name, kind, scope)
        if key not in self.ids:
            self.ids[key] = f"d{len(self.ids)}"
        return self.ids[key]

    def lines(self) -> str:
        return "".join(
            f'  <key id="{i}" for="{scope}" attr.name="{_attribute(name)}" attr.type="{kind}" />\n'
            for (name, kind, scope), i in reversed(self.ids.items())
        )


def _element(tag: str, head: str, data: dict[Any, Any], keys: _Keys) -> str:
    """One node or edge with its ``<data>`` children, as networkx indents it."""
    items = [
        f'      <data key="{keys.id(name, kind, tag)}">{_text(str(value))}</data>\n'
        for name, kind, value in _items(data)
    ]
    if not items:
        return f"    <{tag} {head} />\n"
    return f"    <{tag} {head}>\n{''.join(items)}    </{tag}>\n"


def _bodies(graph: nx.Graph, keys: _Keys) -> Iterator[str]:
    """The nodes, then the edges, formatted (declaring their keys on the way)."""
    for node, data in graph.nodes(data=True):
        yield _element("node", f'id="{_attribute(str(node))}"', data, keys)
    for u, v, data in graph.edges(data=True):
        head = f'source="{_attribute(str(u))}" target="{_attribute(str(v))}"'
        yield _element("edge", head, data, keys)


def _batches(lines: Iterable[str]) -> Iterator[str]:
    batch: list[str] = []
    for line in lines:
        batch.append(line)
        if len(batch) == _BATCH:
            yield "".join(batch)
            batch = []
    if batch:
        yield "".join(batch)


def write_graphml(graph: nx.Graph, path: str | Path) -> Path:
    """Write an undirected simple graph to GraphML (module docstring); returns the path.

    The folder is created. Raises ValueError for a directed graph or a multigraph, and for
    networkx's ``node_default``/``edge_default`` graph attributes (key defaults), which
    this writer does not write.
    """
    if graph.is_directed() or graph.is_multigraph():
        raise ValueError("write_graphml writes undirected simple graphs (nx.Graph)")
    reserved = {"node_default", "edge_default"} & set(graph.graph)
    if reserved:
        raise ValueError(f"graph attributes {sorted(reserved)} are not written by write_graphml")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    keys = _Keys()
    graph_data = {k: v for k, v in graph.graph.items() if k != "id"}
    graph_id = graph.graph.get("id")
    head = 'edgedefault="undirected"' + (
        f' id="{_attribute(str(graph_id))}"' if graph_id is not None else ""
    )
    closing = "".join(  # declared first, written last (as networkx appends them)
        f'    <data key="{keys.id(n, k, "graph")}">{_text(str(v))}</data>\n'
        for n, k, v in _items(graph_data)
    )
    bodies = list(_batches(_bodies(graph, keys)))  # declares the keys, which head the file
    with out.open("w", encoding="utf-8", newline="\n") as fh:
        fh.write(_HEAD + keys.lines())
        if not (closing or bodies):
            fh.write(f"  <graph {head} />\n</graphml>\n")
            return out
        fh.write(f"  <graph {head}>\n")
        fh.writelines(bodies)
        fh.write(f"{closing}  </graph>\n</graphml>\n")
    return out
