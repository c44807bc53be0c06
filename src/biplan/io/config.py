"""TOML tube configuration: read a :class:`~biplan.model.tube.Tube` from a file and write one back.

Units are mm, N, s (mass in t) and degrees throughout. This module holds the schema and the
entry points; the sections are read by :mod:`biplan.io.config_reader` and the values written
by :mod:`biplan.io.config_writer`.

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
Every invalid input raises :class:`~biplan.io.config_reader.ConfigFileError` (a
:class:`~biplan._errors.ConfigError`) before anything is built or solved. Its ``parameter`` is
the dotted TOML key (for example ``geometry.radius``, ``laws.circular.stiffness[1]``,
``laws.override[1].index``) and its message starts with the file path. Unknown keys, wrong
types, non-finite numbers, out-of-range values, TOML syntax errors (``parameter = "toml"``) and
unreadable files (``parameter = "path"``) are all reported this way.

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

import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from biplan.io.config_reader import (
    FOLD_SETS,
    TOP_KEYS,
    ConfigFileError,
    ConfigReader,
    read_geometry,
    read_laws,
    read_options,
)
from biplan.io.config_writer import law_lines, most_common, toml_value
from biplan.laws import FoldLaw
from biplan.model.tube import Tube

__all__ = ["dump_config", "load_config", "load_config_text", "tube_from_dict"]


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
        The tube that ``data`` describes.

    Raises
    ------
    ConfigFileError
        On any invalid, unknown or missing entry; ``parameter`` is its dotted key.
    """
    r = ConfigReader(source)
    if not isinstance(data, Mapping):
        raise r.fail("<document>", data, "a table of configuration keys")
    r.check_keys(data, TOP_KEYS, "")
    name = r.string(data.get("name", ""), "name")
    geometry = read_geometry(r, data)
    options = read_options(r, data)
    laws: dict[str, Any] = read_laws(r, data, geometry, options.transition_reading)
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
        The tube that the file describes.

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
        f"name = {toml_value(tube.name)}",
        "",
        "[geometry]",
        f"radius = {toml_value(dev.radius)}",
        f"pitch = {toml_value(dev.pitch)}",
        f"helical_angle = {toml_value(dev.helical_angle)}",
        f"n_modules = {toml_value(tube.n_modules)}",
        f"base_fold = {toml_value(tube.base_fold)}",
        f"surface_density = {toml_value(float(tube.surface_density))}",
    ]
    overrides: list[tuple[str, int, FoldLaw]] = []
    for fold_set in FOLD_SETS:
        laws: tuple[FoldLaw, ...] = getattr(tube, f"{fold_set}_laws")
        base = most_common(laws)
        if base is None:
            continue
        lines += ["", f"[laws.{fold_set}]", *law_lines(base, reading)]
        overrides += [(fold_set, i, law) for i, law in enumerate(laws) if law != base]
    for fold_set, index, law in overrides:
        lines += ["", "[[laws.override]]", f"fold = {toml_value(fold_set)}", f"index = {index}"]
        lines += law_lines(law, reading)
    lines += ["", "[options]"]
    lines += [f"{k} = {toml_value(v)}" for k, v in tube.options.to_dict().items()]
    return "\n".join(lines) + "\n"
