"""Interactive explorer pages: one self-contained HTML file per result (``biplan explore``).

* :func:`catalogue_page` — a state catalogue: transition graph, endpoint space, shapes and
  pathways, linked;
* :func:`map_page` — a force-ramp design map: the u_z/l₀ and u_r/l₀ heatmaps, each cell's ramp
  response and terminal shape;
* :func:`response_page` — a response (path, trajectory or stable-branch sweep): the
  force–displacement curve with a slider through the saved steps and the shape at each;
* :func:`write_page` — the page as one HTML file (plotly.js inline: it opens from disk with no
  network).

Figures are Plotly figures; the panels are linked by the package data script
``explorer.js``, which draws shapes from the reference mesh and per-configuration element
motions of :mod:`~biplan.plot.explorer.shapes`.
"""

from biplan.plot.explorer.catalogue import catalogue_page as catalogue_page
from biplan.plot.explorer.maps import map_page as map_page
from biplan.plot.explorer.page import Page as Page
from biplan.plot.explorer.page import PageKind as PageKind
from biplan.plot.explorer.page import write_page as write_page
from biplan.plot.explorer.response import response_page as response_page

__all__ = ["Page", "PageKind", "catalogue_page", "map_page", "response_page", "write_page"]
