"""One self-contained HTML page: plotly.js, the figures, the data and the linking script.

A :class:`Page` is what a builder (:mod:`~biplan.plot.explorer.catalogue`,
:mod:`~biplan.plot.explorer.maps`, :mod:`~biplan.plot.explorer.response`) produces: its kind,
title, the Plotly figures of its panels (by the id of the ``div`` they are drawn in), the data
the script needs (shapes, states, curves) and the HTML of its panels. :meth:`Page.html` puts
them into one document with the full plotly.js bundle inline (from the ``plotly`` package),
so the file opens from disk with no server and no network. The linking script
(``explorer.js``) and the style sheet (``explorer.css``) are package data files beside this
module; the script reads the figures and the data from two JSON ``<script>`` blocks.
"""

from __future__ import annotations

import enum
import html
import json
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

__all__ = ["Page", "PageKind", "panel", "shape_panels", "write_page"]


class PageKind(enum.StrEnum):
    """The three kinds of explorer page."""

    catalogue = "catalogue"
    design_map = "design map"
    response = "response"


def _asset(name: str) -> str:
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


def _script_json(value: Any) -> str:
    """JSON safe inside a ``<script>`` element (no ``</``)."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")


def panel(div: str, heading: str, *, note: str = "", wide: bool = False) -> str:
    """HTML of one panel: a heading, an optional note and the ``div`` a figure is drawn in."""
    cls = "panel wide" if wide else "panel"
    text = f'<p class="note">{html.escape(note)}</p>' if note else ""
    return (
        f'<section class="{cls}" id="panel-{div}"><h2>{html.escape(heading)}</h2>{text}'
        f'<div class="plot" id="{div}"></div></section>'
    )


def shape_panels() -> str:
    """HTML of the shape panels every page shares: a title, a table of values, the 3D tube
    (``tube``) and the planar development (``development``)."""
    return (
        '<section class="panel wide" id="panel-shape">'
        '<h2 id="shape-title">shape</h2><div id="shape-info"></div>'
        '<div class="shape-row"><div class="plot" id="tube"></div>'
        '<div class="plot" id="development"></div></div></section>'
    )


@dataclass(frozen=True)
class Page:
    """An explorer page before it is written.

    Attributes
    ----------
    kind : PageKind
    title : str
        Title of the document and its heading.
    subtitle : str
        One line under the heading (the source file, counts).
    body : str
        HTML of the panels and controls.
    figures : dict
        Plotly figures (``plotly.graph_objects.Figure``) by the id of their ``div``.
    data : dict
        JSON-serialisable data for the script (``data.kind`` is the page kind).
    """

    kind: PageKind
    title: str
    subtitle: str
    body: str
    figures: dict[str, Any] = field(default_factory=dict)
    data: dict[str, Any] = field(default_factory=dict)

    def html(self) -> str:
        """The whole document (plotly.js inline: several MB)."""
        from plotly.offline import get_plotlyjs

        figures = {k: json.loads(f.to_json()) for k, f in self.figures.items()}
        data = {**self.data, "kind": self.kind.value}
        return "\n".join(
            [
                "<!DOCTYPE html>",
                '<html lang="en"><head><meta charset="utf-8">',
                f"<title>{html.escape(self.title)}</title>",
                f"<style>{_asset('explorer.css')}</style>",
                f"<script>{get_plotlyjs()}</script>",
                "</head><body>",
                f"<header><h1>{html.escape(self.title)}</h1>",
                f'<p class="subtitle">{html.escape(self.subtitle)}</p></header>',
                f"<main>{self.body}</main>",
                f'<script type="application/json" id="biplan-figures">{_script_json(figures)}'
                "</script>",
                f'<script type="application/json" id="biplan-data">{_script_json(data)}</script>',
                f"<script>{_asset('explorer.js')}</script>",
                "</body></html>",
            ]
        )


def write_page(page: Page, path: str | Path) -> Path:
    """Write ``page`` to ``path`` (UTF-8); returns the path."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(page.html(), encoding="utf-8")
    return out
