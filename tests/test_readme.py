"""The README's ten lines of Python run as printed and print what their comments say."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NUMBER = re.compile(r"-?\d+\.\d+(?:e-?\d+)?|-?\d+e-?\d+")


def _example() -> str:
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```python\n(.*?)```", text, re.S)
    assert block is not None, "README.md has no python block"
    return block[1]


def _claims(code: str) -> list[str]:
    """The comment of every ``print`` line, in order."""
    return [
        line.split("#", 1)[1].strip() for line in code.splitlines() if line.startswith("print(")
    ]


def _agrees(printed: str, claim: str) -> bool:
    """Every number of the claim equals a printed number to the claim's digits, and every
    dotted name of the claim (``Verdict.STABLE``) is printed."""
    shown = [float(x) for x in NUMBER.findall(printed)]
    for token in NUMBER.findall(claim):
        digits = len(token.split("e")[0].split(".")[1]) if "." in token else 0
        exponent = int(token.split("e")[1]) if "e" in token else 0
        half = 0.5 * 10.0 ** (exponent - digits)
        if not any(abs(v - float(token)) <= half * (1 + 1e-9) for v in shown):
            return False
    return all(name in printed for name in re.findall(r"\b[A-Z]\w*\.[A-Z_]+\b", claim))


@pytest.mark.slow
def test_readme_example_runs_as_printed() -> None:
    code = _example()
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    printed = out.getvalue().splitlines()
    claims = _claims(code)
    assert len(printed) == len(claims) == 4
    for line, claim in zip(printed, claims, strict=True):
        assert _agrees(line, claim), f"README prints {line!r}, its comment says {claim!r}"


def test_claim_check_can_fail() -> None:
    assert _agrees("b = 0.573, C = 1.444", "b = 0.573, C = 1.444")
    assert not _agrees("b = 0.574, C = 1.444", "b = 0.573, C = 1.444")
    assert _agrees("0.04512", "0.045") and not _agrees("0.0462", "0.045")
    assert _agrees("1.23 Verdict.STABLE", "reaction [N], Verdict.STABLE")
    assert not _agrees("1.23 Verdict.UNSTABLE", "reaction [N], Verdict.STABLE")
