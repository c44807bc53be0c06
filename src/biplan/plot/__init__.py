"""Plotting: the only layer that imports matplotlib.

Every function has the form ``f(result, *, ax=None, ...) -> Axes``: it draws into the given
Axes (or a new journal-column figure), returns the Axes, never calls ``show()`` and never
selects a backend.
"""

from biplan.plot.animation import animate as animate
from biplan.plot.calibration import calibration_band as calibration_band
from biplan.plot.calibration import validation_band as validation_band
from biplan.plot.cylinder import cylinder as cylinder
from biplan.plot.diagnostics import energy_by_fold_set as energy_by_fold_set
from biplan.plot.diagnostics import measured_band as measured_band
from biplan.plot.diagnostics import min_eigenvalue as min_eigenvalue
from biplan.plot.diagnostics import phase_fractions as phase_fractions
from biplan.plot.gallery import gallery as gallery
from biplan.plot.response import force_displacement as force_displacement
from biplan.plot.sensitivity import elasticities as elasticities
from biplan.plot.tube import development as development
from biplan.plot.tube import development_panels as development_panels
from biplan.plot.tube import elongation_norm as elongation_norm
from biplan.plot.tube import fold_lines as fold_lines

__all__ = [
    "animate",
    "calibration_band",
    "cylinder",
    "development",
    "development_panels",
    "elasticities",
    "elongation_norm",
    "energy_by_fold_set",
    "fold_lines",
    "force_displacement",
    "gallery",
    "measured_band",
    "min_eigenvalue",
    "phase_fractions",
    "validation_band",
]
