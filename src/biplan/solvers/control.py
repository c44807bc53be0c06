"""What a path or trajectory controls: end force, end displacement or internal pressure.

A :class:`Control` names the load parameter Λ and its final value. Λ enters the loading
affinely, (F, U, d) = (c_F Λ, c_U Λ, d) (:meth:`Control.coefficients`):

* force F [N] — a dead axial end force (MODEL CHOICE W1);
* displacement U [mm] — the prescribed axial displacement of the load point, reaction −μ;
* pressure p [MPa = N/mm²] — the paper's pneumatic actuation: internal pressure on a closed
  tube, acting as the end force F = p π R² (R the tube radius).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from biplan._errors import ConfigError, check_finite
from biplan.model.assembly import Load, Model

__all__ = ["Control", "ControlKind"]


class ControlKind(enum.Enum):
    """The controlled quantity."""

    FORCE = "force"
    DISPLACEMENT = "displacement"
    PRESSURE = "pressure"

    @property
    def unit(self) -> str:
        return {"force": "N", "displacement": "mm", "pressure": "MPa"}[self.value]


@dataclass(frozen=True)
class Control:
    """A controlled load parameter and the value at which a path stops.

    Parameters
    ----------
    kind : ControlKind
    stop : float
        Final value of the parameter: F [N], U [mm] or p [MPa].
    start : float, optional
        Initial value; default: the value of the starting state (0 for the relaxed
        reference).
    """

    kind: ControlKind
    stop: float
    start: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.kind, ControlKind):
            try:
                object.__setattr__(self, "kind", ControlKind(self.kind))
            except ValueError:
                raise ConfigError(
                    "control.kind", self.kind, "'force', 'displacement' or 'pressure'"
                ) from None
        object.__setattr__(self, "stop", check_finite("control.stop", self.stop))
        if self.start is not None:
            object.__setattr__(self, "start", check_finite("control.start", self.start))

    @classmethod
    def force(cls, stop: float, start: float | None = None) -> Control:
        """End force F [N] from ``start`` to ``stop``."""
        return cls(ControlKind.FORCE, stop, start)

    @classmethod
    def displacement(cls, stop: float, start: float | None = None) -> Control:
        """Load-point displacement U [mm] from ``start`` to ``stop``."""
        return cls(ControlKind.DISPLACEMENT, stop, start)

    @classmethod
    def pressure(cls, stop: float, start: float | None = None) -> Control:
        """Internal pressure p [MPa = N/mm²] from ``start`` to ``stop`` (1 kPa = 1e-3 MPa)."""
        return cls(ControlKind.PRESSURE, stop, start)

    @property
    def is_displacement(self) -> bool:
        return self.kind is ControlKind.DISPLACEMENT

    def coefficients(self, model: Model) -> np.ndarray:
        """(c_F, c_U, d): Load(F = c_F Λ, U = c_U Λ, d)."""
        if self.kind is ControlKind.FORCE:
            return np.array([1.0, 0.0, 0.0])
        if self.kind is ControlKind.DISPLACEMENT:
            return np.array([0.0, 1.0, 1.0])
        return np.array([self.end_area(model), 0.0, 0.0])

    @staticmethod
    def end_area(model: Model) -> float:
        """π R² [mm²]: the end area the internal pressure acts on."""
        return float(np.pi * model.tube.development.radius**2)

    def load(self, model: Model, value: float) -> Load:
        """The Load at parameter value Λ."""
        if self.kind is ControlKind.FORCE:
            return Load.of_force(value)
        if self.kind is ControlKind.DISPLACEMENT:
            return Load.of_displacement(value)
        return Load.of_pressure(value, model.tube.development.radius)

    def value_of(self, load: Load, displacement: float, force: float, model: Model) -> float:
        """The parameter value of a solved state (its load, z_p [mm] and end force [N])."""
        if self.kind is ControlKind.FORCE:
            return float(force)
        if self.kind is ControlKind.DISPLACEMENT:
            return float(displacement)
        return float(force) / self.end_area(model)
