"""The paper's designs.

``semi_bistable()`` is the validated design of the SI calibration table (Table calib):
R = 2 mm, l = 3.6 mm, β = 60°, N = 6, circular k = [0.9, −0.2, 0.6] N/mm² with
l_circ = [0.2, 1.3] mm, helical linear k = 1.3 N/mm²; b = 0.573 (paper: 0.58), C = 1.444.

``fully_bistable()`` is the four-module variant with both fold sets trilinear and the same
geometry, no base circular fold (7 bistable folds, MODEL.md §5 K4/§15). The paper gives no laws
for it. Two law sets (:class:`FullyBistableLaws`):

* ``PROVISIONAL`` (default): helical (2.0, −1.6, 1.0) N/mm², (0.05, 0.3) mm; circular
  (0.9, −0.37, 0.6) N/mm², (0.3, 1.3) mm.
* ``INFERRED_FIG4``: the provisional laws with the spinodal ends moved (helical 0.3 →
  0.2174 mm, circular 1.3 → 4.331 mm) by inverse design to the paper's u_z/l0 = 0.9 of the
  stable states 66 and 1B (main text, Fig. 4 B); reached: 0.915 and 0.883
  (``benchmarks/fidelity_fully_bistable.py``; docs/fidelity.md).
* ``INFERRED_FIG4_PRINTED``: for the SI's printed TPC sign (``TpcSign.AS_PRINTED``, MODEL §7),
  the lexicographically best law set of a search over both laws
  (``benchmarks/fig4_law_search.py``, :mod:`biplan.calibration.fig4_search`): helical
  (1.66889, −1.33537, 0.891484) N/mm², (0.0755721, 0.325685) mm; circular (0.372094,
  −0.343063, 0.732542) N/mm², (0.15275, 4.3167) mm. Under that sign: 42 stable states with
  00, 2A, 1B and 66 (the fewest of any searched set that keeps the four), slope levels in
  thirds, 66 and 1B at u_z/l0 = 0.930 and 0.867, Θ = −0.60 and −0.69. Without ``options``
  it is built under the readings it was fitted for (R3 ``EDGE_FIT``, ``AS_PRINTED``).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from biplan._errors import ConfigError, check_integer
from biplan.laws import LinearLaw, TrilinearLaw
from biplan.model.tube import Tube
from biplan.options import ChainAttachment, ModelOptions, TpcSign

__all__ = ["FullyBistableLaws", "fully_bistable", "semi_bistable"]


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


class FullyBistableLaws(enum.Enum):
    """Law sets of :func:`fully_bistable` (the paper gives none; module docstring)."""

    PROVISIONAL = "provisional"
    INFERRED_FIG4 = "inferred-from-fig4"
    INFERRED_FIG4_PRINTED = "inferred-from-fig4-printed"


#: (helical, circular) laws of each set: stiffness [N/mm²], transitions [mm].
_FULLY_BISTABLE_LAWS = {
    FullyBistableLaws.PROVISIONAL: (
        ((2.0, -1.6, 1.0), (0.05, 0.3)),
        ((0.9, -0.37, 0.6), (0.3, 1.3)),
    ),
    FullyBistableLaws.INFERRED_FIG4: (
        ((2.0, -1.6, 1.0), (0.05, 0.217426)),
        ((0.9, -0.37, 0.6), (0.3, 4.33087)),
    ),
    FullyBistableLaws.INFERRED_FIG4_PRINTED: (
        ((1.66889, -1.33537, 0.891484), (0.0755721, 0.325685)),
        ((0.372094, -0.343063, 0.732542), (0.15275, 4.3167)),
    ),
}
#: The TPC-sign reading each law set was inferred under (MODEL §7; None: the default).
_FITTED_SIGN = {FullyBistableLaws.INFERRED_FIG4_PRINTED: TpcSign.AS_PRINTED}
_LAW_NAMES = {
    FullyBistableLaws.PROVISIONAL: "provisional laws",
    FullyBistableLaws.INFERRED_FIG4: "laws inferred from Fig. 4",
    FullyBistableLaws.INFERRED_FIG4_PRINTED: "laws inferred from Fig. 4, printed TPC sign",
}


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


def fully_bistable(
    options: ModelOptions | None = None,
    n_modules: int = 4,
    laws: FullyBistableLaws | str = FullyBistableLaws.PROVISIONAL,
) -> Tube:
    """The fully bistable MFT (four modules, seven bistable folds) with one of the law sets
    of :class:`FullyBistableLaws` (module docstring).

    Default options: the MODEL.md readings except R3, which is ``EDGE_FIT`` (edge-fit
    stacking of the module frames; ``docs/states.md``): under it every open helical fold
    rotates the downstream tube, which is what the paper's slope hierarchy (Fig. 4 B–C)
    shows; the paper's chain (H^TPC = I, R3 ``ELEMENT``) lets only S-module openings rotate
    it. The stable states themselves do not depend on R3. ``INFERRED_FIG4_PRINTED`` without
    ``options`` also takes the printed TPC sign (``TpcSign.AS_PRINTED``) it was searched under.
    """
    n_modules = check_integer("n_modules", n_modules, low=1)
    try:
        laws = FullyBistableLaws(laws)
    except ValueError:
        valid = ", ".join(repr(k.value) for k in FullyBistableLaws)
        raise ConfigError("laws", laws, f"one of {valid}") from None
    if options is None:
        sign = _FITTED_SIGN.get(laws, TpcSign.GEOMETRIC)
        options = ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT, tpc_sign=sign)
    t = SEMI_BISTABLE_TABLE
    (k_h, w_h), (k_c, w_c) = _FULLY_BISTABLE_LAWS[laws]
    reading = options.transition_reading
    helical = TrilinearLaw.from_table(k_h, w_h, reading).require_bistable("laws.helical")
    circular = TrilinearLaw.from_table(k_c, w_c, reading).require_bistable("laws.circular")
    return Tube.uniform(
        radius=t.radius,
        pitch=t.pitch,
        helical_angle=t.helical_angle,
        n_modules=n_modules,
        helical=helical,
        circular=circular,
        base_fold=False,
        options=options,
        name=f"fully bistable MFT, {n_modules} modules ({_LAW_NAMES[laws]})",
    )
