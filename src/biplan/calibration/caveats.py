"""Caveats of a calibration: when its numbers mean little (SI "Experimental Calibration";
:attr:`biplan.calibration.calibrate.Calibration.caveats`, printed by the CLI and written into
the law block's comments).

* :attr:`CaveatKind.FEW_SPECIMENS` — bootstrap intervals from fewer than
  :data:`MIN_BOOTSTRAP_SPECIMENS` specimens (one specimen: every resample is that specimen and
  the interval has zero width; n specimens give only C(2n−1, n) distinct resamples);
* :attr:`CaveatKind.BISTABLE_DATA` — a linear law fitted to data whose force falls, along
  increasing displacement, by more than :data:`BISTABLE_DROP` of the force range (the
  example data: 78 % for the trilinear CFT specimens, 44 % for the MFT, 0 % for the linear
  CFT specimens, whose noise is 0.3 % of the range);
* :attr:`CaveatKind.POOR_FIT` — an RMS residual above :data:`POOR_FIT_RMS` of the force
  range (the example fits: 0.2–1.6 % for the matching law, 34–49 % for a linear law fitted
  to bistable data).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from biplan.calibration.fits import LawFit
from biplan.laws import LinearLaw

__all__ = [
    "BISTABLE_DROP",
    "MIN_BOOTSTRAP_SPECIMENS",
    "POOR_FIT_RMS",
    "Caveat",
    "CaveatKind",
    "caveats",
    "force_drop",
]

#: Bootstrap intervals from fewer specimens than this carry a caveat (4 specimens give 35
#: distinct resamples, too few for the tails of a 95 % interval; 5 give 126).
MIN_BOOTSTRAP_SPECIMENS = 5
#: A linear fit to data whose force falls by more than this fraction of its range along
#: increasing displacement carries a caveat: the data are bistable.
BISTABLE_DROP = 0.10
#: A fit whose RMS residual exceeds this fraction of the force range carries a caveat.
POOR_FIT_RMS = 0.10


class CaveatKind(enum.Enum):
    """Why a calibration's numbers may mean little (see the module docstring)."""

    FEW_SPECIMENS = "few specimens"
    BISTABLE_DATA = "bistable data"
    POOR_FIT = "poor fit"


@dataclass(frozen=True)
class Caveat:
    """A warning attached to a calibration: its kind and a one-line message (with numbers)."""

    kind: CaveatKind
    message: str


def force_drop(displacement: np.ndarray, force: np.ndarray) -> float:
    """The largest fall of the force [N] along increasing displacement: max over points of
    (the largest force at smaller or equal displacement − the force there); 0 for a curve
    that never falls. NaN points are ignored."""
    u, f = np.asarray(displacement, dtype=float), np.asarray(force, dtype=float)
    ok = np.isfinite(u) & np.isfinite(f)
    if not ok.any():
        return 0.0
    f = f[ok][np.argsort(u[ok], kind="stable")]
    return float(np.max(np.maximum.accumulate(f) - f))


def caveats(fit: LawFit, n_specimens: int, n_bootstrap: int) -> tuple[Caveat, ...]:
    """The caveats of a fit to the median of ``n_specimens`` specimens with ``n_bootstrap``
    resamples (thresholds :data:`MIN_BOOTSTRAP_SPECIMENS`, :data:`BISTABLE_DROP`,
    :data:`POOR_FIT_RMS`)."""
    out: list[Caveat] = []
    if n_bootstrap > 0 and n_specimens == 1:
        out.append(
            Caveat(
                CaveatKind.FEW_SPECIMENS,
                "the bootstrap intervals come from a single specimen: every resample "
                "is that specimen, so they have zero width and show no scatter",
            )
        )
    elif n_bootstrap > 0 and n_specimens < MIN_BOOTSTRAP_SPECIMENS:
        distinct = math.comb(2 * n_specimens - 1, n_specimens)
        out.append(
            Caveat(
                CaveatKind.FEW_SPECIMENS,
                f"the bootstrap intervals come from only {n_specimens} specimens "
                f"({distinct} distinct resamples; at least {MIN_BOOTSTRAP_SPECIMENS} "
                "specimens are needed): they mean little",
            )
        )
    span = float(np.ptp(fit.force)) if fit.force.size else 0.0
    if span <= 0.0:
        return tuple(out)
    drop = force_drop(fit.displacement, fit.force)
    if isinstance(fit.law, LinearLaw) and drop > BISTABLE_DROP * span:
        out.append(
            Caveat(
                CaveatKind.BISTABLE_DATA,
                f"the data are bistable: the median force falls by {drop:.3g} N "
                f"({drop / span:.0%} of its range) as the displacement grows, which no "
                "linear law can follow; fit a trilinear law",
            )
        )
    if fit.rms > POOR_FIT_RMS * span:
        out.append(
            Caveat(
                CaveatKind.POOR_FIT,
                f"the fit's RMS residual {fit.rms:.3g} N is {fit.rms / span:.0%} of the "
                f"force range {span:.3g} N: the law does not describe the data",
            )
        )
    return tuple(out)
