"""The time-integration schemes and load histories of :func:`biplan.solvers.dynamics.integrate`:
the generalized-α method (:class:`GeneralizedAlpha`, MODEL CHOICE D3, with optional Rayleigh
damping, CHOICE D2), backward Euler (:class:`BackwardEuler`, the fallback for snaps with
contact impacts) and a piecewise-linear :class:`LoadHistory` of force, displacement or pressure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from biplan._errors import ConfigError, check_finite, check_integer, check_range
from biplan.solvers import step_loop
from biplan.solvers.control import Control, ControlKind

__all__ = ["HISTORY_POINTS", "BackwardEuler", "GeneralizedAlpha", "LoadHistory"]


#: Breakpoints of a load history (padded).
HISTORY_POINTS = 16


@dataclass(frozen=True)
class GeneralizedAlpha:
    """Generalized-α integrator settings.

    Parameters
    ----------
    time_step : float
        Nominal step h [s], > 0.
    spectral_radius : float
        ρ∞ ∈ [0, 1]: high-frequency numerical dissipation (1: none, second order for any ρ∞).
    rayleigh : float
        α_R [1/s] ≥ 0 of the mass-proportional damping D = α_R M.
    atol : float
        Newton tolerance on ‖r‖∞ per step (residual units N, mm).
    max_iterations : int
        Newton iterations per step.
    max_halvings : int
        Retries of a failed step, halving h each time.
    save_every : int
        Keep every k-th step in the Trajectory (the last is always kept).
    energy_tolerance : float
        A step may not create more than this energy [N·mm] plus 10 % of the energy it moves
        (|ΔW| + |ΔD| + |ΔT|); a step that does (Newton tunnelling to another equilibrium of
        the multistable landscape) is retried with h/2.
    """

    time_step: float = 0.01
    spectral_radius: float = 0.8
    rayleigh: float = 0.0
    atol: float = 1e-8
    max_iterations: int = 60
    max_halvings: int = 12
    save_every: int = 1
    energy_tolerance: float = 1e-3

    def __post_init__(self) -> None:
        check_range("GeneralizedAlpha.time_step", self.time_step, low=0.0)
        check_range("GeneralizedAlpha.energy_tolerance", self.energy_tolerance, low=0.0)
        check_range(
            "GeneralizedAlpha.spectral_radius",
            self.spectral_radius,
            low=0.0,
            high=1.0,
            low_open=False,
            high_open=False,
        )
        check_range("GeneralizedAlpha.rayleigh", self.rayleigh, low=0.0, low_open=False)
        check_range("GeneralizedAlpha.atol", self.atol, low=0.0)
        for name in ("max_iterations", "max_halvings", "save_every"):
            low = 0 if name == "max_halvings" else 1
            v = check_integer(f"GeneralizedAlpha.{name}", getattr(self, name), low=low)
            object.__setattr__(self, name, v)

    def coefficients(self) -> tuple[float, float, float, float]:
        """(α_m, α_f, γ, β) of the method (Chung & Hulbert)."""
        return tuple(float(c) for c in step_loop.coefficients(self.spectral_radius))  # type: ignore[return-value]

    def describe(self) -> str:
        return (
            f"generalized-alpha(rho_inf={self.spectral_radius:g}, h={self.time_step:g} s, "
            f"alpha_R={self.rayleigh:g}/s)"
        )


@dataclass(frozen=True)
class BackwardEuler(GeneralizedAlpha):
    """Implicit (backward) Euler on positions and velocities — Newmark with β = γ = 1,
    α_m = α_f = 0: first order and strongly dissipative (MODEL §13 alternative). Robust for
    selecting the branch reached after a snap, including contact impacts, at the price of
    distorted transients. ``spectral_radius`` is ignored (ρ∞ = 0)."""

    def coefficients(self) -> tuple[float, float, float, float]:
        return (0.0, 0.0, 1.0, 1.0)

    def describe(self) -> str:
        return f"backward-euler(h={self.time_step:g} s, alpha_R={self.rayleigh:g}/s)"


@dataclass(frozen=True)
class LoadHistory:
    """A piecewise-linear load history Λ(t) of a controlled quantity (constant outside).

    Parameters
    ----------
    kind : ControlKind
        Force [N], displacement [mm] or pressure [MPa].
    times : tuple of float
        Increasing breakpoints [s] (at most 16).
    values : tuple of float
        Λ at the breakpoints.
    """

    kind: ControlKind
    times: tuple[float, ...]
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        if not isinstance(self.kind, ControlKind):
            object.__setattr__(self, "kind", Control(self.kind, 0.0).kind)
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        if t.ndim != 1 or t.shape != v.shape or not 1 <= t.size <= HISTORY_POINTS:
            raise ConfigError(
                "load.times/values",
                (t.size, v.size),
                f"equal lengths between 1 and {HISTORY_POINTS}",
            )
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise ConfigError("load.times/values", "non-finite", "finite numbers")
        if np.any(np.diff(t) <= 0):
            raise ConfigError("load.times", tuple(t), "strictly increasing times [s]")

    @classmethod
    def ramp(cls, rate: float = 0.8, until: float = 2.0, kind: str = "force") -> LoadHistory:
        """Λ(t) = rate·t for 0 ≤ t ≤ until, then held (the paper's F(t) = 0.8 N/s · t)."""
        rate = check_finite("load.rate", rate)
        check_range("load.until", until, low=0.0)
        return cls(ControlKind(kind), (0.0, float(until)), (0.0, rate * float(until)))

    @classmethod
    def constant(cls, value: float, kind: str = "force") -> LoadHistory:
        """Λ(t) = value for all t."""
        return cls(ControlKind(kind), (0.0,), (check_finite("load.value", value),))

    def value(self, t: np.ndarray | float) -> np.ndarray:
        """Λ(t)."""
        return np.asarray(np.interp(t, self.times, self.values))

    def padded(self) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        pad = HISTORY_POINTS - t.size
        last = t[-1]
        return (
            np.concatenate([t, last + 1.0 + np.arange(pad)]),
            np.concatenate([v, np.full(pad, v[-1])]),
        )
