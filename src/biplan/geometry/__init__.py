"""Geometry and kinematics of MFTs: planar development, modules, connectors, chain. No laws, no
energies."""

from biplan.geometry.development import Development as Development
from biplan.geometry.layout import FoldRef as FoldRef
from biplan.geometry.layout import TubeLayout as TubeLayout

__all__ = ["Development", "FoldRef", "TubeLayout"]
