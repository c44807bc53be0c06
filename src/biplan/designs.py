"""The paper's designs.

``semi_bistable()`` is the validated design of the SI calibration table (Table calib):
R = 2 mm, l = 3.6 mm, β = 60°, N = 6, circular k = [0.9, −0.2, 0.6] N/mm² with
l_circ = [0.2, 1.3] mm, helical linear k = 1.3 N/mm²; b = 0.573 (paper: 0.58), C = 1.444.

``fully_bistable()`` is the four-module variant with both fold sets trilinear and the same
geometry, no base circular fold (7 bistable folds, MODEL.md §5 K4/§15). The paper gives no laws
for it; these are provisional (issue "stable states"):
helical (2.0, −1.6, 1.0) N/mm², (0.05, 0.3) mm; circular (0.9, −0.37, 0.6) N/mm², (0.3, 1.3) mm.
"""

from __future__ import annotations

from dataclasses import dataclass

from biplan._errors import check_integer
from biplan.geometry import Tube
from biplan.laws import LinearLaw, TrilinearLaw
from biplan.options import ChainAttachment, ModelOptions

__all__ = ["fully_bistable", "semi_bistable"]


@dataclass(frozen=True)
class CalibrationTable:
    """SI Table calib: geometry [mm, deg] and laws [N/mm², mm] of the validated design."""

    radius: float = 2.0
    pitch: float = 3.6
    helical_angle: float = 60.0
    n_modules: int = 6
    circular_stiffness: tuple[float, float, float] = (0.9, -0.2, 0.6)
    circular_transitions: tuple[float, float] = (0.2, 1.3)
    helical_stiffness: float = 1.3


#: Table calib of the SI.
SEMI_BISTABLE_TABLE = CalibrationTable()


def semi_bistable(options: ModelOptions | None = None) -> Tube:
    """The validated semi-bistable MFT (SI Table calib), under the given readings."""
    options = options or ModelOptions()
    t = SEMI_BISTABLE_TABLE
    circular = TrilinearLaw.from_table(
        t.circular_stiffness, t.circular_transitions, options.transition_reading
    ).require_bistable("laws.circular")
    return Tube.uniform(
        radius=t.radius,
        pitch=t.pitch,
        helical_angle=t.helical_angle,
        n_modules=t.n_modules,
        helical=LinearLaw(t.helical_stiffness),
        circular=circular,
        base_fold=True,
        options=options,
        name="semi-bistable MFT (SI Table calib)",
    )


def fully_bistable(options: ModelOptions | None = None, n_modules: int = 4) -> Tube:
    """The fully bistable MFT (four modules, seven bistable folds) with provisional laws.

    Default options: the MODEL.md readings except R3, which is ``EDGE_FIT`` (edge-fit
    stacking of the module frames; ``docs/states.md``): under it every open helical fold
    rotates the downstream tube, which is what the paper's slope hierarchy (Fig. 4 B–C)
    shows; the paper's chain (H^TPC = I, R3 ``ELEMENT``) lets only S-module openings rotate
    it. The stable states themselves do not depend on R3.
    """
    n_modules = check_integer("n_modules", n_modules, low=1)
    options = options or ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT)
    t = SEMI_BISTABLE_TABLE
    helical = TrilinearLaw.from_table(
        (2.0, -1.6, 1.0), (0.05, 0.3), options.transition_reading
    ).require_bistable("laws.helical")
    circular = TrilinearLaw.from_table(
        (0.9, -0.37, 0.6), (0.3, 1.3), options.transition_reading
    ).require_bistable("laws.circular")
    return Tube.uniform(
        radius=t.radius,
        pitch=t.pitch,
        helical_angle=t.helical_angle,
        n_modules=n_modules,
        helical=helical,
        circular=circular,
        base_fold=False,
        options=options,
        name=f"fully bistable MFT, {n_modules} modules (provisional laws)",
    )
