"""What a sensitivity computes and returns: the observables (:class:`Observable`, their units),
the mode of the implicit derivative's linear solves (:class:`Mode`) and the result
(:class:`Sensitivity`, with its elasticities and its table). The computation:
:mod:`biplan.analysis.sensitivity.equilibrium`.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from biplan._errors import ConfigError
from biplan.analysis.sensitivity.parameters import Parameter
from biplan.solvers.newton import Solution

__all__ = [
    "ROWS",
    "SIMPLE_GAP",
    "ZERO_VALUE",
    "Mode",
    "Observable",
    "Sensitivity",
    "derivative_unit",
    "observable",
]


class Observable(enum.Enum):
    """An observable of an equilibrium (or of the first limit point)."""

    U_Z = "u_z"
    U_R = "u_r"
    THETA = "theta"
    FORCE = "force"
    ENERGY = "energy"
    DISPLACEMENT = "displacement"
    MIN_EIGENVALUE = "min_eigenvalue"
    LIMIT_FORCE = "limit_force"
    LIMIT_DISPLACEMENT = "limit_displacement"

    @property
    def unit(self) -> str:
        """Unit of the observable."""
        return _UNITS[self.value]


_UNITS = {
    "u_z": "mm",
    "u_r": "mm",
    "theta": "rad",
    "force": "N",
    "energy": "N·mm",
    "displacement": "mm",
    "min_eigenvalue": "H_r",
    "limit_force": "N",
    "limit_displacement": "mm",
}
#: The observables of an equilibrium, in the rows of the sensitivity functions' output.
ROWS = (
    Observable.U_Z,
    Observable.U_R,
    Observable.THETA,
    Observable.FORCE,
    Observable.ENERGY,
    Observable.DISPLACEMENT,
    Observable.MIN_EIGENVALUE,
)


#: λ_min counts as repeated (not differentiable) when the next eigenvalue is within this,
#: relative to max(|λ_min|, 1).
SIMPLE_GAP = 1e-8


class Mode(enum.Enum):
    """Mode of the implicit derivative's linear solves (as forward/reverse-mode AD)."""

    AUTO = "auto"  # adjoint when fewer observables than parameters
    ADJOINT = "adjoint"  # one solve with Jᵀ per observable
    DIRECT = "direct"  # one solve with J per parameter


#: |y| at most this [mm, rad, N, N·mm] is zero for :attr:`Sensitivity.elasticities`: a
#: nanometre, a nanoradian, a nanonewton, far below anything the model resolves.
ZERO_VALUE = 1e-9


@dataclass(frozen=True)
class Sensitivity:
    """Derivatives of observables with respect to design parameters at one state.

    Attributes
    ----------
    observables : tuple of Observable
    parameters : tuple of Parameter
    values : ndarray
        Observable values y (n_obs,) [their units].
    derivatives : ndarray
        dy/dp (n_obs, n_par) [observable unit / parameter unit].
    left_out : tuple of str
        Why an observable of the default set is not among ``observables`` (λ_min of a
        contact-locked state, or a repeated one: no derivative).
    """

    observables: tuple[Observable, ...]
    parameters: tuple[Parameter, ...]
    values: np.ndarray
    derivatives: np.ndarray
    state: Solution | None = field(default=None, repr=False, compare=False)
    left_out: tuple[str, ...] = ()

    @property
    def elasticities(self) -> np.ndarray:
        """(p / y) dy/dp (n_obs, n_par), dimensionless; NaN where |y| ≤ :data:`ZERO_VALUE`
        (no relative change of a quantity that is zero, or rounding: the end displacement of
        a contact-locked tube, 4e-12 mm)."""
        p = np.asarray([par.value for par in self.parameters])
        with np.errstate(divide="ignore", invalid="ignore"):
            out = self.derivatives * p[None, :] / self.values[:, None]
        return np.where(np.abs(self.values[:, None]) <= ZERO_VALUE, np.nan, out)

    def derivative(self, observable: Observable | str, parameter: str) -> float:
        """dy/dp of one observable and one parameter (by name)."""
        obs = Observable(observable)
        names = [p.name for p in self.parameters]
        if obs not in self.observables:
            valid = ", ".join(o.value for o in self.observables)
            raise ConfigError("observable", obs.value, f"one of {valid}")
        if parameter not in names:
            raise ConfigError("parameter", parameter, f"one of {', '.join(names)}")
        return float(self.derivatives[self.observables.index(obs), names.index(parameter)])

    def to_dataframe(self) -> Any:
        """One row per (observable, parameter): ``observable, parameter, value, unit,
        elasticity, observable_value, parameter_value`` (``value`` = dy/dp in ``unit``)."""
        import pandas as pd

        el = self.elasticities
        rows = [
            {
                "observable": obs.value,
                "parameter": par.name,
                "value": float(self.derivatives[i, j]),
                "unit": derivative_unit(obs.unit, par.unit),
                "elasticity": float(el[i, j]),
                "observable_value": float(self.values[i]),
                "parameter_value": par.value,
            }
            for i, obs in enumerate(self.observables)
            for j, par in enumerate(self.parameters)
        ]
        return pd.DataFrame(rows)


def derivative_unit(numerator: str, denominator: str) -> str:
    """Unit of d(numerator)/d(denominator), e.g. ``mm/(N/mm²)``; ``1`` divides out."""
    if denominator == "1":
        return numerator
    if any(c in denominator for c in "/·"):
        denominator = f"({denominator})"
    return f"{numerator}/{denominator}"


def observable(o: Observable | str) -> Observable:
    try:
        found = Observable(o)
    except ValueError:
        found = None
    if found not in ROWS:
        valid = ", ".join(r.value for r in ROWS)
        raise ConfigError("observable", getattr(o, "value", o), f"one of {valid}")
    return found  # type: ignore[return-value]
