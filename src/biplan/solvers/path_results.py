"""The result of path following: :class:`EquilibriumPath`, with why it ended
(:class:`PathStatus`), the work it took (:class:`PathStats`), its located limit points and
bifurcations (:class:`Event`) and, for a load-controlled response, its jumps between stable
branches (:class:`Snap`).

A path converts to an ``xarray.Dataset`` (dim ``step``) with
:meth:`~biplan.solvers.results.LabelledResult.to_dataset` (:mod:`biplan.solvers.results`).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from biplan._errors import ResultStatus
from biplan.model.assembly import Model
from biplan.solvers.control import Control
from biplan.solvers.observation import Observation
from biplan.solvers.results import OBSERVABLES, LabelledResult, display_units, observables

__all__ = [
    "PRESSED_SHUT_SHARE",
    "Critical",
    "EquilibriumPath",
    "Event",
    "PathStats",
    "PathStatus",
    "Snap",
]

#: A stalled path whose last state's largest contact reaction is at least this share of the
#: end force says that the load goes into closed folds (:attr:`EquilibriumPath.message`). At
#: an equilibrium that deforms, the contacts carry a few hundredths of a newton at most (the
#: semi-bistable and fully bistable designs up to 2 N: ≤ 0.02 N); where a path stalls against
#: full contact they carry about half of it.
PRESSED_SHUT_SHARE = 0.1


class PathStatus(ResultStatus):
    """Why a path ended (``ok``: it ended where it was asked to)."""

    COMPLETED = 0, "reached the stop value", True
    MAX_STEPS = 1, "stopped at the maximum number of steps"
    STALLED = (
        2,
        "stalled: the step fell below min_step without a converged corrector "
        "(a limit point of the controlled quantity under load stepping — use "
        "ArcLength or dynamics — or the end of the admissible range, e.g. full contact)",
    )
    NONFINITE = 3, "a state became non-finite"
    FULL_CONTACT = (
        4,
        "stopped at full contact: going on would press a closed fold past flat by "
        "more than the contact compliance allows (the tube is closed solid; "
        'docs/model.md, "Degenerate contacts")',
    )
    RETURNED = (
        5,
        "stopped where the path would have run back past its start value (the load "
        "would have returned through the start, or changed sign)",
    )
    LIMIT_POINT = 6, "stopped past the first limit point of the load, as asked", True
    SNAPPED = 7, "stopped at the first snap, as asked", True
    NO_LANDING = 8, "no stable state found at the snap load (descent at fixed load failed)"

    @staticmethod
    def from_code(code: int) -> PathStatus:
        return PathStatus(code) if code in (0, 1, 2, 3, 5, 6) else PathStatus.STALLED


class Critical(enum.StrEnum):
    """What was lost where λ_min(H_r) changes sign (the value is what files hold)."""

    LIMIT_POINT = "limit point"  #: the load turns back (the tangent's load component flips)
    BIFURCATION = "bifurcation"  #: the load goes on; another branch crosses
    LOSS_OF_STABILITY = "loss of stability"  #: not located: last stable before first unstable


@dataclass(frozen=True)
class Event:
    """A located sign change of λ_min(H_r) along a path."""

    kind: Critical  # LIMIT_POINT or BIFURCATION
    step: int  # index of the located state in the path
    load_parameter: float
    force: float  # [N]
    displacement: float  # [mm]
    tolerance: float = float("nan")  # width of the final bracket in Λ


@dataclass(frozen=True)
class Snap:
    """A jump of a load-controlled response
    (:func:`biplan.analysis.response.loadcontrol.load_response`).

    At a located loss of stability the tube leaves its branch at the fixed load for a stable
    state on another branch; the response goes on from there.

    Attributes
    ----------
    step : int
        Index of the last state before the jump (the located loss of stability); the landing
        state is ``step + 1``.
    load_parameter : float
        Λ at the jump: F [N], U [mm] or p [MPa].
    force : float
        End force at the jump [N].
    displacement_before, displacement_after : float
        Load-point displacement z_p [mm] before and after the jump.
    critical : Critical
        What was lost (``LOSS_OF_STABILITY``: not located, the last stable state before the
        first unstable one).
    folds : tuple of str
        The folds whose dominant phase changed in the jump
        (:func:`~biplan.solvers.results.fold_names`).
    landing : str
        How the landing state was found (``"descent at fixed load"``).
    tolerance : float
        Width in Λ of the bracket that located the loss of stability (NaN when not located).
    """

    step: int
    load_parameter: float
    force: float
    displacement_before: float
    displacement_after: float
    critical: Critical
    folds: tuple[str, ...]
    landing: str
    tolerance: float = float("nan")

    def describe(self, unit: str = "N", scale: float = 1.0) -> str:
        """One line: where the tube snapped, which folds went and where it landed."""
        tol = "" if not np.isfinite(self.tolerance) else f" ± {self.tolerance * scale:.1g}"
        folds = ", ".join(self.folds) if self.folds else "no fold changed phase"
        return (
            f"snap at {self.load_parameter * scale:.4f}{tol} {unit} ({self.critical}): "
            f"z_p {self.displacement_before:.3f} → {self.displacement_after:.3f} mm; "
            f"{folds} ({self.landing})"
        )


@dataclass(frozen=True)
class PathStats:
    """Work done by a path solve."""

    n_steps: int
    n_cutbacks: int
    newton_iterations: int
    n_events: int
    smallest_step: float
    largest_step: float


@dataclass(frozen=True)
class EquilibriumPath(LabelledResult):
    """An equilibrium path (one entry per accepted step; located events inserted).

    Attributes
    ----------
    load_parameter : ndarray
        Λ at each state: F [N], U [mm] or p [MPa] (``control.kind``).
    force, displacement, u_z, u_r, theta, energy : ndarray
        End force [N], load-point displacement [mm], endpoint [mm, mm, rad], Π [N·mm].
    fold_energy : ndarray (step, fold)
    phase_fraction : ndarray (step, fold, 3)
        Closed, spinodal, open fraction of each fold's length.
    min_eigenvalue : ndarray
        λ_min(H_r) (+inf when contact-locked); ``stable`` where > 1e-8.
    is_event : ndarray of bool
        States inserted at located limit points / bifurcations.
    events : tuple of Event
    direction : ndarray
        Λ-component of the path tangent (changes sign at limit points).
    q, z : ndarray
        Coordinates (step, n_q) and packed unknowns (step, n_z).
    status : PathStatus
    stats : PathStats
    segment : ndarray of int, optional
        Stable branch of each state of a load-controlled response (0 before the first snap,
        1 after it, …); None for a plain path.
    snaps : tuple of Snap
        The jumps between those branches.
    """

    model: Model = field(repr=False)
    control: Control
    method: str
    load_parameter: np.ndarray
    force: np.ndarray
    displacement: np.ndarray
    u_z: np.ndarray
    u_r: np.ndarray
    theta: np.ndarray
    energy: np.ndarray
    helical_energy: np.ndarray
    circular_energy: np.ndarray
    fold_energy: np.ndarray
    phase_fraction: np.ndarray
    min_eigenvalue: np.ndarray
    stable: np.ndarray
    constraint_residual: np.ndarray
    is_event: np.ndarray
    events: tuple[Event, ...]
    direction: np.ndarray
    q: np.ndarray = field(repr=False)
    z: np.ndarray = field(repr=False)
    status: PathStatus = PathStatus.COMPLETED
    stats: PathStats | None = None
    segment: np.ndarray | None = field(default=None, repr=False)
    snaps: tuple[Snap, ...] = ()

    @property
    def switched(self) -> np.ndarray:
        """True at the landing state of each snap (the first state of a new branch)."""
        out = np.zeros(self.n_steps, dtype=bool)
        if self.segment is not None and self.n_steps > 1:
            out[1:] = np.diff(self.segment) != 0
        return out

    @classmethod
    def build(
        cls,
        *,
        model: Model,
        control: Control,
        method: str,
        z: np.ndarray,
        load_parameter: np.ndarray,
        observation: Observation,
        event_flags: np.ndarray,
        events: tuple[Event, ...],
        status: PathStatus,
        stats: PathStats,
        direction: np.ndarray,
    ) -> EquilibriumPath:
        common: dict[str, Any] = observables(model, observation, load_parameter)
        return cls(
            model=model,
            control=control,
            method=method,
            is_event=np.asarray(event_flags, bool),
            events=events,
            direction=np.asarray(direction, float),
            q=np.asarray(z)[:, : model.n_coordinates],
            z=np.asarray(z),
            status=status,
            stats=stats,
            **common,
        )

    @property
    def n_steps(self) -> int:
        return len(self.load_parameter)

    @property
    def completed(self) -> bool:
        return self.status is PathStatus.COMPLETED

    @property
    def message(self) -> str:
        """Why the path ended and the work it took; a stalled path adds
        :meth:`contact_share` where the contacts of its last state carry a share of the end
        force."""
        s = self.stats
        extra = f"; {s.n_steps} steps, {s.n_cutbacks} cut-backs" if s else ""
        if self.status is PathStatus.STALLED and self.n_steps:
            reaction, force = self.contact_share()
            if reaction >= PRESSED_SHUT_SHARE * abs(force) and reaction > 0.0:
                extra += (
                    f". At its last state the contacts carry up to {reaction:.3g} N at an end "
                    f"force of {force:.5g} N: the load goes into closed folds, not into "
                    'deformation; the tube is pressed shut (docs/model.md, "Degenerate '
                    'contacts")'
                )
        return f"{self.status.message}{extra}"

    def contact_share(self) -> tuple[float, float]:
        """(largest contact multiplier λ_∂ [N], end force F [N]) at the last state."""
        m = self.model
        first = m.n_coordinates + m.n_guides
        reactions = self.z[-1, first : first + m.n_contacts]
        return float(reactions.max(initial=0.0)), float(self.force[-1])

    @property
    def limit_points(self) -> tuple[Event, ...]:
        return tuple(e for e in self.events if e.kind is Critical.LIMIT_POINT)

    def _variables(self) -> dict[str, np.ndarray]:
        out = {n: getattr(self, n) for n in (*OBSERVABLES, "q")}
        out["limit_point"] = self.is_event
        if self.segment is not None:
            out["segment"] = np.asarray(self.segment, dtype=np.int64)
            out["switched"] = self.switched
        return out

    def _attrs(self) -> dict[str, Any]:
        s = self.stats
        scale, unit = display_units(self.control)
        attrs = {
            "method": self.method,
            "status": self.status.name,
            "message": self.message,
            "n_cutbacks": s.n_cutbacks if s else 0,
            "events": "; ".join(
                f"{e.kind} at step {e.step}: F = {e.force:.6g} N, z_p = {e.displacement:.6g} mm"
                for e in self.events
            ),
        }
        if self.segment is not None:
            attrs["snaps"] = "; ".join(
                f"step {p.step}: " + p.describe(unit, scale) for p in self.snaps
            )
        return attrs
