"""Synthetic calibration specimens from a known fold law (for tests, examples and docs).

Model of the synthetic measurements (all draws from one seeded generator):

* specimen-to-specimen scatter: each specimen has its own law, every stiffness and every
  breakpoint of the true law multiplied by an independent log-normal factor
  ``exp(σ z)``, z ~ N(0, 1) (σ = ``Scatter.stiffness`` for k, ``Scatter.transitions`` for the
  breakpoints); the true law is thus the median specimen;
* sampling: displacements on a regular grid with ±``jitter`` of a step of uniform jitter;
* measurement noise: additive Gaussian force noise of SD ``Scatter.noise`` [N];
* protocol of a trilinear CFT (SI "Experimental Calibration"): phase 1 under force-controlled
  extension from u = 0 up to the specimen's instability point (the last sample falls within one
  step before it, at a uniformly random place); phase 2 under contraction from a random
  extension down to its stability limit (samples stored in decreasing displacement); nothing
  inside the spinodal. A linear CFT is one extension segment to a random end displacement.

The specimen force is the uniform-field CFT response F = H f(u / n)
(:func:`biplan.calibration.calibrate.cft_force`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from biplan._errors import ConfigError, check_range
from biplan.calibration.fits import CftGeometry, cft_force
from biplan.calibration.specimens import Segment, Specimen
from biplan.laws import LinearLaw, TrilinearLaw

__all__ = ["Scatter", "sample_segment", "synthetic_specimens"]


@dataclass(frozen=True)
class Scatter:
    """Scatter and noise of synthetic specimens.

    Parameters
    ----------
    stiffness : float
        Log-normal SD of each specimen's stiffness coefficients (≈ relative SD).
    transitions : float
        Log-normal SD of each specimen's breakpoints.
    noise : float
        SD of the additive force noise [N].
    jitter : float
        Uniform displacement jitter, as a fraction of the sampling step, in [0, 0.5).
    """

    stiffness: float = 0.05
    transitions: float = 0.04
    noise: float = 0.02
    jitter: float = 0.3

    def __post_init__(self) -> None:
        for name in ("stiffness", "transitions", "noise"):
            check_range(name, getattr(self, name), low=0.0, low_open=False)
        check_range("jitter", self.jitter, low=0.0, high=0.5, low_open=False)


def sample_segment(
    rng: np.random.Generator, start: float, stop: float, n_points: int, jitter: float
) -> np.ndarray:
    """``n_points`` strictly monotonic displacements from ``start`` towards ``stop`` [mm].

    The first sample is ``start``; the rest sit on the regular grid of step
    ``(stop − start) / n_points`` jittered by ±``jitter`` step, so the last one falls within
    one step before ``stop``.
    """
    step = (stop - start) / n_points
    offsets = np.arange(n_points, dtype=float)
    offsets[1:] += rng.uniform(-jitter, jitter, n_points - 1)
    offsets[-1] = n_points - 1 + rng.uniform(0.0, 1.0 - 1e-6) if n_points > 1 else 0.0
    return start + step * offsets


def _specimen_law(
    law: TrilinearLaw | LinearLaw, scatter: Scatter, rng: np.random.Generator
) -> TrilinearLaw | LinearLaw:
    if isinstance(law, LinearLaw):
        return LinearLaw(law.stiffness * float(np.exp(scatter.stiffness * rng.normal())))
    k = np.asarray(law.stiffness) * np.exp(scatter.stiffness * rng.normal(size=3))
    w = np.asarray(law.transitions) * np.exp(scatter.transitions * rng.normal(size=2))
    w = np.sort(w)
    return TrilinearLaw(stiffness=tuple(k), transitions=tuple(w))  # type: ignore[arg-type]


def synthetic_specimens(
    law: TrilinearLaw | LinearLaw,
    geometry: CftGeometry | None = None,
    *,
    n_specimens: int = 10,
    scatter: Scatter | None = None,
    n_points: tuple[int, int] = (30, 40),
    extent: float = 0.4,
    seed: int | None = 0,
) -> tuple[Specimen, ...]:
    """Synthetic CFT specimens measured on a known law (see the module docstring).

    Parameters
    ----------
    law : TrilinearLaw or LinearLaw
        The true fold-field law (the median specimen's law).
    geometry : CftGeometry, optional
        Default R = 2 mm, one fold.
    n_specimens : int
        Number of specimens (≥ 1).
    scatter : Scatter, optional
    n_points : (int, int)
        Range of samples per segment (drawn uniformly per segment, inclusive).
    extent : float
        Mean fold elongation [mm] measured beyond w2 in phase 2 (trilinear) or from 0
        (linear); each specimen's extent is scaled by a uniform factor in [0.8, 1.2].
    seed : int or None

    Returns
    -------
    tuple of Specimen
        Named ``specimen_01`` …; trilinear ones with segments labelled ``"1"``, ``"2"``.
    """
    geometry = geometry or CftGeometry()
    scatter = scatter or Scatter()
    if isinstance(n_specimens, bool) or int(n_specimens) != n_specimens or n_specimens < 1:
        raise ConfigError("n_specimens", n_specimens, "an integer ≥ 1")
    lo, hi = n_points
    if not 5 <= lo <= hi:
        raise ConfigError("n_points", n_points, "(low, high) with 5 ≤ low ≤ high")
    check_range("extent", extent, low=0.0)
    rng = np.random.default_rng(seed)
    n = geometry.n_folds
    out = []
    for i in range(int(n_specimens)):
        own = _specimen_law(law, scatter, rng)
        reach = extent * rng.uniform(0.8, 1.2)
        segments = []
        if isinstance(own, LinearLaw):
            spans = [(0.0, n * reach, "1")]
        else:
            w1, w2 = own.transitions
            spans = [(0.0, n * w1, "1"), (n * (w2 + reach), n * w2, "2")]
        for start, stop, label in spans:  # phase 2 runs from its far end down to its limit
            u = sample_segment(rng, start, stop, int(rng.integers(lo, hi + 1)), scatter.jitter)
            f = cft_force(own, geometry, u) + scatter.noise * rng.normal(size=u.size)
            segments.append(Segment(u, f, label))
        out.append(Specimen(f"specimen_{i + 1:02d}", tuple(segments)))
    return tuple(out)
