"""biplan — BiPlan reduced-order simulation of multistable Mixed Folded Tubes (MFTs).

Units throughout: mm, N, s (mass in t = 10³ kg, so that N = t·mm/s²); angles of the public
API in degrees, internal rotations in radians.

Quick start::

    import biplan
    tube = biplan.designs.semi_bistable()
    model = biplan.Model(tube)
    ref = biplan.relaxed_reference(model)
    sol = biplan.solve_equilibrium(model, biplan.Newton(), ref, biplan.Load.of_displacement(1.0))
    print(sol.force, biplan.classify(model, sol).verdict)
"""

from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from biplan import designs as designs
    from biplan._errors import BiplanError as BiplanError
    from biplan._errors import ConfigError as ConfigError
    from biplan._errors import ConvergenceError as ConvergenceError
    from biplan._errors import CostWarning as CostWarning
    from biplan.analysis.sensitivity.equilibrium import Sensitivity as Sensitivity
    from biplan.analysis.sensitivity.equilibrium import sensitivity as sensitivity
    from biplan.analysis.sensitivity.limit_point import (
        limit_point_sensitivity as limit_point_sensitivity,
    )
    from biplan.analysis.stability import Stability as Stability
    from biplan.analysis.stability import Verdict as Verdict
    from biplan.analysis.stability import classify as classify
    from biplan.analysis.stability import reduced_hessian as reduced_hessian
    from biplan.geometry import Development as Development
    from biplan.geometry import FoldRef as FoldRef
    from biplan.io.config import load_config as load_config
    from biplan.laws import LinearLaw as LinearLaw
    from biplan.laws import TrilinearLaw as TrilinearLaw
    from biplan.model.assembly import Load as Load
    from biplan.model.assembly import Model as Model
    from biplan.model.tube import Tube as Tube
    from biplan.options import ModelOptions as ModelOptions
    from biplan.options import TransitionReading as TransitionReading
    from biplan.solvers import ArcLength as ArcLength
    from biplan.solvers import Control as Control
    from biplan.solvers import EquilibriumPath as EquilibriumPath
    from biplan.solvers import GeneralizedAlpha as GeneralizedAlpha
    from biplan.solvers import LoadHistory as LoadHistory
    from biplan.solvers import LoadStepping as LoadStepping
    from biplan.solvers import Newton as Newton
    from biplan.solvers import PathStatus as PathStatus
    from biplan.solvers import Solution as Solution
    from biplan.solvers import Status as Status
    from biplan.solvers import Trajectory as Trajectory
    from biplan.solvers import TrajectoryStatus as TrajectoryStatus
    from biplan.solvers import integrate as integrate
    from biplan.solvers import relaxed_reference as relaxed_reference
    from biplan.solvers import solve_equilibrium as solve_equilibrium
    from biplan.solvers import trace_path as trace_path

#: Public name → the module that defines it. Imported on first access (PEP 562), so that
#: ``import biplan`` loads neither JAX nor the model and sets no process-wide state; the JAX
#: set-up (:func:`biplan._compile.setup.configure`) runs when the numerical core is first imported.
_EXPORTS = {
    "BiplanError": "biplan._errors",
    "ConfigError": "biplan._errors",
    "ConvergenceError": "biplan._errors",
    "CostWarning": "biplan._errors",
    "limit_point_sensitivity": "biplan.analysis.sensitivity.limit_point",
    "Sensitivity": "biplan.analysis.sensitivity.equilibrium",
    "sensitivity": "biplan.analysis.sensitivity.equilibrium",
    "Stability": "biplan.analysis.stability",
    "Verdict": "biplan.analysis.stability",
    "classify": "biplan.analysis.stability",
    "reduced_hessian": "biplan.analysis.stability",
    "Load": "biplan.model.assembly",
    "Model": "biplan.model.assembly",
    "Development": "biplan.geometry",
    "FoldRef": "biplan.geometry",
    "Tube": "biplan.model.tube",
    "load_config": "biplan.io.config",
    "LinearLaw": "biplan.laws",
    "TransitionReading": "biplan.options",
    "TrilinearLaw": "biplan.laws",
    "ModelOptions": "biplan.options",
    "ArcLength": "biplan.solvers",
    "Control": "biplan.solvers",
    "GeneralizedAlpha": "biplan.solvers",
    "LoadHistory": "biplan.solvers",
    "LoadStepping": "biplan.solvers",
    "Newton": "biplan.solvers",
    "EquilibriumPath": "biplan.solvers",
    "PathStatus": "biplan.solvers",
    "Solution": "biplan.solvers",
    "Status": "biplan.solvers",
    "Trajectory": "biplan.solvers",
    "TrajectoryStatus": "biplan.solvers",
    "integrate": "biplan.solvers",
    "relaxed_reference": "biplan.solvers",
    "solve_equilibrium": "biplan.solvers",
    "trace_path": "biplan.solvers",
}


def __getattr__(name: str) -> Any:
    if name == "designs":
        return import_module("biplan.designs")
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'biplan' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)


try:
    __version__ = version("biplan")
except PackageNotFoundError:  # pragma: no cover
    __version__ = "0.0.0+unknown"

__all__ = [
    "ArcLength",
    "BiplanError",
    "ConfigError",
    "Control",
    "ConvergenceError",
    "CostWarning",
    "Development",
    "EquilibriumPath",
    "FoldRef",
    "GeneralizedAlpha",
    "LinearLaw",
    "Load",
    "LoadHistory",
    "LoadStepping",
    "Model",
    "ModelOptions",
    "Newton",
    "PathStatus",
    "Sensitivity",
    "Solution",
    "Stability",
    "Status",
    "Trajectory",
    "TrajectoryStatus",
    "TransitionReading",
    "TrilinearLaw",
    "Tube",
    "Verdict",
    "__version__",
    "classify",
    "designs",
    "integrate",
    "limit_point_sensitivity",
    "load_config",
    "reduced_hessian",
    "relaxed_reference",
    "sensitivity",
    "solve_equilibrium",
    "trace_path",
]
