"""The band of the reproduction's validation stage (Fig. 3 A.2) when no specimens are measured,
and the comparison file it writes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["synthetic_band"]


def synthetic_band(path: Any, seed: int = 11) -> Any:
    """A five-specimen median ± 1 SD band from the model's own sweep with specimen scatter.

    As in examples/data/make_synthetic.py: phase 1 (up to the first snap,
    :func:`~biplan.analysis.response.summary.phase_one_end`) and phase 2 (the stable steps
    from the last snap on); each specimen scales force by exp(0.05 z) and displacement by
    exp(0.03 z) (z standard normal), samples each phase at 40–60 jittered points and adds
    force noise of SD 0.02 N.

    Parameters
    ----------
    path : QuasiStaticPath
        The displacement sweep [mm, N].
    seed : int
        Seed of the scatter.

    Returns
    -------
    Band
        :func:`biplan.calibration.band.band_statistics` of the five specimens.
    """
    from biplan.analysis.response.summary import phase_one_end
    from biplan.calibration.band import band_statistics
    from biplan.calibration.specimens import Segment, Specimen
    from biplan.calibration.synthetic import sample_segment

    ok = np.isfinite(path.force) & path.stable
    first = phase_one_end(path.force, path.stable, path.switched)
    snaps = np.flatnonzero(path.switched)
    u, f = np.asarray(path.displacement), np.asarray(path.force)
    parts = [("1", u[:first], f[:first])]
    if snaps.size:
        tail = np.arange(snaps[-1], u.size)
        tail = tail[ok[tail]]
        parts.append(("2", u[tail], f[tail]))
    rng = np.random.default_rng(seed)
    specimens = []
    for i in range(5):
        s_f, s_u = float(np.exp(0.05 * rng.normal())), float(np.exp(0.03 * rng.normal()))
        segs = []
        for label, uu, ff in parts:
            if uu.size < 3:
                continue
            x = sample_segment(rng, float(uu[0]), float(uu[-1]), int(rng.integers(40, 61)), 0.3)
            y = s_f * np.interp(x, uu, ff) + 0.02 * rng.normal(size=x.size)
            segs.append(Segment(s_u * x, y, label))
        specimens.append(Specimen(f"synthetic_{i + 1:02d}", tuple(segs)))
    return band_statistics(specimens)
