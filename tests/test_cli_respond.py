"""``biplan respond`` in-process: files, columns, dynamic runs, errors."""

from __future__ import annotations

import csv
from pathlib import Path

from typer.testing import CliRunner

from biplan.cli.main import app

runner = CliRunner()
CONFIG = Path(__file__).resolve().parents[1] / "examples" / "semi_bistable.toml"
REQUIRED = {"force", "u_z", "u_r", "theta", "energy", "min_eigenvalue", "stable"}


def _header(file: Path) -> list[str]:
    with file.open(newline="") as fh:
        rows = [r for r in csv.reader(fh) if r and not r[0].startswith("#")]
    return rows[0]


def test_respond_quasi_static_displacement(tmp_path: Path) -> None:
    out = tmp_path / "qs"
    args = ["respond", str(CONFIG), "--control", "displacement", "--stop", "1.0"]
    result = runner.invoke(app, [*args, "--method", "stepping", "--out", str(out)])
    assert result.exit_code == 0, result.output
    for name in ("response.nc", "response.csv", "response.png"):
        assert (out / name).is_file()
    assert set(_header(out / "response.csv")) >= REQUIRED
    assert "phase-1 peak force" in result.output


def test_respond_dynamic_pressure(tmp_path: Path) -> None:
    out = tmp_path / "dyn"
    args = ["respond", str(CONFIG), "--control", "pressure", "--dynamic", "--rate", "50"]
    result = runner.invoke(
        app, [*args, "--duration", "0.1", "--time-step", "0.02", "--out", str(out), "--quiet"]
    )
    assert result.exit_code == 0, result.output
    header = _header(out / "response.csv")
    assert header[0] == "t" and set(header) >= REQUIRED


def test_respond_rejects_a_missing_config(tmp_path: Path) -> None:
    result = runner.invoke(app, ["respond", str(tmp_path / "nope.toml")])
    assert result.exit_code != 0


def test_bifurcation_note_names_the_first_bifurcation_only_when_there_is_one() -> None:
    from types import SimpleNamespace

    from biplan.cli.respond import bifurcation_note
    from biplan.solvers.results import Event

    limit = Event("limit point", 3, 1.5, 2.1, 1.5)
    bif = Event("bifurcation", 8, 1.54, 2.126, 1.54)
    assert bifurcation_note(SimpleNamespace(events=(limit,))) is None
    assert bifurcation_note(SimpleNamespace()) is None  # a trajectory has no events
    note = bifurcation_note(SimpleNamespace(events=(limit, bif, bif)))
    assert note is not None
    assert "2 bifurcation(s)" in note and "z_p = 1.54 mm, F = 2.13 N" in note
    assert "displacement_sweep" in note
