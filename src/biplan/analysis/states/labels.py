"""Fold-state bits and hexadecimal labels of stable states (SI "state transition diagram").

A fully bistable MFT's configuration is named by one bit per bistable fold — 0 closed, 1 open
— ordered **from the free end toward the clamped base** in physical order along the tube
(MODEL §15 CHOICE B1: for four modules without a base fold, H₄ C₃|₄ H₃ C₂|₃ H₂ C₁|₂ H₁). The
bits are left-padded with zeros to a multiple of four and written in hexadecimal, two digits
for seven folds: 0011011 → 00011011 → ``1B``.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from biplan._errors import ConfigError
from biplan.geometry import FoldRef
from biplan.model.tube import Tube

__all__ = [
    "bistable_folds",
    "bits_to_label",
    "bits_to_labels",
    "hamming",
    "label_to_bits",
    "physical_folds",
    "require_bistable_folds",
    "state_name",
]

_STATE_NAME = re.compile(r"^([0-9A-Fa-f]+)(?:\.([0-9]+))?$")


def physical_folds(tube: Tube) -> tuple[FoldRef, ...]:
    """Every fold of the tube in physical order, free end first.

    Helical fold of module N, the circular fold between modules N−1 and N, …, helical fold of
    module 1, then the base circular fold when the tube has one.
    """
    connectors = tube.layout.connectors
    above: dict[int | None, int] = {}
    for index, c in enumerate(connectors):
        above[c.lower] = index  # the connector on top of module c.lower (None: the clamp)
    out: list[FoldRef] = []
    for module in reversed(range(tube.n_modules)):
        out.append(FoldRef("helical", module))
        below = next((i for i, c in enumerate(connectors) if c.upper == module), None)
        if below is not None:
            out.append(FoldRef("circular", below))
    return tuple(out)


def bistable_folds(tube: Tube) -> tuple[FoldRef, ...]:
    """The folds whose law is bistable, free end first: the bits of a state label."""
    laws = {"helical": tube.helical_laws, "circular": tube.circular_laws}
    return tuple(f for f in physical_folds(tube) if laws[f.set][f.index].is_bistable)


def require_bistable_folds(
    tube: Tube, name: str = "model", value: str | None = None
) -> tuple[FoldRef, ...]:
    """:func:`bistable_folds`, or a ConfigError naming ``name`` and ``value`` (default the
    tube's name) when there is none (a state search needs at least one)."""
    folds = bistable_folds(tube)
    if not folds:
        n = len(tube.helical_laws) + len(tube.circular_laws)
        raise ConfigError(
            name, value or tube.name or "the tube",
            f"a tube with at least one bistable fold law (its {n} fold laws are all "
            "monostable; a trilinear law is bistable when k2 < 0 and its valley force "
            "F2 = k1 w1 + k2 (w2 − w1) < 0)",
        )  # fmt: skip
    return folds


def bits_to_label(bits: Sequence[int]) -> str:
    """Hexadecimal label of a bit sequence (free end first), zero-padded to whole digits.

    >>> bits_to_label((0, 0, 1, 1, 0, 1, 1))
    '1B'
    """
    if not bits or any(b not in (0, 1) for b in bits):
        raise ConfigError("bits", tuple(bits), "a non-empty sequence of 0/1")
    digits = (len(bits) + 3) // 4
    value = int("".join(str(int(b)) for b in bits), 2)
    return f"{value:0{digits}X}"


def bits_to_labels(bits: np.ndarray) -> list[str]:
    """:func:`bits_to_label` of every row of ``bits`` (k, n), vectorised (a state search
    labels every seed).

    >>> bits_to_labels(np.array([[0, 0, 1, 1, 0, 1, 1], [1, 0, 0, 0, 0, 0, 0]]))
    ['1B', '40']
    """
    bits = np.asarray(bits)
    if bits.ndim != 2 or bits.shape[1] == 0 or not np.isin(bits, (0, 1)).all():
        raise ConfigError("bits", bits.shape, "rows of a non-empty sequence of 0/1")
    n = bits.shape[1]
    if n > 62:  # beyond int64
        return [bits_to_label(row) for row in bits.tolist()]
    values = bits.astype(np.int64) @ (np.int64(1) << np.arange(n - 1, -1, -1, dtype=np.int64))
    digits = (n + 3) // 4
    return [f"{v:0{digits}X}" for v in values.tolist()]


def label_to_bits(label: str, n_bits: int) -> tuple[int, ...]:
    """Bits (free end first) of a hexadecimal label for a tube with ``n_bits`` bistable folds."""
    try:
        value = int(label, 16)
    except ValueError:
        raise ConfigError("label", label, "a hexadecimal state label such as '1B'") from None
    if n_bits < 1 or value >= 2**n_bits or len(label) != (n_bits + 3) // 4:
        raise ConfigError(
            "label", label, f"{(n_bits + 3) // 4} hex digits below {2**n_bits:X} ({n_bits} folds)"
        )
    return tuple(int(c) for c in format(value, f"0{n_bits}b"))


def hamming(a: Sequence[int], b: Sequence[int]) -> int:
    """Number of folds in which two bit sequences differ."""
    if len(a) != len(b):
        raise ConfigError("bits", (tuple(a), tuple(b)), "sequences of equal length")
    return sum(int(x != y) for x, y in zip(a, b, strict=True))


def state_name(parameter: str, text: str, tube: Tube) -> str:
    """The state name ``text`` checked against the tube's bistable folds: hexadecimal digits
    in any case, as many as the folds need, below 2^n_folds, optionally followed by ``.k``
    (k ≥ 2, a repeated label); returned upper case (``"2a"`` → ``"2A"``, ``" 1b.2"`` →
    ``"1B.2"``).

    Parameters
    ----------
    parameter : str
        What errors name (e.g. the CLI's ``START``).
    text : str
        The name as typed.
    tube : Tube

    Raises
    ------
    ConfigError
        Naming ``parameter``, ``text`` and the valid form.
    """
    n_bits = len(bistable_folds(tube))
    digits = (n_bits + 3) // 4
    if n_bits == 0:
        raise ConfigError(parameter, text, "a state of a tube with bistable folds (it has none)")
    valid = (
        f"{digits} hexadecimal digit{'s' if digits > 1 else ''} from {0:0{digits}X} to "
        f"{2**n_bits - 1:0{digits}X} ({n_bits} bistable folds, any case), optionally followed "
        "by .2, .3, … (a repeated label)"
    )
    match = _STATE_NAME.match(text.strip())
    if match is None or (match[2] is not None and int(match[2]) < 2):
        raise ConfigError(parameter, text, valid)
    try:
        label_to_bits(match[1].upper(), n_bits)
    except ConfigError:
        raise ConfigError(parameter, text, valid) from None
    return match[1].upper() + ("" if match[2] is None else f".{match[2]}")
