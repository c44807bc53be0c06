"""Design parameters of a model as one vector, named as the TOML configuration names them.

:func:`design_parameters` lists the scalars a design is made of — R, l, β (or b), every
coefficient and transition of every law set, per-fold laws where the tube has them, and the
load — and :class:`ParameterSet` maps a vector of their values back to the traced model
parameters (:class:`~biplan.model.params.ModelParams`) and the
:class:`~biplan.model.params.Load`.
The map is a JAX function, so the residual and the observables can be differentiated with
respect to the design by autodiff, and it is the same map a finite-difference check re-solves
with (:meth:`ParameterSet.model_at`).

Names (units):

* ``geometry.radius`` (mm), ``geometry.pitch`` (mm), and ``geometry.helical_angle`` (deg) or,
  with :attr:`AngleParameter.B`, ``geometry.b`` (1): β then follows from
  cos β = l / (2πR b), so R and l are varied at fixed b;
* ``laws.helical.stiffness`` (N/mm²) for a linear law; ``laws.circular.stiffness[0..2]``
  (N/mm²) and ``laws.circular.transitions[0..1]`` (mm, the table entries [l1, l2] under the
  tube's ``transition_reading``) for a trilinear one. A set's name covers every fold with the
  set's most common law (as :func:`biplan.io.config.dump_config` writes it); a fold with
  another law is named by its index, ``laws.circular[0].stiffness[1]`` (and every fold is,
  with ``per_fold=True``);
* ``load.force`` (N) or ``load.displacement`` (mm).
"""

from __future__ import annotations

import copy
import enum
import math
from collections import Counter
from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import numpy as np

from biplan._compile.setup import jnp
from biplan._errors import ConfigError
from biplan.geometry import Development, chain
from biplan.laws import LinearLaw, TrilinearLaw
from biplan.model.assembly import Load, Model
from biplan.model.params import ModelParams
from biplan.model.tube import Tube
from biplan.options import TransitionReading

__all__ = ["AngleParameter", "Parameter", "ParameterSet", "design_parameters"]

Array = Any


class AngleParameter(enum.Enum):
    """Which crease-angle parameter is varied (and which is held when R or l vary)."""

    HELICAL_ANGLE = "helical_angle"  # β [deg]
    B = "b"  # b = (l / cos β) / (2πR)


@dataclass(frozen=True)
class Parameter:
    """One design parameter: its configuration name, unit, value at the base design and valid
    range (low, high) [unit] (open; ±inf where unbounded; a range that depends on other
    parameters, such as β < atan(2πR/l) or w2 > w1, is taken at the base design)."""

    name: str
    unit: str
    value: float
    low: float = -math.inf
    high: float = math.inf


class Maps(NamedTuple):
    """Traced arrays of the linear part of the map (laws): ModelParams.helical and .circular
    are their base value plus Σ_i (v_i − v0_i) · mask_i."""

    base: ModelParams
    values: Array  # (n,) v0
    helical: Array  # (n, N, 5)
    circular: Array  # (n, Nc, 5)


