"""Sweep grids: axes of design (and load) parameters and how a value is applied to a tube.

:class:`Grid` is a tensor product of :class:`GridAxis` (row-major, the last axis fastest);
:func:`parse_axis` reads ``"START:STOP:N"``, ``"START:STOP:Nlog"`` or lists;
:func:`apply_values` derives the tube of a grid point from the base design (b through β at
fixed R and l, C through k_helic with the circular law fixed, MODEL.md §3).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from biplan._errors import ConfigError, check_finite
from biplan.analysis.maps.cost import MAX_MODULES
from biplan.geometry.development import Development
from biplan.laws import FoldLaw, LinearLaw, TrilinearLaw
from biplan.model.tube import Tube, initial_stiffness

__all__ = ["QUANTITIES", "Grid", "GridAxis", "apply_values", "base_value", "parse_axis"]

_GEOMETRY = ("radius", "pitch", "helical_angle", "n_modules")
_COEFFS = ("k1", "k2", "k3", "w1", "w2")
#: Sweepable quantities: geometry [mm, deg], N, the ratios b and C, and any law coefficient
#: ``helical.k1`` … ``circular.w2`` [N/mm², mm] (applied to every fold of the set).
QUANTITIES = (*_GEOMETRY, "b", "C", *(f"{s}.{c}" for s in ("helical", "circular") for c in _COEFFS))
_UNITS = {
    "radius": "mm",
    "pitch": "mm",
    "helical_angle": "deg",
    "n_modules": "1",
    "b": "1",
    "C": "1",
    "displacement": "1 (U / l0)",
}


@dataclass(frozen=True)
class GridAxis:
    """One axis of a sweep grid.

    Parameters
    ----------
    name : str
        A quantity of :data:`QUANTITIES` or an evaluator's load axis (``displacement``).
    values : tuple of float
        The values, in the unit of the quantity (see :data:`QUANTITIES`).
    """

    name: str
    values: tuple[float, ...]

    def __post_init__(self) -> None:
        vals = tuple(check_finite(f"grid.{self.name}", v) for v in self.values)
        if not vals:
            raise ConfigError(f"grid.{self.name}", self.values, "at least one value")
        object.__setattr__(self, "values", vals)

    @property
    def unit(self) -> str:
        """Unit of the axis values."""
        if self.name in _UNITS:
            return _UNITS[self.name]
        return "N/mm^2" if self.name.split(".")[-1].startswith("k") else "mm"


@dataclass(frozen=True)
class Grid:
    """A tensor-product grid of design (and load) parameters, row-major, last axis fastest."""

    axes: tuple[GridAxis, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "axes", tuple(self.axes))
        if not self.axes:
            raise ConfigError("grid", (), "at least one axis")
        names = [a.name for a in self.axes]
        if len(set(names)) != len(names):
            raise ConfigError("grid", names, "distinct axis names")

    @classmethod
    def of(cls, **axes: Sequence[float] | str | np.ndarray) -> Grid:
        """``Grid.of(b="0.4:0.7:4", C=[1, 2])`` — each axis from a spec or a list."""
        return cls(tuple(parse_axis(k, v) for k, v in axes.items()))

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a.values) for a in self.axes)

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(a.name for a in self.axes)

    def point(self, index: int) -> dict[str, float]:
        """Parameter values of the flat (row-major) point ``index``."""
        idx = np.unravel_index(index, self.shape)
        return {a.name: a.values[int(i)] for a, i in zip(self.axes, idx, strict=True)}


_SPEC = re.compile(r"^\s*([^:]+):([^:]+):([^:]+)\s*$")


def parse_axis(name: str, spec: Sequence[float] | str | np.ndarray) -> GridAxis:
    """A grid axis from ``"START:STOP:N"`` (N evenly spaced values, both ends included),
    ``"START:STOP:Nlog"`` (N log-spaced values, both ends > 0: for a ratio such as C that
    spans decades), a comma-separated list ``"1.0,1.5,2"`` or a sequence of numbers.

    Raises
    ------
    ConfigError
        Naming the axis, the spec and the valid form, on malformed or non-finite input.
    """
    if isinstance(spec, str):
        m = _SPEC.match(spec)
        if m:
            count = m.group(3).strip()
            log = count.lower().endswith("log")
            form = "START:STOP:Nlog" if log else "START:STOP:N"
            try:
                start, stop = float(m.group(1)), float(m.group(2))
                n = int(count[:-3] if log else count)
            except ValueError:
                raise ConfigError(name, spec, f"{form} with numbers and an integer N") from None
            if n < 1 or not (math.isfinite(start) and math.isfinite(stop)):
                raise ConfigError(name, spec, f"{form} with finite ends and N ≥ 1")
            if n > 1 and start == stop:
                raise ConfigError(name, spec, "START ≠ STOP when N > 1")
            if log and min(start, stop) <= 0:
                raise ConfigError(name, spec, "START:STOP:Nlog with START > 0 and STOP > 0")
            spaced = np.geomspace(start, stop, n) if log else np.linspace(start, stop, n)
            return GridAxis(name, tuple(spaced.tolist()))
        try:
            values = [float(v) for v in spec.split(",") if v.strip()]
        except ValueError:
            raise ConfigError(
                name, spec, "START:STOP:N, START:STOP:Nlog or a comma-separated list"
            ) from None
        return GridAxis(name, tuple(values))
    arr = np.asarray(spec, dtype=float).ravel()
    return GridAxis(name, tuple(arr.tolist()))


def _law_with(law: FoldLaw, coefficient: str, value: float) -> FoldLaw:
    k = list(law.coefficients[:3]) if isinstance(law, TrilinearLaw) else None
    if isinstance(law, LinearLaw):
        if coefficient != "k1":
            raise ConfigError(coefficient, value, "k1 only for a linear (single-branch) law")
        return LinearLaw(value)
    assert k is not None
    if coefficient.startswith("k"):
        k[int(coefficient[1]) - 1] = value
        return replace(law, stiffness=(k[0], k[1], k[2]))
    w = list(law.transitions)
    w[int(coefficient[1]) - 1] = value
    return replace(law, transitions=(w[0], w[1]))


def base_value(tube: Tube, name: str) -> float | None:
    """The value of the quantity ``name`` of :data:`QUANTITIES` in ``tube`` (the inverse of
    :func:`apply_values`; a law coefficient is read from the first law of the set), or None
    for a load axis (``displacement``) or a coefficient the law does not have."""
    dev = tube.development
    if name in ("radius", "pitch", "helical_angle"):
        return float(getattr(dev, name))
    if name == "n_modules":
        return float(tube.n_modules)
    if name in ("b", "C"):
        return float(getattr(tube, name))
    if "." not in name:
        return None
    fold_set, coefficient = name.split(".", 1)
    laws = getattr(tube, f"{fold_set}_laws", ())
    if not laws or coefficient not in _COEFFS:
        return None
    law = laws[0]
    if isinstance(law, LinearLaw):
        return float(law.stiffness) if coefficient == "k1" else None
    index = int(coefficient[1]) - 1
    values = law.stiffness if coefficient.startswith("k") else law.transitions
    return float(values[index])


def _scaled(law: FoldLaw, factor: float) -> FoldLaw:
    if isinstance(law, LinearLaw):
        return LinearLaw(law.stiffness * factor)
    k1, k2, k3 = law.stiffness
    return replace(law, stiffness=(k1 * factor, k2 * factor, k3 * factor))


def apply_values(tube: Tube, values: Mapping[str, float]) -> Tube:
    """A copy of ``tube`` with the design parameters ``values`` set.

    ``b`` is set through β at fixed R and l; ``C`` through the helical stiffness (every helical
    law scaled so that its k1 = C · k1 of the base-most circular law, circular laws fixed).
    Geometry is applied before b, and b before C; other names (load axes) are ignored.

    Raises
    ------
    ConfigError
        When a value is out of its valid range (e.g. b ≤ l/H) or the name is unknown.
    """
    dev = tube.development
    geo = {"radius": dev.radius, "pitch": dev.pitch, "helical_angle": dev.helical_angle}
    n = tube.n_modules
    for name in ("radius", "pitch", "helical_angle"):
        if name in values:
            geo[name] = float(values[name])
    if "n_modules" in values:
        v = values["n_modules"]
        if float(v) != round(float(v)) or not 1 <= v <= MAX_MODULES:
            raise ConfigError("n_modules", v, f"an integer in [1, {MAX_MODULES}]")
        n = round(float(v))
    if "b" in values:
        geo["helical_angle"] = Development.helical_angle_for_b(
            values["b"], geo["radius"], geo["pitch"]
        )
    out = tube
    if n != tube.n_modules:
        nc = n - 1 + int(tube.base_fold)
        if nc and not tube.circular_laws:
            raise ConfigError(
                "n_modules", values["n_modules"],
                "1 for this tube: it has no circular fold whose law the added ones would take",
            )  # fmt: skip
        out = replace(
            out, n_modules=n, helical_laws=(tube.helical_laws[0],) * n,
            circular_laws=(tube.circular_laws[0],) * nc,
        )  # fmt: skip
    out = replace(out, development=Development(**geo))
    for name, value in values.items():
        if "." in name:
            fold_set, coefficient = name.split(".", 1)
            if fold_set not in ("helical", "circular") or coefficient not in _COEFFS:
                raise ConfigError("grid axis", name, f"one of {', '.join(QUANTITIES)}")
            laws = tuple(
                _law_with(law, coefficient, float(value))
                for law in getattr(out, f"{fold_set}_laws")
            )
            if fold_set == "helical":
                out = replace(out, helical_laws=laws)
            else:
                out = replace(out, circular_laws=laws)
        elif name not in (*_GEOMETRY, "b", "C", "displacement"):
            raise ConfigError("grid axis", name, f"one of {', '.join(QUANTITIES)}")
    if "C" in values:
        c = check_finite("C", values["C"])
        if c <= 0:
            raise ConfigError("C", c, "> 0")
        if not out.circular_laws:
            raise ConfigError(
                "C", c, "a grid axis of a tube with a circular fold (C sets the helical laws "
                "against the base-most circular law; this tube has none)",
            )  # fmt: skip
        k_target = c * initial_stiffness(out.circular_laws[0])
        laws = tuple(
            _scaled(law, k_target / initial_stiffness(out.helical_laws[0]))
            for law in out.helical_laws
        )
        out = replace(out, helical_laws=laws)
    return out
