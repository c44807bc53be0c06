"""Reading the sections of a TOML tube configuration (the schema: :mod:`biplan.io.config`).

:class:`ConfigReader` gives typed access to a parsed TOML document; every invalid entry raises
:class:`ConfigFileError` with its dotted key and the file path. :func:`read_geometry`,
:func:`read_options` and :func:`read_laws` read ``[geometry]``, ``[options]`` and ``[laws]``
into the keyword arguments of :class:`~biplan.model.tube.Tube` (units: mm, N, s, t, degrees);
:func:`biplan.io.config.tube_from_dict` puts them together.
"""

from __future__ import annotations

import enum
import math
import numbers
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import fields
from typing import Any

from biplan._errors import ConfigError, CostWarning
from biplan.analysis.maps.cost import LARGE_MODULES, MAX_MODULES, duration, tube_cost
from biplan.geometry import Development
from biplan.laws import FoldLaw, LinearLaw, TrilinearLaw
from biplan.options import ModelOptions, TransitionReading

__all__ = [
    "FOLD_SETS",
    "TOP_KEYS",
    "ConfigFileError",
    "ConfigReader",
    "read_geometry",
    "read_laws",
    "read_options",
]

#: The keys of the top level of a configuration.
TOP_KEYS = ("name", "geometry", "laws", "options")
_GEOMETRY_KEYS = (
    "radius",
    "pitch",
    "helical_angle",
    "b",
    "n_modules",
    "base_fold",
    "surface_density",
)
_LAWS_KEYS = ("helical", "circular", "override")
_LAW_KEYS = ("type", "stiffness", "transitions", "bistable")
_OVERRIDE_KEYS = ("fold", "index", *_LAW_KEYS)
_LAW_TYPES = ("linear", "trilinear")
#: The fold sets, each with a ``[laws.<set>]`` table and ``<set>_laws`` of a Tube.
FOLD_SETS = ("helical", "circular")
_OPTION_FIELDS = {f.name: f for f in fields(ModelOptions)}


class _Missing:
    def __repr__(self) -> str:
        return "<missing>"


_MISSING: Any = _Missing()


class ConfigFileError(ConfigError):
    """A :class:`ConfigError` in a configuration, whose message starts with the file path.

    Parameters
    ----------
    parameter : str
        Dotted TOML key of the offending entry (``"path"`` / ``"toml"`` for file errors).
    value : object
        The value that was given.
    valid : str
        Human-readable description of the valid range.
    source : str
        The file path (or ``"<dict>"`` / ``"<string>"``).
    """

    def __init__(self, parameter: str, value: Any, valid: str, source: str) -> None:
        super().__init__(parameter, value, valid)
        self.source = source
        self.args = (f"{source}: {self.args[0]}",)

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.parameter, self.value, self.valid, self.source))


