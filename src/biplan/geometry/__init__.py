"""Geometry and kinematics of MFTs: planar development, modules, connectors, chain. No energies."""

from biplan.geometry.development import Development as Development
from biplan.geometry.tube import FoldRef as FoldRef
from biplan.geometry.tube import Tube as Tube
from biplan.geometry.tube import TubeLayout as TubeLayout

__all__ = ["Development", "FoldRef", "Tube", "TubeLayout"]
