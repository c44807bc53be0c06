"""Figures written to files: the one place that picks the Agg backend, saves and closes.

The drawing functions of :mod:`biplan.plot` take an ``ax`` and draw into it (in a notebook, into
the user's figure); the commands and the reproduction write PNG files through
:func:`figure_file` (a new figure, saved on success, always closed) or :func:`save` (a figure a
drawing function made).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any

#: Resolution of every PNG the commands write [dots per inch].
DPI = 300


def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` on the Agg backend: files only, no window, no display needed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save(fig: Any, file: str | Path, *, dpi: float = DPI) -> None:
    """Write ``fig`` to ``file`` (format from the suffix) and close it."""
    try:
        fig.savefig(file, dpi=dpi)
    finally:
        pyplot().close(fig)


@contextmanager
def figure_file(
    file: str | Path, *, dpi: float = DPI, **subplots: Any
) -> Iterator[tuple[Any, Any]]:
    """A new figure (constrained layout) and its axes, written to ``file`` when the block ends
    without an error, and closed in every case.

    Parameters
    ----------
    file : str or Path
        Output file; the format follows the suffix.
    dpi : float
        Resolution [dots per inch].
    **subplots
        Passed to ``plt.subplots`` (``figsize`` [in], ``nrows``, ``ncols``, …).
    """
    plt = pyplot()
    fig, axes = plt.subplots(layout="constrained", **subplots)
    try:
        yield fig, axes
        fig.savefig(file, dpi=dpi)
    finally:
        plt.close(fig)