@dataclass(frozen=True)
class ParameterSet:
    """The parameters of one model and state, and the map from their values to the model.

    Attributes
    ----------
    parameters : tuple of Parameter
        In order: geometry (3), laws, then the load (last).
    angle : AngleParameter
    displacement_control : bool
        Whether the load parameter is the prescribed displacement U [mm] (else the force F [N]).
    maps : Maps
    groups : tuple
        (name prefix, fold set, folds) of every law parameter group.
    """

    parameters: tuple[Parameter, ...]
    angle: AngleParameter
    displacement_control: bool
    maps: Maps
    groups: tuple[tuple[str, str, tuple[int, ...]], ...] = ()  # (prefix, fold set, folds)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def values(self) -> np.ndarray:
        return np.asarray([p.value for p in self.parameters])

    def index(self, name: str) -> int:
        """Position of the parameter ``name``; raises :class:`ConfigError` if unknown."""
        if name not in self.names:
            raise ConfigError("parameter", name, f"one of {', '.join(self.names)}")
        return self.names.index(name)

    def apply(self, values: Array) -> tuple[ModelParams, Load]:
        """(ModelParams, Load) at the parameter values ``values`` (n,); JAX-traceable."""
        return apply(self.maps, self.angle, self.displacement_control, values)

    def model_at(self, model: Model, values: Array) -> tuple[Model, Load]:
        """A copy of ``model`` with the parameters at ``values``, and the load there (for
        re-solves; the copy shares the compiled kernels)."""
        params, load = self.apply(jnp.asarray(values, dtype=jnp.float64))
        out = copy.copy(model)
        out.params = params
        return out, Load(*(float(v) for v in load))

    def tube_at(self, tube: Tube, values: Array) -> Tube:
        """``tube`` with the parameters at ``values``: its geometry and laws rebuilt (validated
        as a configuration is: :class:`ConfigError` on a value out of its range)."""
        v = dict(zip(self.names, (float(x) for x in values), strict=True))
        radius, pitch = v["geometry.radius"], v["geometry.pitch"]
        if self.angle is AngleParameter.B:
            angle = Development.helical_angle_for_b(v["geometry.b"], radius, pitch)
        else:
            angle = v["geometry.helical_angle"]
        laws = {"helical": list(tube.helical_laws), "circular": list(tube.circular_laws)}
        reading = tube.options.transition_reading
        for prefix, fold_set, folds in self.groups:
            old = laws[fold_set][folds[0]]
            law: Any
            if isinstance(old, LinearLaw):
                law = LinearLaw(v[f"{prefix}.stiffness"])
            else:
                k = tuple(v[f"{prefix}.stiffness[{j}]"] for j in range(3))
                t = tuple(v[f"{prefix}.transitions[{j}]"] for j in range(2))
                law = TrilinearLaw.from_table(k, t, reading)  # type: ignore[arg-type]
            for i in folds:
                laws[fold_set][i] = law
        return replace(
            tube,
            development=Development(radius, pitch, angle),
            helical_laws=tuple(laws["helical"]),
            circular_laws=tuple(laws["circular"]),
        )


def apply(
    maps: Maps, angle: AngleParameter, displacement_control: bool, v: Array
) -> tuple[ModelParams, Load]:
    """The map of :meth:`ParameterSet.apply` (a pure function of its traced arguments)."""
    radius, pitch, third = v[0], v[1], v[2]
    if angle is AngleParameter.B:
        beta = jnp.arccos(pitch / (2.0 * jnp.pi * radius * third))
    else:
        beta = jnp.deg2rad(third)
    dv = v - maps.values
    base = maps.base
    params = base._replace(
        geometry=chain.GeometryParams(radius, pitch, beta),
        helical=base.helical + jnp.tensordot(dv, maps.helical, axes=1),
        circular=base.circular + jnp.tensordot(dv, maps.circular, axes=1),
    )
    if displacement_control:
        return params, Load(jnp.asarray(0.0), v[-1], jnp.asarray(1.0))
    return params, Load(v[-1], jnp.asarray(0.0), jnp.asarray(0.0))


def _law_entries(law: Any, row: np.ndarray, reading: TransitionReading) -> list[Parameter]:
    """The parameters (key as name) of a law's table entries, the values read from its
    coefficient row (k1, k2, k3, w1, w2) in the model's parameters."""
    inf = math.inf
    if isinstance(law, LinearLaw):
        return [Parameter("stiffness", "N/mm²", row[0], 0.0)]
    out = [
        Parameter("stiffness[0]", "N/mm²", row[0], 0.0),
        Parameter("stiffness[1]", "N/mm²", row[1]),
        Parameter("stiffness[2]", "N/mm²", row[2], 0.0),
    ]
    if reading is TransitionReading.BRANCH_LENGTHS:  # w1 = l1, w2 = l1 + l2
        return [*out, Parameter("transitions[0]", "mm", row[3], 0.0),
                Parameter("transitions[1]", "mm", row[4] - row[3], 0.0)]  # fmt: skip
    return [*out, Parameter("transitions[0]", "mm", row[3], 0.0, row[4]),
            Parameter("transitions[1]", "mm", row[4], row[3], inf)]  # fmt: skip


#: Columns of (k1, k2, k3, w1, w2) each table entry moves.
_COLUMNS = {
    "stiffness": [0, 1, 2],
    "stiffness[0]": [0],
    "stiffness[1]": [1],
    "stiffness[2]": [2],
    "transitions[0]": [3],
    "transitions[1]": [4],
}


