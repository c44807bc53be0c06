"""Fold laws: one fold's constitutive law versus its local elongation w (mm)."""

from biplan.laws.linear import LinearLaw as LinearLaw
from biplan.laws.trilinear import TrilinearLaw as TrilinearLaw

FoldLaw = TrilinearLaw | LinearLaw

__all__ = ["FoldLaw", "LinearLaw", "TrilinearLaw"]
