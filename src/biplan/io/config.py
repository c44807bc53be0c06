"""TOML tube configuration: read a :class:`~biplan.model.tube.Tube` from a file and write one back.

Units are mm, N, s (mass in t) and degrees throughout.

Schema
------
::

    name = "semi-bistable MFT (SI Table calib)"   # optional free label, default ""

    [geometry]                # required
    radius = 2.0              # R [mm], > 0
    pitch = 3.6               # l [mm], > 0
    helical_angle = 60.0      # β [deg], in (0, 90) with l tan β < 2πR
    # b = 0.573               # alternative to helical_angle: β from b = (l / cos β) / (2πR)
    n_modules = 6             # N, an integer in [1, 400] (above 48: a warning with the cost)
    base_fold = true          # optional, default true: a circular fold joins module 1 to the clamp
    surface_density = 3.6e-10 # optional, μ [t/mm²], > 0

    [laws.helical]            # the law of every helical fold (N folds)
    type = "linear"           # "linear" | "trilinear"
    stiffness = 1.3           # linear: k [N/mm²]

    [laws.circular]           # the law of every circular fold (N − 1, + 1 if base_fold)
    type = "trilinear"
    stiffness = [0.9, -0.2, 0.6]  # trilinear: [k1, k2, k3] [N/mm²]
    transitions = [0.2, 1.3]      # trilinear: [l1, l2] [mm], read with options.transition_reading
    bistable = true               # optional: true requires a bistable law; false/absent: no check

    [[laws.override]]         # optional, any number: the law of one fold
    fold = "circular"         # "helical" | "circular"
    index = 0                 # from 0 at the base (helical: module index;
                              # circular: fold index, the base fold first)
    type = "linear"           # then the keys of a law table, as above
    stiffness = 2.0

    [options]                 # optional: any ModelOptions field; enum readings as strings
    transition_reading = "absolute"
    mirror = "reflection"

Keys
----
name : str, optional
    Free label of the tube.
geometry.radius, geometry.pitch : float
    R and l [mm].
geometry.helical_angle : float
    β [degrees]. Exactly one of ``helical_angle`` and ``b`` must be given.
geometry.b : float
    Geometric ratio b; β then follows from :meth:`Development.helical_angle_for_b` at the given
    R and l.
geometry.n_modules : int
    Number of modules N, 1 ≤ N ≤ :data:`~biplan.analysis.maps.cost.MAX_MODULES` (400). Above
    :data:`~biplan.analysis.maps.cost.LARGE_MODULES` (48) loading warns (:class:`CostWarning`)
    with the estimated compile time and time per solved state.
geometry.base_fold : bool, optional
    Default ``true``.
geometry.surface_density : float, optional
    Shell surface density μ [t/mm²]; default that of :class:`~biplan.model.tube.Tube`.
laws.helical, laws.circular : table
    ``type`` (``"linear"`` or ``"trilinear"``), ``stiffness`` (a number, or ``[k1, k2, k3]``),
    for trilinear laws ``transitions = [l1, l2]`` and optionally ``bistable``. A set's table
    may be left out only if the tube has no fold of that set.
laws.override : array of tables, optional
    ``fold``, ``index`` and the keys of a law table; each fold may be overridden once.
options : table, optional
    Fields of :class:`~biplan.options.ModelOptions`; ``transition_reading`` decides how every
    ``transitions`` entry becomes breakpoints (:meth:`TrilinearLaw.from_table`).

Errors
------
Every invalid input raises :class:`ConfigFileError` (a :class:`~biplan._errors.ConfigError`)
before anything is built or solved. Its ``parameter`` is the dotted TOML key (for example
``geometry.radius``, ``laws.circular.stiffness[1]``, ``laws.override[1].index``) and its message
starts with the file path. Unknown keys, wrong types, non-finite numbers, out-of-range values,
TOML syntax errors (``parameter = "toml"``) and unreadable files (``parameter = "path"``) are
all reported this way.

Notes
-----
:func:`dump_config` writes a file that loads back to an equal tube. The one exception is
``transition_reading = "branch_lengths"``: l2 = w2 − w1 is written, and for some breakpoints no
float l2 gives w1 + l2 == w2 exactly, so the loaded w2 may differ by one ulp.

Examples
--------
>>> from biplan.io.config import dump_config, load_config, load_config_text
>>> tube = load_config("examples/semi_bistable.toml")  # doctest: +SKIP
>>> load_config_text(dump_config(tube)) == tube  # doctest: +SKIP
True
"""

from __future__ import annotations