class ConfigReader:
    """Typed access to a parsed TOML document, raising :class:`ConfigFileError`."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, value: Any, valid: str) -> ConfigFileError:
        """The error for ``key`` (to be raised by the caller)."""
        return ConfigFileError(key, value, valid, self.source)

    @contextmanager
    def renamed(self, prefix: str, names: Mapping[str, str] | None = None) -> Iterator[None]:
        """Re-raise a constructor's :class:`ConfigError` under the dotted key it came from.

        The inner parameter (annotation after a space dropped) becomes ``names[inner]`` if
        listed, else ``prefix.inner``; names that already start with ``prefix.`` are kept.
        """
        try:
            yield
        except ConfigFileError:
            raise
        except ConfigError as err:
            inner = str(err.parameter).split(" ", 1)[0]
            if names is not None and inner in names:
                key = names[inner]
            elif inner == prefix or inner.startswith(f"{prefix}."):
                key = inner
            else:
                key = f"{prefix}.{inner}"
            raise self.fail(key, err.value, err.valid) from None

    def check_keys(self, table: Mapping[str, Any], valid: tuple[str, ...], prefix: str) -> None:
        """Reject keys of ``table`` not in ``valid``."""
        for key, value in table.items():
            if key not in valid:
                where = f"[{prefix}]" if prefix else "the top level"
                raise self.fail(
                    _join(prefix, key),
                    value,
                    f"a known key of {where} (one of: {', '.join(valid)})",
                )

    def table(self, parent: Mapping[str, Any], key: str, prefix: str, *, required: bool) -> dict:
        """A sub-table (``{}`` if absent and not required)."""
        value = parent.get(key, _MISSING)
        if value is _MISSING:
            if required:
                raise self.fail(_join(prefix, key), value, "a table (required)")
            return {}
        if not isinstance(value, Mapping):
            raise self.fail(_join(prefix, key), value, f"a table [{_join(prefix, key)}]")
        return dict(value)

    def require(self, table: Mapping[str, Any], key: str, prefix: str) -> Any:
        """The value of a required key."""
        value = table.get(key, _MISSING)
        if value is _MISSING:
            raise self.fail(_join(prefix, key), value, "given (required key)")
        return value

    def number(self, value: Any, key: str) -> float:
        """A finite real number (Python or NumPy, not bool)."""
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise self.fail(key, value, "a finite real number")
        x = float(value)
        if not math.isfinite(x):
            raise self.fail(key, value, "a finite real number")
        return x

    def positive(self, value: Any, key: str, unit: str) -> float:
        """A finite number > 0."""
        x = self.number(value, key)
        if x <= 0:
            raise self.fail(key, value, f"a finite number > 0 {unit}")
        return x

    def numbers(self, value: Any, key: str, count: int, what: str) -> tuple[float, ...]:
        """An array of exactly ``count`` finite numbers."""
        if not isinstance(value, list | tuple) or len(value) != count:
            raise self.fail(key, value, f"an array of {count} numbers {what}")
        return tuple(self.number(v, f"{key}[{i}]") for i, v in enumerate(value))

    def integer(self, value: Any, key: str, valid: str) -> int:
        """An integer (Python or NumPy, not bool), returned as an int."""
        if isinstance(value, bool) or not isinstance(value, numbers.Integral):
            raise self.fail(key, value, valid)
        return int(value)

    def boolean(self, value: Any, key: str) -> bool:
        """A bool."""
        if not isinstance(value, bool):
            raise self.fail(key, value, "true or false")
        return value

    def string(self, value: Any, key: str) -> str:
        """A str."""
        if not isinstance(value, str):
            raise self.fail(key, value, "a string")
        return value

    def choice(self, value: Any, key: str, valid: tuple[str, ...]) -> str:
        """One of the strings ``valid``."""
        if not isinstance(value, str) or value not in valid:
            raise self.fail(key, value, f"one of {', '.join(repr(v) for v in valid)}")
        return value


def _join(prefix: str, key: str) -> str:
    return f"{prefix}.{key}" if prefix else key


def _read_development(r: ConfigReader, geo: Mapping[str, Any]) -> Development:
    """R, l and β (from ``helical_angle`` or ``b``) of ``[geometry]``."""
    radius = r.positive(r.require(geo, "radius", "geometry"), "geometry.radius", "mm")
    pitch = r.positive(r.require(geo, "pitch", "geometry"), "geometry.pitch", "mm")
    has_angle, has_b = "helical_angle" in geo, "b" in geo
    if has_angle and has_b:
        raise r.fail(
            "geometry.b",
            geo["b"],
            "absent when geometry.helical_angle is given (give exactly one of helical_angle, b)",
        )
    if not (has_angle or has_b):
        raise r.fail("geometry.helical_angle", _MISSING, "given (or geometry.b instead)")
    if not has_b:
        angle = r.number(geo["helical_angle"], "geometry.helical_angle")
        with r.renamed("geometry"):
            return Development(radius, pitch, angle)
    b = r.number(geo["b"], "geometry.b")
    with r.renamed("geometry"):
        angle = Development.helical_angle_for_b(b, radius, pitch)
    try:
        return Development(radius, pitch, angle)
    except ConfigError as err:
        raise r.fail("geometry.b", b, f"such that β = {angle:.6g}° is {err.valid}") from None


def read_geometry(r: ConfigReader, data: Mapping[str, Any]) -> dict[str, Any]:
    """Tube keyword arguments from ``[geometry]``."""
    geo = r.table(data, "geometry", "", required=True)
    r.check_keys(geo, _GEOMETRY_KEYS, "geometry")
    dev = _read_development(r, geo)
    valid = f"an integer in [1, {MAX_MODULES}] (the largest tube biplan builds from a file)"
    n = r.integer(r.require(geo, "n_modules", "geometry"), "geometry.n_modules", valid)
    if not 1 <= n <= MAX_MODULES:
        raise r.fail("geometry.n_modules", n, valid)
    if n > LARGE_MODULES:
        cost = tube_cost(n)
        warnings.warn(
            f"{r.source}: geometry.n_modules = {n} is a large tube: expect about "
            f"{duration(cost.cold_start)} to compile and {duration(cost.step)} per solved "
            "state on a 2-core machine (measured up to 384 modules; docs/performance.md)",
            CostWarning,
            stacklevel=4,
        )
    out: dict[str, Any] = {"development": dev, "n_modules": n}
    out["base_fold"] = r.boolean(geo.get("base_fold", True), "geometry.base_fold")
    if "surface_density" in geo:
        out["surface_density"] = r.positive(
            geo["surface_density"], "geometry.surface_density", "t/mm²"
        )
    return out


def read_options(r: ConfigReader, data: Mapping[str, Any]) -> ModelOptions:
    """``[options]`` (all fields optional)."""
    table = r.table(data, "options", "", required=False)
    r.check_keys(table, tuple(_OPTION_FIELDS), "options")
    kwargs: dict[str, Any] = {}
    for name, value in table.items():
        key = f"options.{name}"
        default = _OPTION_FIELDS[name].default
        if isinstance(default, enum.Enum):
            kwargs[name] = r.choice(value, key, tuple(m.value for m in type(default)))
        elif isinstance(default, bool):
            kwargs[name] = r.boolean(value, key)
        else:
            kwargs[name] = r.number(value, key)
    with r.renamed("options"):
        return ModelOptions(**kwargs)


def _read_law(
    r: ConfigReader, table: Mapping[str, Any], prefix: str, reading: TransitionReading
) -> FoldLaw:
    """A fold law from a law table (keys already checked against the union of law keys)."""
    kind = r.choice(r.require(table, "type", prefix), f"{prefix}.type", _LAW_TYPES)
    stiffness = r.require(table, "stiffness", prefix)
    bistable = r.boolean(table.get("bistable", False), f"{prefix}.bistable")
    law: FoldLaw
    if kind == "linear":
        if "transitions" in table:
            raise r.fail(
                f"{prefix}.transitions", table["transitions"], "absent for type = 'linear'"
            )
        k = r.number(stiffness, f"{prefix}.stiffness")
        with r.renamed(prefix):
            law = LinearLaw(k)
    else:
        ks = r.numbers(stiffness, f"{prefix}.stiffness", 3, "[k1, k2, k3] in N/mm²")
        raw = r.require(table, "transitions", prefix)
        ts = r.numbers(raw, f"{prefix}.transitions", 2, "[l1, l2] in mm")
        with r.renamed(prefix):
            law = TrilinearLaw.from_table(ks, ts, reading)  # type: ignore[arg-type]
    if bistable:
        with r.renamed(prefix):
            law.require_bistable(prefix)
    return law


def _read_set_law(
    r: ConfigReader, laws: Mapping[str, Any], fold_set: str, count: int, reading: TransitionReading
) -> FoldLaw | None:
    """The law of every fold of one set (``None`` if the set is empty and the table absent)."""
    prefix = f"laws.{fold_set}"
    table = r.table(laws, fold_set, "laws", required=count > 0)
    if not table and count == 0:
        return None
    r.check_keys(table, _LAW_KEYS, prefix)
    return _read_law(r, table, prefix, reading)


def _read_overrides(
    r: ConfigReader, laws: Mapping[str, Any], counts: Mapping[str, int], reading: TransitionReading
) -> dict[tuple[str, int], FoldLaw]:
    """``[[laws.override]]`` entries keyed by (fold set, index)."""
    raw = laws.get("override", [])
    if not isinstance(raw, list) or not all(isinstance(t, Mapping) for t in raw):
        raise r.fail("laws.override", raw, "an array of tables ([[laws.override]])")
    out: dict[tuple[str, int], FoldLaw] = {}
    first: dict[tuple[str, int], int] = {}
    for i, table in enumerate(raw):
        prefix = f"laws.override[{i}]"
        r.check_keys(table, _OVERRIDE_KEYS, prefix)
        fold = r.choice(r.require(table, "fold", prefix), f"{prefix}.fold", FOLD_SETS)
        n = counts[fold]
        valid = f"an integer in [0, {n - 1}] (the tube has {n} {fold} folds)"
        if n == 0:
            valid = f"absent: the tube has no {fold} folds"
        index = r.integer(r.require(table, "index", prefix), f"{prefix}.index", valid)
        if not 0 <= index < n:
            raise r.fail(f"{prefix}.index", index, valid)
        if (fold, index) in first:
            j = first[(fold, index)]
            raise r.fail(f"{prefix}.index", index, f"a fold not already set by laws.override[{j}]")
        first[(fold, index)] = i
        law_table = {k: v for k, v in table.items() if k not in ("fold", "index")}
        out[(fold, index)] = _read_law(r, law_table, prefix, reading)
    return out


def read_laws(
    r: ConfigReader,
    data: Mapping[str, Any],
    geometry: Mapping[str, Any],
    reading: TransitionReading,
) -> dict[str, tuple[FoldLaw, ...]]:
    """``helical_laws`` and ``circular_laws`` from ``[laws]``."""
    laws = r.table(data, "laws", "", required=True)
    r.check_keys(laws, _LAWS_KEYS, "laws")
    n = geometry["n_modules"]
    counts = {"helical": n, "circular": n - 1 + int(geometry["base_fold"])}
    per_set = {s: _read_set_law(r, laws, s, counts[s], reading) for s in FOLD_SETS}
    overrides = _read_overrides(r, laws, counts, reading)
    out: dict[str, tuple[FoldLaw, ...]] = {}
    for fold_set in FOLD_SETS:
        base = per_set[fold_set]
        # base is None only for an empty set, so no index reaches it
        chosen = [overrides.get((fold_set, i), base) for i in range(counts[fold_set])]
        out[f"{fold_set}_laws"] = tuple(chosen)  # type: ignore[arg-type]
    return out
