"""Analysis: stability, state enumeration, transition graphs, sweeps, calibration."""

from biplan.analysis.stability import Stability as Stability
from biplan.analysis.stability import Verdict as Verdict
from biplan.analysis.stability import classify as classify
from biplan.analysis.stability import reduced_hessian as reduced_hessian

__all__ = ["Stability", "Verdict", "classify", "reduced_hessian"]