import enum
import math
import numbers
import os
import tomllib
import warnings
from collections import Counter
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import fields
from pathlib import Path
from typing import Any

from biplan._errors import ConfigError, CostWarning
from biplan.analysis.maps.cost import LARGE_MODULES, MAX_MODULES, duration, tube_cost
from biplan.geometry import Development
from biplan.laws import FoldLaw, LinearLaw, TransitionReading, TrilinearLaw
from biplan.model.tube import Tube
from biplan.options import ModelOptions

__all__ = ["ConfigFileError", "dump_config", "load_config", "load_config_text", "tube_from_dict"]

_TOP_KEYS = ("name", "geometry", "laws", "options")
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
_FOLD_SETS = ("helical", "circular")
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


# --------------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------------
class _Reader:
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


def _read_development(r: _Reader, geo: Mapping[str, Any]) -> Development:
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


def _read_geometry(r: _Reader, data: Mapping[str, Any]) -> dict[str, Any]:
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


def _read_options(r: _Reader, data: Mapping[str, Any]) -> ModelOptions:
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
    r: _Reader, table: Mapping[str, Any], prefix: str, reading: TransitionReading
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
    r: _Reader, laws: Mapping[str, Any], fold_set: str, count: int, reading: TransitionReading
) -> FoldLaw | None:
    """The law of every fold of one set (``None`` if the set is empty and the table absent)."""
    prefix = f"laws.{fold_set}"
    table = r.table(laws, fold_set, "laws", required=count > 0)
    if not table and count == 0:
        return None
    r.check_keys(table, _LAW_KEYS, prefix)
    return _read_law(r, table, prefix, reading)


