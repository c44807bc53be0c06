"""Endpoint-space hierarchy of stable states (main Fig. 4 B–C; SI distributions figure).

The stable states of a fully bistable MFT project onto endpoint space (u_z/l₀, u_r/l₀, Θ).
The paper reads a three-level hierarchy there:

* **slope branches** — states with the same number of open helical folds share a slope level;
* **iso-elongation sub-branches** — within a slope branch, states with the same circular-fold
  configuration (here: the same number of open circular folds) share an elongation level;
* **distributions** — state counts over Θ, u_z/l₀ and u_r/l₀, and branch-wise RMS relations
  (the root mean square of u_z/l₀ and u_r/l₀ over each slope branch against its mean Θ).

:func:`hierarchy` returns all of it as one ``xarray.Dataset``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from biplan.analysis.states.catalogue import StateCatalogue

__all__ = ["BINS", "count_peaks", "hierarchy"]

#: Default number of histogram bins per endpoint quantity.
BINS = 12


def count_peaks(counts: np.ndarray) -> int:
    """Local maxima of a histogram (a plateau counts once; zero bins are no peak): the
    modes of the SI's distributions (the elongation one is bimodal)."""
    c = np.asarray(counts, dtype=float)
    keep = np.r_[True, np.diff(c) != 0]  # collapse plateaus
    v = c[keep]
    padded = np.r_[-1.0, v, -1.0]
    return int(np.sum((v > padded[:-2]) & (v > padded[2:]) & (v > 0)))


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(x)))) if x.size else float("nan")


def hierarchy(catalogue: StateCatalogue, bins: int = BINS) -> Any:
    """Branches, sub-branches, distributions and RMS relations of a state catalogue.

    Parameters
    ----------
    catalogue : StateCatalogue
    bins : int
        Bins of the u_z/l₀ and u_r/l₀ histograms (Θ uses bins centred on the slope levels
        k/n_h, n_h = the largest number of open helical folds among the states).

    Returns
    -------
    xarray.Dataset
        Per state (dim ``state``): ``u_z_rel``, ``u_r_rel``, ``Theta``, ``slope_branch`` (open
        helical folds), ``sub_branch`` (open circular folds). Per slope branch (dim
        ``branch``): ``count``, ``mean_Theta``, ``rms_u_z_rel``, ``rms_u_r_rel``,
        ``n_sub_branches``. Histograms: ``count_Theta(Theta_bin)``,
        ``count_u_z(u_z_bin)``, ``count_u_r(u_r_bin)`` with bin centres as coordinates.
    """
    import xarray as xr

    l0 = catalogue.model.tube.initial_length
    rows = catalogue.rows()
    names = [r["name"] for r in rows]
    uz = np.array([r["u_z"] for r in rows], dtype=float) / l0
    ur = np.array([r["u_r"] for r in rows], dtype=float) / l0
    theta = np.array([r["Theta"] for r in rows], dtype=float)
    hel = np.array([r["n_open_helical"] for r in rows], dtype=int)
    circ = np.array([r["n_open_circular"] for r in rows], dtype=int)
    branches = np.unique(hel) if hel.size else np.zeros(0, dtype=int)

    n_levels = max(int(hel.max()) if hel.size else 1, 1)
    theta_edges = (np.arange(-n_levels - 1, n_levels + 1) + 0.5) / n_levels
    count_theta, _ = np.histogram(theta, bins=theta_edges)
    count_uz, uz_edges = np.histogram(uz, bins=bins)
    count_ur, ur_edges = np.histogram(ur, bins=bins)

    def centres(edges: np.ndarray) -> np.ndarray:
        return 0.5 * (edges[1:] + edges[:-1])

    per_branch = {
        "count": [int(np.sum(hel == b)) for b in branches],
        "mean_Theta": [float(np.mean(theta[hel == b])) for b in branches],
        "rms_u_z_rel": [_rms(uz[hel == b]) for b in branches],
        "rms_u_r_rel": [_rms(ur[hel == b]) for b in branches],
        "n_sub_branches": [len(np.unique(circ[hel == b])) for b in branches],
    }
    ds = xr.Dataset(
        {
            "u_z_rel": (("state",), uz),
            "u_r_rel": (("state",), ur),
            "Theta": (("state",), theta),
            "slope_branch": (("state",), hel),
            "sub_branch": (("state",), circ),
            **{k: (("branch",), np.asarray(v)) for k, v in per_branch.items()},
            "count_Theta": (("Theta_bin",), count_theta),
            "count_u_z": (("u_z_bin",), count_uz),
            "count_u_r": (("u_r_bin",), count_ur),
        },
        coords={
            "state": names,
            "branch": branches,
            "Theta_bin": centres(theta_edges),
            "u_z_bin": centres(uz_edges),
            "u_r_bin": centres(ur_edges),
        },
    )
    ds.attrs.update(
        kind="state_hierarchy",
        initial_length=l0,
        description="slope branches = open helical folds; sub-branches = open circular folds",
    )
    return ds