def _law_groups(tube: Any, per_fold: bool) -> list[tuple[str, str, list[int], Any]]:
    """(fold set, name prefix, folds, law): a set's most common law shared by its folds, then
    every other fold on its own (every fold with ``per_fold``)."""
    groups: list[tuple[str, str, list[int], Any]] = []
    for fold_set in ("helical", "circular"):
        laws = getattr(tube, f"{fold_set}_laws")
        if not laws:
            continue
        common = Counter(laws).most_common(1)[0][0]
        shared = [] if per_fold else [i for i, law in enumerate(laws) if law == common]
        if shared:
            groups.append((fold_set, f"laws.{fold_set}", shared, common))
        groups += [
            (fold_set, f"laws.{fold_set}[{i}]", [i], law)
            for i, law in enumerate(laws)
            if i not in shared
        ]
    return groups


def design_parameters(
    model: Model,
    load: Load,
    *,
    angle: AngleParameter = AngleParameter.HELICAL_ANGLE,
    per_fold: bool = False,
) -> ParameterSet:
    """The design parameters of ``model`` under ``load`` (see the module docstring).

    Values are read from the model's traced parameters (``model.params``), so a model from
    :meth:`ParameterSet.model_at` lists its own; names and grouping follow its tube's laws.

    Parameters
    ----------
    model : Model
    load : Load
        Its kind decides the load parameter (``load.force`` [N] or ``load.displacement`` [mm]).
    angle : AngleParameter
        ``HELICAL_ANGLE`` (β [deg], default) or ``B`` (b, with R and l varied at fixed b).
    per_fold : bool
        Name every fold's law separately (default: one name per law shared by a set's folds).

    Returns
    -------
    ParameterSet
    """
    angle = AngleParameter(angle)
    tube = model.tube
    geometry = model.params.geometry
    radius, pitch, beta = (float(v) for v in geometry)
    h = 2 * math.pi * radius
    b = pitch / math.cos(beta) / h
    third = (
        Parameter("geometry.b", "1", b, pitch / h, math.hypot(pitch, h) / h)
        if angle is AngleParameter.B
        else Parameter(
            "geometry.helical_angle", "deg", math.degrees(beta), 0.0,
            min(90.0, math.degrees(math.atan(h / pitch))),
        )
    )  # fmt: skip
    params = [
        Parameter("geometry.radius", "mm", radius, 0.0),
        Parameter("geometry.pitch", "mm", pitch, 0.0),
        third,
    ]
    rows = {k: np.asarray(getattr(model.params, k)) for k in ("helical", "circular")}
    sizes = {"helical": len(tube.helical_laws), "circular": len(tube.circular_laws)}
    reading = tube.options.transition_reading
    entries: list[tuple[str, list[int], list[int]]] = []  # (set, folds, columns) per parameter
    groups = _law_groups(tube, per_fold)
    for fold_set, prefix, folds, law in groups:
        for entry in _law_entries(law, rows[fold_set][folds[0]], reading):
            cols = _COLUMNS[entry.name]
            if reading is TransitionReading.BRANCH_LENGTHS and entry.name == "transitions[0]":
                cols = [3, 4]
            params.append(replace(entry, name=f"{prefix}.{entry.name}", value=float(entry.value)))
            entries.append((fold_set, folds, cols))
    disp = load.is_displacement_controlled
    params.append(
        Parameter("load.displacement", "mm", float(load.displacement))
        if disp
        else Parameter("load.force", "N", float(load.force))
    )
    masks = {k: np.zeros((len(params), n, 5)) for k, n in sizes.items()}
    for i, (fold_set, folds, cols) in enumerate(entries, start=3):
        masks[fold_set][i][np.ix_(folds, cols)] = 1.0
    maps = Maps(
        model.params,
        jnp.asarray([p.value for p in params]),
        jnp.asarray(masks["helical"]),
        jnp.asarray(masks["circular"]),
    )
    layout = tuple((prefix, fold_set, tuple(folds)) for fold_set, prefix, folds, _ in groups)
    return ParameterSet(tuple(params), angle, disp, maps, layout)
