"""``biplan explore RESULT --out explorer.html``: an interactive page of a result, in one file.

RESULT is one of three kinds of result file (:func:`biplan.io.results.result_kind`, the
detection ``biplan plot`` uses):

* a state catalogue (``states.nc`` of ``biplan states``): transition graph, endpoint space,
  the selected state's tube and development, pathways between two states; the barriers of
  ``transitions.graphml`` beside it (``biplan states --barriers``) colour the edges and allow
  the least-barrier pathway;
* a force-ramp design map (``map.nc`` of ``biplan map design``): the u_z/l₀ and u_r/l₀
  heatmaps; every design's ramp response and terminal shape are computed again for the page
  (:func:`biplan.analysis.maps.ramp_curves.ramp_curves`, as long as the map itself took);
* a response (``response.nc`` of ``biplan respond``: a path, trajectory or stable-branch sweep):
  the force–displacement curve with a slider through the steps, the tube and development at
  each.

The page (:mod:`biplan.plot.explorer`) holds plotly.js, its data and its script: it opens
from disk with no server and no network. A file of another kind, an unreadable file, a
catalogue without states or a file without its tube's configuration is refused with one line
that names the file and what ``explore`` accepts, before anything is computed or written; so
is an ``--out`` that is not a writable ``.html`` file.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.markup import escape

from biplan._errors import ConfigError
from biplan.cli._checks import output_file

if TYPE_CHECKING:
    pass

__all__ = ["explore"]


def explore(
    result: Annotated[
        Path,
        typer.Argument(
            help="states.nc (biplan states), map.nc (biplan map design) or response.nc "
            "(biplan respond).",
            show_default=False,
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="The page to write (.html).")] = Path(
        "explorer.html"
    ),
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No summary.")] = False,
) -> None:
    """Write an interactive page of a result (one self-contained HTML file, works offline)."""
    from biplan.plot.explorer import write_page
    from biplan.plot.explorer.source import explorer_page, read_explorable

    output_file(out, suffixes=(".html", ".htm"))
    start = time.perf_counter()
    dataset = read_explorable(result)
    page = explorer_page(dataset, result)
    try:
        write_page(page, out)
    except OSError as err:
        raise ConfigError("--out", str(out), f"a file you can write ({err.strerror})") from None
    size = out.stat().st_size / 2**20
    Console(quiet=quiet, highlight=False).print(
        f"wrote {escape(str(out))} ({page.kind.value} page, {size:.1f} MiB, "
        f"{time.perf_counter() - start:.1f} s)"
    )
