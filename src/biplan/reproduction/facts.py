"""What the claims of :mod:`biplan.reproduction.claims` read: the paper's reported numbers and
the computed results (``biplan reproduce``).

The results are plain numbers and arrays (the ``*Facts`` dataclasses and the map datasets of
:class:`Results`) so that a claim can be checked against any input, including hand-made ones
in the tests. :func:`snapshot_steps` is the one choice of the Fig. 3 B.1–B.3 snapshots, used by
the reproduction's ``fig3_B_snapshots.png`` and by ``biplan demo``.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from biplan.analysis.response.summary import phase_one_end
from biplan.analysis.states.law_records import PAPER_N_STATES, PAPER_STATES, PAPER_SUB_BRANCH
from biplan.analysis.states.transitions import PAPER_PATHWAYS

__all__ = [
    "PAPER_B",
    "PAPER_N_STATES",
    "PAPER_PATHWAYS",
    "PAPER_STATES",
    "PAPER_SUB_BRANCH",
    "RAMP_FORCE",
    "CalibrationFacts",
    "MovieFacts",
    "Results",
    "SemiBistableFacts",
    "StateFacts",
    "ValidationFacts",
    "snapshot_steps",
    "state_facts",
]

# --- the paper's reported numbers ------------------------------------------------------------
#: The paper's terminal force of the ramp and the transition [N].
RAMP_FORCE = 1.6
#: The paper's geometric ratio of the validated design (Fig. 3 A.3: b = 0.58).
PAPER_B = 0.58
# PAPER_N_STATES, PAPER_STATES, PAPER_SUB_BRANCH (Fig. 4) are defined with the fold-law
# search's records (biplan.analysis.states.law_records), which measures law sets against them.


def snapshot_steps(force: Any, stable: Any, switched: Any) -> dict[str, int]:
    """Steps of the paper's Fig. 3 B panels on a displacement sweep; only those that exist.

    * ``B.1`` phase 1: the phase-1 step whose force is nearest half the largest phase-1 force
      (phase 1: :func:`~biplan.analysis.response.summary.phase_one_end`);
    * ``B.2`` the transformation: the step midway between the first and the last snap;
    * ``B.3`` phase 2: the last converged step, when it comes after the last snap.

    Parameters
    ----------
    force : array_like
        End force per step [N]; NaN where a step failed.
    stable, switched : array_like of bool
        Per step: a stable equilibrium; the step left an unstable state for a stable one (a
        snap).

    Returns
    -------
    dict
        Panel (``B.1``, ``B.2``, ``B.3``) → step index, in that order.
    """
    f = np.asarray(force, dtype=float)
    out: dict[str, int] = {}
    p1 = np.arange(phase_one_end(f, stable, switched))
    if p1.size:
        peak = float(np.max(f[p1]))
        out["B.1"] = int(p1[np.argmin(np.abs(f[p1] - 0.5 * peak))])
    snaps = np.flatnonzero(np.asarray(switched, dtype=bool))
    if snaps.size:
        out["B.2"] = int((snaps[0] + snaps[-1]) // 2)
        ok = np.flatnonzero(np.isfinite(f))
        if ok.size and ok[-1] > snaps[-1]:
            out["B.3"] = int(ok[-1])
    return out


# --- the results the claims read -------------------------------------------------------------
@dataclass(frozen=True)
class SemiBistableFacts:
    """The validated semi-bistable design under displacement control (stable-branch sweep).

    Attributes
    ----------
    b, C : float
        Geometric and stiffness ratio of the design.
    initial_length : float
        l₀ [mm].
    displacement, force, u_z, u_r, theta : ndarray
        Per sweep step [mm, N, mm, mm, rad]; NaN where a step failed.
    stable, switched : ndarray of bool
        Stable equilibrium; the step left an unstable state for a stable one (a snap).
    spinodal : ndarray (step, circular fold), optional
        Fraction of each circular fold's length on its spinodal branch (NaN at failed steps).
    """

    b: float
    C: float
    initial_length: float
    displacement: np.ndarray
    force: np.ndarray
    u_z: np.ndarray
    u_r: np.ndarray
    theta: np.ndarray
    stable: np.ndarray
    switched: np.ndarray
    spinodal: np.ndarray | None = None

    #: A fold counts as transforming when more than this fraction of it is on the spinodal.
    ONSET_FRACTION = 0.05

    @property
    def onset_spread(self) -> int:
        """Circular folds partly on their spinodal branch at the last phase-1 step, just before
        the first snap (0 without ``spinodal`` data or a phase 1)."""
        last = self.phase_one.stop - 1
        if self.spinodal is None or last < 0:
            return 0
        return int(np.sum(np.asarray(self.spinodal)[last] > self.ONSET_FRACTION))

    @property
    def phase_one(self) -> slice:
        """Steps before the first irregular one: the first snap, failure, instability or fall
        of the force along stable states
        (:func:`biplan.analysis.response.summary.phase_one_end`)."""
        return slice(0, phase_one_end(self.force, self.stable, self.switched))

    @property
    def snaps(self) -> np.ndarray:
        """Indices of the steps that snapped."""
        return np.flatnonzero(self.switched)

    def snapshots(self) -> dict[str, int]:
        """Steps of the B panels (:func:`snapshot_steps`)."""
        return snapshot_steps(self.force, self.stable, self.switched)


@dataclass(frozen=True)
class ValidationFacts:
    """The predicted force–displacement curve against the measured band (Fig. 3 A.2).

    Attributes
    ----------
    rms : float
        RMS difference of the prediction from the band's median [N].
    fraction_outside : float
        Fraction of the compared band points outside the median ± 1 SD band.
    n_compared : int
        Band points compared (where both the band and the prediction exist).
    synthetic : bool
        The band was made from this model's own sweep, not measured.
    source : str
        Where the band comes from, in words.
    """

    rms: float
    fraction_outside: float
    n_compared: int
    synthetic: bool
    source: str


@dataclass(frozen=True)
class StateFacts:
    """Stable states of the fully bistable MFT and their hierarchy (Fig. 4, SI S11–S12).

    Attributes
    ----------
    n_seeds : int
    labels : tuple of str
        Paper label of every state (two hex digits).
    u_z, u_r, Theta : ndarray
        Per state: u_z/l₀, u_r/l₀ and Θ = θ/max|θ|.
    n_open_helical, n_open_circular : ndarray of int
        Per state: the slope branch and the sub-branch.
    theta_bins, theta_counts, u_z_bins, u_z_counts, u_r_bins, u_r_counts : ndarray
        State-count distributions (bin centres, counts).
    branch_theta, branch_rms_u_z, branch_rms_u_r : ndarray
        Per slope branch (open helical folds ``branches``): mean Θ and RMS u_z/l₀, u_r/l₀.
    branches : ndarray of int
    pathways : dict
        Paper pathway name → the states along it, or None when it does not exist.
    """

    n_seeds: int
    labels: tuple[str, ...]
    u_z: np.ndarray
    u_r: np.ndarray
    Theta: np.ndarray
    n_open_helical: np.ndarray
    n_open_circular: np.ndarray
    theta_bins: np.ndarray
    theta_counts: np.ndarray
    u_z_bins: np.ndarray
    u_z_counts: np.ndarray
    u_r_bins: np.ndarray
    u_r_counts: np.ndarray
    branches: np.ndarray
    branch_theta: np.ndarray
    branch_rms_u_z: np.ndarray
    branch_rms_u_r: np.ndarray
    pathways: Mapping[str, tuple[str, ...] | None]

    def index(self, label: str) -> int | None:
        """Index of the (first) state with this label, or None."""
        return self.labels.index(label) if label in self.labels else None


@dataclass(frozen=True)
class CalibrationFacts:
    """A CFT calibration against the law that generated (or is expected for) the specimens.

    Attributes
    ----------
    kind : str
        ``trilinear`` or ``linear``.
    estimates : dict
        Parameter name → (value, low, high) (bootstrap interval; NaN bounds without).
    truth : dict
        Parameter name → the reference value (SI Table calib).
    rms, noise : float
        RMS fit residual and the specimens' force noise SD [N] (NaN if unknown).
    synthetic : bool
        The specimens were generated, not measured.
    """

    kind: str
    estimates: Mapping[str, tuple[float, float, float]]
    truth: Mapping[str, float]
    rms: float
    noise: float
    synthetic: bool


@dataclass(frozen=True)
class MovieFacts:
    """The Movie S1 analogue: frames written and what the animated history shows.

    Attributes
    ----------
    file : str
        Name of the animation file (``movie_S1.mp4``, or ``.gif`` without ffmpeg).
    n_frames : int
    lost_stability : bool
        Some state of the animated ramp is unstable.
    final_force : float
        End force at the end of the ramp [N].
    """

    file: str
    n_frames: int
    lost_stability: bool
    final_force: float


@dataclass
class Results:
    """Everything the claims read; a stage that failed leaves its field None and its error.

    Not frozen: the stages of :func:`biplan.reproduction.stages.run_stages` fill it in turn.

    Attributes
    ----------
    semi, validation, states, calibration, movie
        The facts of the stage of that name.
    design_map, instability_map, stability_map : xarray.Dataset
        The maps as the sweeps store them.
    errors : dict
        Stage name → ``type: message`` of its failure.
    """

    semi: SemiBistableFacts | None = None
    design_map: Any = None
    instability_map: Any = None
    stability_map: Any = None
    validation: ValidationFacts | None = None
    states: StateFacts | None = None
    calibration: tuple[CalibrationFacts, ...] | None = None
    movie: MovieFacts | None = None
    errors: dict[str, str] = field(default_factory=dict)


def state_facts(folder: Path) -> StateFacts:
    """The :class:`StateFacts` of a ``biplan states`` output folder
    (states.csv, seeds.csv, hierarchy.nc, transitions.graphml)."""
    import networkx as nx
    import xarray as xr

    from biplan.analysis.states.transitions import pathway

    with (folder / "states.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    with (folder / "seeds.csv").open(newline="") as fh:
        n_seeds = len(list(csv.DictReader(fh)))
    with xr.open_dataset(folder / "hierarchy.nc", engine="h5netcdf") as h:
        h = h.load()
    graph = nx.read_graphml(folder / "transitions.graphml")
    names = {r["name"] for r in rows}
    pathways: dict[str, tuple[str, ...] | None] = {}
    for name, (a, b) in PAPER_PATHWAYS.items():
        try:
            found = pathway(graph, a, b) if a in names and b in names else None
        except Exception:  # not connected: no pathway
            found = None
        pathways[name] = tuple(found) if found else None  # type: ignore[arg-type]

    def col(key: str, dtype: Any = float) -> np.ndarray:
        return np.asarray([r[key] for r in rows], dtype=dtype)

    l0 = float(h.attrs["initial_length"])
    return StateFacts(
        n_seeds=n_seeds,
        labels=tuple(r["label"] for r in rows),
        u_z=col("u_z") / l0,
        u_r=col("u_r") / l0,
        Theta=col("Theta"),
        n_open_helical=col("n_open_helical", int),
        n_open_circular=col("n_open_circular", int),
        theta_bins=np.asarray(h["Theta_bin"]),
        theta_counts=np.asarray(h["count_Theta"]),
        u_z_bins=np.asarray(h["u_z_bin"]),
        u_z_counts=np.asarray(h["count_u_z"]),
        u_r_bins=np.asarray(h["u_r_bin"]),
        u_r_counts=np.asarray(h["count_u_r"]),
        branches=np.asarray(h["branch"]),
        branch_theta=np.asarray(h["mean_Theta"]),
        branch_rms_u_z=np.asarray(h["rms_u_z_rel"]),
        branch_rms_u_r=np.asarray(h["rms_u_r_rel"]),
        pathways=pathways,
    )
