"""Plotting: the only layer that imports matplotlib.

Every function has the form ``f(result, *, ax=None, ...) -> Axes``: it draws into the given
Axes (or a new journal-column figure), returns the Axes, never calls ``show()`` and never
selects a backend.
"""

from biplan.plot.response import force_displacement as force_displacement
from biplan.plot.tube import cylinder as cylinder
from biplan.plot.tube import development as development
from biplan.plot.tube import elongation_norm as elongation_norm
from biplan.plot.tube import fold_lines as fold_lines

__all__ = ["cylinder", "development", "elongation_norm", "fold_lines", "force_displacement"]
