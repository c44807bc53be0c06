"""Writing the parts of a TOML tube configuration (the schema: :mod:`biplan.io.config`).

:func:`toml_value` writes a TOML scalar or array, :func:`law_lines` the ``key = value`` lines of
a law table (stiffness [N/mm²], transitions [mm], written so that they read back to the same
breakpoints), and :func:`most_common` picks the law that a fold set's table holds;
:func:`biplan.io.config.dump_config` puts them together.
"""

from __future__ import annotations

import enum
import math
from collections import Counter
from typing import Any

from biplan.laws import FoldLaw, LinearLaw, TrilinearLaw
from biplan.options import TransitionReading

__all__ = ["law_lines", "most_common", "toml_value"]

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


def toml_value(value: Any) -> str:
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
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
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


def law_lines(law: FoldLaw, reading: TransitionReading) -> list[str]:
    """``key = value`` lines of a law table."""
    if isinstance(law, LinearLaw):
        return ['type = "linear"', f"stiffness = {toml_value(law.stiffness)}"]
    lines = [
        'type = "trilinear"',
        f"stiffness = {toml_value(law.stiffness)}",
        f"transitions = {toml_value(_table_transitions(law, reading))}",
    ]
    if law.is_bistable:
        lines.append("bistable = true")
    return lines


def most_common(laws: tuple[FoldLaw, ...]) -> FoldLaw | None:
    """The law most folds of a set share (the first such on ties)."""
    return Counter(laws).most_common(1)[0][0] if laws else None
