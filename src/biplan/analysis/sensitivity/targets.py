"""The targets of an inverse design and its result: :class:`Target` (an observable's value at a
load, a reached state or the first limit point; parsed from ``OBSERVABLE[/l0]=VALUE[@…]``),
:func:`check_targets` and :class:`DesignResult`. The search:
:func:`biplan.analysis.sensitivity.inverse.inverse_design`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np

from biplan._errors import ConfigError, check_finite
from biplan.analysis.sensitivity.observables import Observable
from biplan.analysis.states.labels import bistable_folds, label_to_bits
from biplan.model.assembly import Load
from biplan.model.tube import Tube

__all__ = ["LIMITS", "DesignResult", "Target", "check_targets"]

#: The first-limit-point observables (a target of the tube's first instability, no load).
LIMITS = (Observable.LIMIT_FORCE, Observable.LIMIT_DISPLACEMENT)
_SYNTAX = re.compile(r"^\s*(\w+)(/l0)?\s*=\s*([^@\s]+)\s*(?:@\s*(F|U|state)\s*=\s*(\S+))?\s*$")
_VALID = "OBSERVABLE[/l0]=VALUE[@F=FORCE|@U=DISPLACEMENT|@state=LABEL], e.g. u_z/l0=0.06@F=1.6"


@dataclass(frozen=True)
class Target:
    """One wanted value of an observable.

    Attributes
    ----------
    observable : Observable
    value : float
        Wanted value [observable unit, or 1 when ``per_length``].
    load : Load or None
        Where (None for the limit-point observables; zero end force for a named state).
    per_length : bool
        The observable divided by l0 = N l (u_z/l0, u_r/l0).
    state : str or None
        Hexadecimal label of a stable state at zero end load (:mod:`biplan.analysis.states.labels`).
    """

    observable: Observable
    value: float
    load: Load | None = None
    per_length: bool = False
    state: str | None = None

    def __post_init__(self) -> None:
        limit = self.observable in LIMITS
        if limit and (self.load is not None or self.state is not None):
            raise ConfigError("target", self.label, f"no load for {self.observable.value}")
        if not limit and self.load is None:
            raise ConfigError("target", self.label, "a load: OBSERVABLE=VALUE@F=… or @U=…")
        if self.state is not None and (
            self.load is None or self.load.is_displacement_controlled or float(self.load.force)
        ):
            raise ConfigError("target", self.label, "a named state at zero end force")

    @classmethod
    def parse(cls, text: str) -> Target:
        """A target from ``OBSERVABLE[/l0]=VALUE[@F=FORCE | @U=DISPLACEMENT | @state=LABEL]``."""
        match = _SYNTAX.match(text)
        if match is None:
            raise ConfigError("target", text, _VALID)
        name, per, value, kind, at = match.groups()
        try:
            obs = Observable(name)
        except ValueError:
            names = ", ".join(o.value for o in Observable)
            raise ConfigError("target", text, f"an observable among {names}") from None
        if kind == "state" and not re.fullmatch(r"[0-9A-Fa-f]+", at):
            raise ConfigError("target", text, "a hexadecimal state label after @state=")
        try:
            number = check_finite("target", float(value))
            if kind == "state":
                return cls(obs, number, Load.of_force(0.0), per is not None, at.upper())
            load = None
            if kind is not None:
                x = check_finite("target", float(at))
                load = Load.of_force(x) if kind == "F" else Load.of_displacement(x)
        except ValueError:
            raise ConfigError("target", text, _VALID) from None
        return cls(obs, number, load, per is not None)

    @property
    def label(self) -> str:
        """The text form."""
        name = self.observable.value + ("/l0" if self.per_length else "")
        if self.load is None:
            return f"{name}={self.value:g}"
        if self.state is not None:
            return f"{name}={self.value:g}@state={self.state}"
        if self.load.is_displacement_controlled:
            return f"{name}={self.value:g}@U={float(self.load.displacement):g}"
        return f"{name}={self.value:g}@F={float(self.load.force):g}"


@dataclass(frozen=True)
class DesignResult:
    """Outcome of :func:`inverse_design`.

    Attributes
    ----------
    names : tuple of str
        The varied parameters.
    values : ndarray
        Their values in the best design found [their units].
    start : ndarray
        Their values in the given design.
    targets : tuple of Target
    achieved : ndarray
        The targets' observables in the best design.
    met : ndarray of bool
        Per target: |y − t| ≤ tolerance · max(|t|, SCALE_FLOOR).
    jacobian : ndarray
        ∂y/∂p of the targets with respect to the varied parameters in the best design.
    tube : Tube
        The best design.
    iterations : int
        Evaluations of the targets and their derivatives, over all starts.
    starts : int
        Starts tried.
    message : str
    """

    names: tuple[str, ...]
    values: np.ndarray
    start: np.ndarray
    targets: tuple[Target, ...]
    achieved: np.ndarray
    met: np.ndarray
    jacobian: np.ndarray
    tube: Tube = field(repr=False)
    iterations: int
    starts: int
    message: str

    @property
    def success(self) -> bool:
        return bool(np.all(self.met))


def check_targets(tube: Tube, targets: tuple[Target, ...]) -> None:
    """Refuse a named-state target whose label cannot name a state of ``tube`` (ConfigError)."""
    n_bits = len(bistable_folds(tube))
    for t in targets:
        if t.state is None:
            continue
        if not n_bits:
            raise ConfigError("target", t.label, "@state= on a tube with bistable folds")
        try:
            label_to_bits(t.state, n_bits)
        except ConfigError as err:
            raise ConfigError("target", t.label, f"a state label of {err.valid}") from None