def _read_overrides(
    r: _Reader, laws: Mapping[str, Any], counts: Mapping[str, int], reading: TransitionReading
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
        fold = r.choice(r.require(table, "fold", prefix), f"{prefix}.fold", _FOLD_SETS)
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


def _read_laws(
    r: _Reader, data: Mapping[str, Any], geometry: Mapping[str, Any], reading: TransitionReading
) -> dict[str, tuple[FoldLaw, ...]]:
    """``helical_laws`` and ``circular_laws`` from ``[laws]``."""
    laws = r.table(data, "laws", "", required=True)
    r.check_keys(laws, _LAWS_KEYS, "laws")
    n = geometry["n_modules"]
    counts = {"helical": n, "circular": n - 1 + int(geometry["base_fold"])}
    per_set = {s: _read_set_law(r, laws, s, counts[s], reading) for s in _FOLD_SETS}
    overrides = _read_overrides(r, laws, counts, reading)
    out: dict[str, tuple[FoldLaw, ...]] = {}
    for fold_set in _FOLD_SETS:
        base = per_set[fold_set]
        # base is None only for an empty set, so no index reaches it
        chosen = [overrides.get((fold_set, i), base) for i in range(counts[fold_set])]
        out[f"{fold_set}_laws"] = tuple(chosen)  # type: ignore[arg-type]
    return out


def tube_from_dict(data: Mapping[str, Any], source: str = "<dict>") -> Tube:
    """Build a :class:`Tube` from a parsed configuration (see the module docstring for the schema).

    Parameters
    ----------
    data : mapping
        The parsed TOML document.
    source : str
        Where ``data`` came from; it starts every error message.

    Returns
    -------
    Tube

    Raises
    ------
    ConfigFileError
        On any invalid, unknown or missing entry; ``parameter`` is its dotted key.
    """
    r = _Reader(source)
    if not isinstance(data, Mapping):
        raise r.fail("<document>", data, "a table of configuration keys")
    r.check_keys(data, _TOP_KEYS, "")
    name = r.string(data.get("name", ""), "name")
    geometry = _read_geometry(r, data)
    options = _read_options(r, data)
    laws: dict[str, Any] = _read_laws(r, data, geometry, options.transition_reading)
    with r.renamed("geometry"):
        return Tube(**geometry, **laws, options=options, name=name)


def load_config_text(text: str, source: str = "<string>") -> Tube:
    """Build a :class:`Tube` from TOML text (see :func:`load_config`)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ConfigFileError("toml", str(err), "valid TOML syntax", source) from None
    return tube_from_dict(data, source)


def load_config(path: str | Path) -> Tube:
    """Read a tube configuration from a TOML file (schema: see the module docstring).

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file.

    Returns
    -------
    Tube

    Raises
    ------
    ConfigFileError
        If ``path`` is not a path (a str or os.PathLike) or the file cannot be read
        (``parameter = "path"``), is not valid TOML (``parameter = "toml"``), or any entry is
        invalid (``parameter`` = its dotted key).
    """
    source = str(path)
    if not isinstance(path, str | os.PathLike):
        raise ConfigFileError("path", path, "a path to a TOML file (str or pathlib.Path)", source)
    try:
        text = Path(path).read_bytes().decode("utf-8")
    except (OSError, UnicodeDecodeError) as err:
        reason = getattr(err, "strerror", None) or str(err)
        raise ConfigFileError(
            "path", source, f"a readable UTF-8 TOML file ({reason})", source
        ) from None
    return load_config_text(text, source)


# --------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------
_ESCAPES = {
    '"': '\\"',
    "\\": "\\\\",
    "\b": "\\b",
    "\t": "\\t",
    "\n": "\\n",
    "\f": "\\f",
    "\r": "\\r",
}


def _toml_string(text: str) -> str:
    """A TOML basic string."""
    out = []
    for ch in text:
        if ch in _ESCAPES:
            out.append(_ESCAPES[ch])
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_value(value: Any) -> str:
    """A TOML scalar or array of a bool, int, finite float, str, enum or sequence."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, enum.Enum):
        return _toml_string(str(value.value))
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {value!r} as TOML")  # pragma: no cover


def _table_transitions(law: TrilinearLaw, reading: TransitionReading) -> tuple[float, float]:
    """Table entry [l1, l2] that :meth:`TrilinearLaw.from_table` maps back to the breakpoints.

    Under ``branch_lengths`` l2 = w2 − w1 is chosen among a few neighbouring floats so that
    w1 + l2 rounds to w2. Where no float does (w1 + l2 falls on a rounding tie), the nearest
    is written and the loaded w2 differs from the original by one ulp.
    """
    w1, w2 = law.transitions
    if reading is TransitionReading.ABSOLUTE:
        return w1, w2
    candidates = [w2 - w1]
    for direction in (math.inf, -math.inf):
        span = candidates[0]
        for _ in range(4):
            span = math.nextafter(span, direction)
            candidates.append(span)
    return w1, min(candidates, key=lambda s: abs((w1 + s) - w2))  # first best: w2 − w1


def _law_lines(law: FoldLaw, reading: TransitionReading) -> list[str]:
    """``key = value`` lines of a law table."""
    if isinstance(law, LinearLaw):
        return ['type = "linear"', f"stiffness = {_toml_value(law.stiffness)}"]
    lines = [
        'type = "trilinear"',
        f"stiffness = {_toml_value(law.stiffness)}",
        f"transitions = {_toml_value(_table_transitions(law, reading))}",
    ]
    if law.is_bistable:
        lines.append("bistable = true")
    return lines


def _most_common(laws: tuple[FoldLaw, ...]) -> FoldLaw | None:
    """The law most folds of a set share (the first such on ties)."""
    return Counter(laws).most_common(1)[0][0] if laws else None


def dump_config(tube: Tube) -> str:
    """TOML text that :func:`load_config` reads back to a tube equal to ``tube``.

    Each fold set's most common law becomes ``[laws.helical]`` / ``[laws.circular]``; every
    other fold gets a ``[[laws.override]]``. All options are written explicitly.

    Parameters
    ----------
    tube : Tube

    Returns
    -------
    str
    """
    dev = tube.development
    reading = tube.options.transition_reading
    lines = [
        "# biplan tube configuration (units: mm, N, s, degrees)",
        f"name = {_toml_value(tube.name)}",
        "",
        "[geometry]",
        f"radius = {_toml_value(dev.radius)}",
        f"pitch = {_toml_value(dev.pitch)}",
        f"helical_angle = {_toml_value(dev.helical_angle)}",
        f"n_modules = {_toml_value(tube.n_modules)}",
        f"base_fold = {_toml_value(tube.base_fold)}",
        f"surface_density = {_toml_value(float(tube.surface_density))}",
    ]
    overrides: list[tuple[str, int, FoldLaw]] = []
    for fold_set in _FOLD_SETS:
        laws: tuple[FoldLaw, ...] = getattr(tube, f"{fold_set}_laws")
        base = _most_common(laws)
        if base is None:
            continue
        lines += ["", f"[laws.{fold_set}]", *_law_lines(base, reading)]
        overrides += [(fold_set, i, law) for i, law in enumerate(laws) if law != base]
    for fold_set, index, law in overrides:
        lines += ["", "[[laws.override]]", f"fold = {_toml_value(fold_set)}", f"index = {index}"]
        lines += _law_lines(law, reading)
    lines += ["", "[options]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in tube.options.to_dict().items()]
    return "\n".join(lines) + "\n"
