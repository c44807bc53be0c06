"""Trilinear bistable fold law (main Eqs. stiffness, field_constitutive_energy; MODEL.md §1)."""

from __future__ import annotations

from dataclasses import dataclass

from biplan._errors import ConfigError, check_finite
from biplan.laws._base import LawMixin
from biplan.options import TransitionReading

__all__ = ["TrilinearLaw"]


@dataclass(frozen=True)
class TrilinearLaw(LawMixin):
    """Piecewise-linear differential stiffness with two breakpoints.

    ``k(w) = k1 (w < w1), k2 (w1 ≤ w < w2), k3 (w ≥ w2)``; F = ∫k, Ψ = ∫F.

    Parameters
    ----------
    stiffness : (float, float, float)
        (k1, k2, k3) [N/mm²]; k1 > 0 and k3 > 0, k2 any finite value (k2 < 0 for bistability).
    transitions : (float, float)
        Breakpoint elongations (w1, w2) [mm] with 0 < w1 < w2.

    Raises
    ------
    ConfigError
        On non-finite numbers, k1 ≤ 0, k3 ≤ 0, w1 ≤ 0 or w1 ≥ w2.
    """

    stiffness: tuple[float, float, float]
    transitions: tuple[float, float]

    def __post_init__(self) -> None:
        if len(self.stiffness) != 3:
            raise ConfigError("stiffness", self.stiffness, "three numbers (k1, k2, k3) in N/mm²")
        if len(self.transitions) != 2:
            raise ConfigError("transitions", self.transitions, "two numbers (w1, w2) in mm")
        k = tuple(check_finite(f"stiffness[{i}]", v) for i, v in enumerate(self.stiffness))
        t = tuple(check_finite(f"transitions[{i}]", v) for i, v in enumerate(self.transitions))
        if k[0] <= 0:
            raise ConfigError("stiffness[0] (k1)", k[0], "> 0 N/mm² (stable closed branch)")
        if k[2] <= 0:
            raise ConfigError("stiffness[2] (k3)", k[2], "> 0 N/mm² (stable open branch)")
        if t[0] <= 0:
            raise ConfigError("transitions[0] (w1)", t[0], "> 0 mm")
        if t[1] <= t[0]:
            raise ConfigError("transitions[1] (w2)", t[1], f"> transitions[0] = {t[0]} mm")
        object.__setattr__(self, "stiffness", k)
        object.__setattr__(self, "transitions", t)

    @classmethod
    def from_table(
        cls,
        stiffness: tuple[float, float, float],
        transitions: tuple[float, float],
        reading: TransitionReading | str = TransitionReading.ABSOLUTE,
    ) -> TrilinearLaw:
        """Build a law from a calibration table entry under a :class:`TransitionReading`."""
        try:
            reading = TransitionReading(reading)
        except ValueError:
            valid = ", ".join(r.value for r in TransitionReading)
            raise ConfigError("transition_reading", reading, f"one of {valid}") from None
        t1, t2 = (check_finite(f"transitions[{i}]", v) for i, v in enumerate(transitions))
        if reading is TransitionReading.BRANCH_LENGTHS:
            if t2 <= 0:
                raise ConfigError("transitions[1] (spinodal length)", t2, "> 0 mm")
            t2 = t1 + t2
        return cls(stiffness=stiffness, transitions=(t1, t2))

    @property
    def coefficients(self) -> tuple[float, float, float, float, float]:
        """(k1, k2, k3, w1, w2) for the compiled kernels and the JAX functions."""
        return (*self.stiffness, *self.transitions)

    # --- characteristic points -------------------------------------------------------------
    @property
    def peak_force(self) -> float:
        """F1 = k1 w1 [N/mm], the closed branch's limit force."""
        return self.stiffness[0] * self.transitions[0]

    @property
    def valley_force(self) -> float:
        """F2 = F1 + k2 (w2 − w1) [N/mm], the spinodal's end force."""
        return self.peak_force + self.stiffness[1] * (self.transitions[1] - self.transitions[0])

    @property
    def is_bistable(self) -> bool:
        """True when Ψ has two wells at zero load (F2 < 0 with k2 < 0)."""
        return self.stiffness[1] < 0 and self.valley_force < 0

    def require_bistable(self, name: str = "law") -> TrilinearLaw:
        """Return self, or raise :class:`ConfigError` if the law is not bistable."""
        if not self.is_bistable:
            raise ConfigError(
                name,
                self,
                "a bistable law: k2 < 0 and F2 = k1 w1 + k2 (w2 − w1) < 0 "
                f"(here F2 = {self.valley_force:.4g} N/mm)",
            )
        return self

    def wells(self) -> tuple[float, ...]:
        """Zero-force stable elongations [mm]: (0,) or (0, w_s) with w_s = w2 + |F2|/k3."""
        if not self.is_bistable:
            return (0.0,)
        return (0.0, self.transitions[1] - self.valley_force / self.stiffness[2])

    def hilltop(self) -> float:
        """Unstable zero-force elongation w_b = w1 + F1/|k2| [mm] (bistable laws only)."""
        self.require_bistable()
        return self.transitions[0] + self.peak_force / abs(self.stiffness[1])

    def spinodal(self) -> tuple[float, float]:
        """Elongation interval (w1, w2) [mm] of negative differential stiffness."""
        return self.transitions

    def barrier(self) -> tuple[float, float]:
        """Energy-density barriers [N]: (closed → open, open → closed).

        These are (Ψ(w_b), Ψ(w_b) − Ψ(w_s)).
        """
        wb = self.hilltop()
        ws = self.wells()[1]
        psi_b = float(self.energy_density(wb))
        return psi_b, psi_b - float(self.energy_density(ws))
