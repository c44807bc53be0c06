"""Measured specimen curves from CSV files, checked row by row (the fitted laws as TOML blocks:
:mod:`biplan.calibration.law_blocks`; the calibration config: :mod:`biplan.calibration.config`).

CSV format
----------
One file per specimen. The first non-blank row that is not a ``#`` comment is the header; the
columns are found by name (case-insensitive, configurable in :class:`SpecimenFormat`):

* ``displacement`` — end displacement (tube extension) [mm];
* ``force`` [N] *or* ``pressure`` [kPa] — exactly one of the two; a pressure p becomes the end
  force F = p · πR² with the tube radius R (1 kPa = 10⁻³ N/mm²);
* ``segment`` (optional) — a label per row; consecutive rows with the same label form one
  segment (e.g. ``1`` for phase 1 under pressure-driven extension, ``2`` for phase 2 under
  gravity-induced contraction; nothing is measured in the spinodal between them). Without
  this column the file is one segment.

A header cell may state its unit as ``name [unit]`` or ``name (unit)``, e.g. ``force [N]``. A
stated unit must equal the configured one (default mm, N, kPa; the others listed in
:data:`UNITS` convert on reading), else the file is rejected as a unit mismatch. Other
columns are ignored. Delimiter: comma, semicolon or tab (detected).

Checks
------
Every problem raises :class:`DataError` naming the file, the row (1-based line number, the
header included) and the column: a missing or ambiguous column, a unit mismatch, a
non-numeric or empty cell, a NaN or infinite value, displacement not strictly monotonic within
a segment (increasing or decreasing throughout), fewer than ``min_points`` rows in a segment,
or a segment label that reappears after another segment.
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from biplan._errors import ConfigError, check_integer
from biplan.calibration.fits import CftGeometry
from biplan.calibration.specimens import MIN_POINTS, Segment, Specimen, segment_problem

__all__ = [
    "UNITS",
    "DataError",
    "SpecimenFormat",
    "read_specimen",
    "read_specimens",
]

#: Known units per quantity and their factor to mm, N and N/mm² (pressure).
UNITS: dict[str, dict[str, float]] = {
    "displacement": {"mm": 1.0, "cm": 10.0, "m": 1e3, "um": 1e-3, "µm": 1e-3},
    "force": {"N": 1.0, "mN": 1e-3, "kN": 1e3},
    "pressure": {
        "kPa": 1e-3,
        "Pa": 1e-6,
        "MPa": 1.0,
        "N/mm2": 1.0,
        "bar": 0.1,
        "mbar": 1e-4,
        "psi": 6.894757e-3,
    },
}
_HEADER = re.compile(r"^\s*(?P<name>.*?)\s*(?:[\[(]\s*(?P<unit>[^\])]*?)\s*[\])])?\s*$")


class DataError(ConfigError):
    """Invalid measured data; the message starts with the file and the row.

    Parameters
    ----------
    parameter : str
        What is wrong (e.g. ``"column 'force'"``).
    value : object
        The offending value.
    valid : str
        What would be valid.
    source : str
        The file.
    row : int or str or None
        1-based row (line) number, a row range ``"a–b"``, or None (whole file or directory).
    """

    def __init__(
        self, parameter: str, value: Any, valid: str, source: str, row: int | str | None
    ) -> None:
        super().__init__(parameter, value, valid)
        self.source = source
        self.row = row
        where = "" if row is None else f", {'rows' if '–' in str(row) else 'row'} {row}"
        self.args = (f"{source}{where}: {self.args[0]}",)

    def __reduce__(self) -> tuple[Any, ...]:
        return (type(self), (self.parameter, self.value, self.valid, self.source, self.row))


def _unit_key(unit: str) -> str:
    return unit.strip().replace("²", "2").replace("μ", "µ")


@dataclass(frozen=True)
class SpecimenFormat:
    """Column names and units of specimen CSV files.

    Parameters
    ----------
    displacement, force, pressure, segment : str
        Column names (matched case-insensitively, without the unit).
    displacement_unit, force_unit, pressure_unit : str
        Units of the values (keys of :data:`UNITS`); a unit stated in a header must match.
    min_points : int
        Minimum rows per segment (≥ 2).
    """

    displacement: str = "displacement"
    force: str = "force"
    pressure: str = "pressure"
    segment: str = "segment"
    displacement_unit: str = "mm"
    force_unit: str = "N"
    pressure_unit: str = "kPa"
    min_points: int = MIN_POINTS

    def __post_init__(self) -> None:
        for quantity, table in UNITS.items():
            name = f"{quantity}_unit"
            unit = _unit_key(str(getattr(self, name)))
            if unit not in table:
                raise ConfigError(name, getattr(self, name), f"one of {', '.join(table)}")
            object.__setattr__(self, name, unit)
        for name in ("displacement", "force", "pressure", "segment"):
            if not str(getattr(self, name)).strip():
                raise ConfigError(f"{name} column", getattr(self, name), "a non-empty name")
        object.__setattr__(self, "min_points", check_integer("min_points", self.min_points, low=2))

    def factor(self, quantity: str) -> float:
        """Factor from the configured unit of ``quantity`` to mm, N or N/mm²."""
        return UNITS[quantity][getattr(self, f"{quantity}_unit")]


def _rows(path: Path) -> list[tuple[int, list[str]]]:
    """(line number, cells) of the non-blank, non-comment rows of a CSV file."""
    source = str(path)
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except (OSError, UnicodeDecodeError) as err:
        reason = getattr(err, "strerror", None) or str(err)
        raise DataError(
            "file", source, f"a readable UTF-8 CSV file ({reason})", source, 0
        ) from None
    lines = text.splitlines()
    sample = next((ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")), "")
    delimiter = max((",", ";", "\t"), key=sample.count)
    out = []
    reader = csv.reader(lines, delimiter=delimiter)
    for cells in reader:
        if not any(c.strip() for c in cells) or cells[0].lstrip().startswith("#"):
            continue
        out.append((reader.line_num, [c.strip() for c in cells]))
    return out


def _columns(
    header: list[str], fmt: SpecimenFormat, source: str, row: int
) -> dict[str, tuple[int, str]]:
    """Index and quantity of the displacement, force-or-pressure and segment columns."""
    found: dict[str, tuple[int, str | None]] = {}
    wanted = {getattr(fmt, q).strip().lower(): q for q in UNITS} | {
        fmt.segment.strip().lower(): "segment"
    }
    for i, cell in enumerate(header):
        m = _HEADER.match(cell)
        name = (m.group("name") if m else cell).strip().lower()
        if name in wanted:
            quantity = wanted[name]
            if quantity in found:
                raise DataError(
                    f"column {cell!r}", cell, "given once (duplicate column)", source, row
                )
            found[quantity] = (i, m.group("unit") if m else None)
    if "displacement" not in found:
        raise DataError(
            "header", header, f"a header with a {fmt.displacement!r} column", source, row
        )
    kinds = [q for q in ("force", "pressure") if q in found]
    if len(kinds) != 1:
        raise DataError(
            "header",
            header,
            f"a header with exactly one of the columns {fmt.force!r} [N] or {fmt.pressure!r} [kPa]",
            source,
            row,
        )
    out: dict[str, tuple[int, str]] = {}
    for quantity, (i, unit) in found.items():
        if unit is not None and quantity != "segment":
            expected = getattr(fmt, f"{quantity}_unit")
            if _unit_key(unit) != expected:
                known = ", ".join(UNITS[quantity])
                raise DataError(
                    f"unit of column {header[i]!r}",
                    unit,
                    f"{expected} as configured (unit mismatch: configure the {quantity} unit "
                    f"to match the file; known {quantity} units: {known})",
                    source,
                    row,
                )
        out["load" if quantity in ("force", "pressure") else quantity] = (i, quantity)
    return out


def _number(cells: list[str], i: int, name: str, source: str, row: int) -> float:
    text = cells[i] if i < len(cells) else ""
    if not text:
        raise DataError(f"column {name!r}", text, "a number (the cell is empty)", source, row)
    try:
        x = float(text)
    except ValueError:
        raise DataError(
            f"column {name!r}", text, "a number (non-numeric value)", source, row
        ) from None
    if math.isnan(x):
        raise DataError(
            f"column {name!r}", text, "a finite number (NaN is not allowed)", source, row
        )
    if not math.isfinite(x):
        raise DataError(f"column {name!r}", text, "a finite number (not infinite)", source, row)
    return x


def read_specimen(
    path: str | Path, fmt: SpecimenFormat | None = None, *, radius: float | None = None
) -> Specimen:
    """Read and check one specimen CSV file (format: module docstring).

    Parameters
    ----------
    path : str or Path
    fmt : SpecimenFormat, optional
        Column names and units; default ``displacement`` [mm], ``force`` [N] or ``pressure``
        [kPa], ``segment``.
    radius : float, optional
        Tube radius R [mm] for pressure files (F = p πR²); required for them.

    Returns
    -------
    Specimen
        Named after the file stem; displacement in mm, force in N.

    Raises
    ------
    DataError
        On any problem listed in the module docstring, naming the file and the row.
    """
    fmt = fmt or SpecimenFormat()
    path = Path(path)
    source = str(path)
    rows = _rows(path)
    if not rows:
        raise DataError("file", "no rows", "a header row and data rows", source, 1)
    header_row, header = rows[0]
    cols = _columns(header, fmt, source, header_row)
    (iu, _), (iload, quantity) = cols["displacement"], cols["load"]
    names = {iu: header[iu], iload: header[iload]}
    scale = fmt.factor(quantity)
    if quantity == "pressure":
        if radius is None or not radius > 0:
            raise DataError(
                "radius", radius, "a tube radius > 0 mm to convert pressure", source, header_row
            )
        scale *= CftGeometry(radius).end_area
    iseg = cols.get("segment", (None, ""))[0]
    groups: list[tuple[str, list[int], list[float], list[float]]] = []
    for row, cells in rows[1:]:
        u = _number(cells, iu, names[iu], source, row) * fmt.factor("displacement")
        f = _number(cells, iload, names[iload], source, row) * scale
        label = "1"
        if iseg is not None:
            label = cells[iseg] if iseg < len(cells) else ""
            if not label:
                raise DataError(f"column {header[iseg]!r}", label, "a segment label", source, row)
        if not groups or groups[-1][0] != label:
            if any(g[0] == label for g in groups):
                raise DataError(
                    f"column {header[iseg or 0]!r}",
                    label,
                    "a new label: rows of one segment must be contiguous",
                    source,
                    row,
                )
            groups.append((label, [], [], []))
        groups[-1][1].append(row)
        groups[-1][2].append(u)
        groups[-1][3].append(f)
    if not groups:
        raise DataError("file", "no data rows", "data rows after the header", source, header_row)
    segments = []
    for label, lines, us, fs in groups:
        problem = segment_problem(np.array(us), np.array(fs), min_points=fmt.min_points)
        if problem is None:
            segments.append(Segment(np.array(us), np.array(fs), label))
            continue
        where = f"{lines[0]}–{lines[-1]} (segment {label!r})"
        if problem.quantity == "points":
            raise DataError("number of points", problem.value, problem.valid, source, where)
        raise DataError(
            f"column {names[iu]!r}",
            problem.value,
            f"{problem.valid} (segment {label!r})",
            source,
            lines[problem.index],
        )
    try:
        return Specimen(path.stem, tuple(segments))
    except ConfigError as err:  # overlapping segments
        where = f"{groups[0][1][0]}–{groups[-1][1][-1]}"
        raise DataError(err.parameter, err.value, err.valid, source, where) from None


def read_specimens(
    directory: str | Path,
    fmt: SpecimenFormat | None = None,
    *,
    radius: float | None = None,
    pattern: str = "*.csv",
) -> tuple[Specimen, ...]:
    """Read every specimen file ``pattern`` in ``directory`` (sorted by name).

    Raises
    ------
    DataError
        If the directory holds no matching file, or on any file's first problem.
    """
    folder = Path(directory)
    files = sorted(folder.glob(pattern)) if folder.is_dir() else []
    if not files:
        raise DataError(
            "data directory", str(folder), f"a directory holding {pattern} files", str(folder), None
        )
    return tuple(read_specimen(f, fmt, radius=radius) for f in files)
