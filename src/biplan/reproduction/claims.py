"""The paper's claims, each assessed from computed results (``biplan reproduce``).

Every quantitative or qualitative claim of the paper that the model can speak to is a
:class:`Claim` of :data:`CLAIMS`: an id, the figure and section it belongs to, the paper's words
(paraphrased) and a check function that reads the computed
:class:`~biplan.reproduction.facts.Results` and returns a
:class:`~biplan.reproduction.grading.Finding` — our number or observation, a verdict and the
reason. The check functions live one module per table of the report:
:mod:`~biplan.reproduction.checks_fig3`, :mod:`~biplan.reproduction.checks_fig4` and
:mod:`~biplan.reproduction.checks_si`; their verdicts are never typed
(:mod:`biplan.reproduction.grading`). :func:`biplan.reproduction.report.assess` runs them and
:func:`~biplan.reproduction.report.report_markdown` renders the report.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from biplan.reproduction import checks_fig3 as fig3
from biplan.reproduction import checks_fig4 as fig4
from biplan.reproduction import checks_si as si
from biplan.reproduction.facts import Results
from biplan.reproduction.grading import Finding

__all__ = ["CLAIMS", "FIGURES", "Claim"]


@dataclass(frozen=True)
class Claim:
    """One claim of the paper.

    Attributes
    ----------
    id : str
        Short identifier (``fig3.A1.extension``).
    figure : str
        Key of :data:`FIGURES` whose table lists it.
    section : str
        Where the paper says it.
    paper : str
        The paper's words, paraphrased.
    needs : tuple of str
        The :class:`Results` fields it reads.
    check : callable
        ``Results -> Finding``.
    """

    id: str
    figure: str
    section: str
    paper: str
    needs: tuple[str, ...]
    check: Callable[[Results], Finding]


#: Figure keys → title of the table in the report.
FIGURES = {
    "fig3": "Fig. 3 — semi-bistable MFT (validated design, design and stability maps)",
    "fig4": "Fig. 4 — fully bistable MFT (states, transitions, hierarchy)",
    "si": "Supplement — distributions, CFT calibration, Movie S1",
}

_MAIN3 = "Main, Semi-bistable MFT"
_MAIN4 = "Main, Hierarchical state space"
CLAIMS: tuple[Claim, ...] = (
    Claim("fig3.design", "fig3", "Main Fig. 3; SI Table calib",
          "The validated semi-bistable design has b ≈ 0.58 (stability map at b = 0.58) and "
          "the stiffness ratio C of Table calib.", ("semi",), fig3.design_ratios),
    Claim("fig3.A2.phases", "fig3", _MAIN3 + " (Fig. 3 A.2)",
          "The response is a transition between two stable phases through an intermediate "
          "spinodal regime with loss of tangent stiffness.", ("semi",), fig3.two_phases),
    Claim("fig3.A2.within_ramp", "fig3", _MAIN3 + "; SI Design maps",
          "The phase transformation happens within the 0.8 N/s × 2 s force ramp (1.6 N).",
          ("semi",), fig3.within_ramp),
    Claim("fig3.distributed", "fig3", _MAIN3 + " (closing paragraph)",
          "Coupling to the monostable helical folds distributes the phase transformation "
          "along the tube (compliant, not fold by fold).", ("semi",), fig3.distributed),
    Claim("fig3.B1.eccentric", "fig3", _MAIN3 + " (Fig. 3 B.1)",
          "In phase 1 the circular folds extend non-uniformly around the circumference, "
          "driving global eccentric bending.", ("semi",), fig3.eccentric_bending),
    Claim("fig3.B.modes", "fig3", _MAIN3 + " (Fig. 3 B.1–B.3)",
          "Bending dominates in the spinodal regime (B.2); phase 2 restores dominant "
          "extension (B.3).", ("semi",), fig3.snapshot_modes),
    Claim("fig3.A1.extension", "fig3", _MAIN3 + " (Fig. 3 A.1 top)",
          "Extension is largest at low b and low C; the contours are oblique.",
          ("design_map",), fig3.extension_trend),
    Claim("fig3.A1.deflection", "fig3", _MAIN3 + " (Fig. 3 A.1 bottom)",
          "Radial deflection is largest at low b and C and smallest at high C and "
          "intermediate b.", ("design_map",), fig3.deflection_trend),
    Claim("fig3.A1.star", "fig3", _MAIN3 + " (Fig. 3 A.1)",
          "A star marks the experimentally validated design on the maps.",
          ("design_map", "semi"), fig3.star),
    Claim("fig3.A3.regimes", "fig3", _MAIN3 + " (Fig. 3 A.3)",
          "At b = 0.58: monostable at small displacement and high C, multistable at large "
          "displacement and low C, separated by a transition region.",
          ("stability_map",), fig3.stability_regimes),
    Claim("fig3.A2.band", "fig3", _MAIN3 + " (Fig. 3 A.2)",
          "The predicted force–displacement curve stays within the measured ± 1 SD band over "
          "most of the range.", ("validation",), fig3.within_band),
    Claim("fig4.count", "fig4", "SI S11 (transition diagram)",
          "The 128 seeds of the four-module tube yield 34 stable equilibria.",
          ("states",), fig4.state_count),
    Claim("fig4.A.named", "fig4", _MAIN4 + " (Fig. 4 A)",
          "States 00, 2A, 1B and 66 are stable.", ("states",), fig4.named_states),
    Claim("fig4.B.shared_branch", "fig4", _MAIN4 + " (Fig. 4 B)",
          "66 and 1B lie on the Θ ≈ 0.67 slope branch, in one iso-elongation sub-branch "
          "(u_z/l0 = 0.9), with 1B deflecting more.", ("states",), fig4.shared_branch),
    Claim("fig4.A.pathways", "fig4", _MAIN4 + " (Fig. 4 A, D)",
          "Pathways p1 (2A → 66), p2 (2A → 1B) and p3 (→ 00) exist in the transition graph.",
          ("states",), fig4.pathways),
    Claim("fig4.C.hierarchy", "fig4", _MAIN4 + " (Fig. 4 B–C)",
          "Open helical folds set equally spaced slope branches; branchwise RMS elongation "
          "and deflection increase about linearly with slope.", ("states",), fig4.hierarchy),
    Claim("si.dist.slope", "si", "SI S12 (distributions)",
          "The slope distribution is unimodal and peaks near Θ = 1/3.",
          ("states",), si.slope_peak),
    Claim("si.dist.elongation", "si", "SI S12 (distributions)",
          "The elongation distribution is bimodal.", ("states",), si.elongation_bimodal),
    Claim("si.dist.deflection", "si", "SI S12 (distributions)",
          "The deflection distribution has a dominant peak near zero and a smaller secondary "
          "peak over u_r/l0 ∈ [1/8, 5/8].", ("states",), si.deflection_peaks),
    Claim("si.cft", "si", "SI S10 (Experimental calibration)",
          "Linear least-squares fits of the median CFT responses give the trilinear circular "
          "and linear helical laws of Table calib.", ("calibration",), si.calibration),
    Claim("si.movie", "si", "SI Movie S1",
          "The modelled response of the semi-bistable MFT under actuation, in the planar "
          "development and the reconstructed cylinder.", ("movie",), si.movie),
)  # fmt: skip
