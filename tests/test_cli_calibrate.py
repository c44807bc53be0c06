"""``biplan calibrate`` and ``biplan validate``, run in-process on the shipped synthetic data."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import biplan
from biplan.cli.main import EXIT_BIPLAN_ERROR, app, main
from biplan.io.config import load_config_text

runner = CliRunner()
DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
CONFIG = Path(__file__).resolve().parents[1] / "examples" / "semi_bistable.toml"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
GEOMETRY = "[geometry]\nradius = 2.0\npitch = 3.6\nhelical_angle = 60.0\nn_modules = 6\n\n"


def test_help_lists_the_subcommands() -> None:
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0
    assert "calibrate" in result.output and "validate" in result.output
    result = runner.invoke(app, ["calibrate", "--help"])
    assert "trilinear" in result.output and "linear" in result.output


def test_calibrate_trilinear_writes_a_law_block_figure_and_table(tmp_path: Path) -> None:
    out = tmp_path / "laws" / "circular.toml"
    args = ["calibrate", "trilinear", str(DATA / "cft_trilinear"), "--out", str(out)]
    result = runner.invoke(app, [*args, "--bootstrap", "30", "--quiet"])
    assert result.exit_code == 0, result.output
    assert "trilinear law from 10 specimens" in result.output
    text = out.read_text()
    assert text.count("[laws.circular]") == 1
    tube = load_config_text(
        GEOMETRY + text + '\n[laws.helical]\ntype = "linear"\nstiffness = 1.3\n'
    )
    law = tube.circular_laws[0]
    assert law.is_bistable
    np.testing.assert_allclose(law.coefficients, (0.9, -0.2, 0.6, 0.2, 1.3), rtol=0.1)
    assert out.with_suffix(".png").read_bytes().startswith(PNG_SIGNATURE)
    with out.with_suffix(".csv").open(newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["displacement", "phase", "count", "median", "std", "fitted", "residual"]
    assert {r[1] for r in rows[1:]} == {"1", "2"}


def test_calibrate_linear_reads_pressure_and_free_breakpoints(tmp_path: Path) -> None:
    out = tmp_path / "helical.toml"
    result = runner.invoke(
        app,
        ["calibrate", "linear", str(DATA / "cft_linear"), "-o", str(out), "--bootstrap", "20"],
    )
    assert result.exit_code == 0, result.output
    assert "Fitted law" in result.output and "N/mm²" in result.output
    tube = load_config_text(
        GEOMETRY + out.read_text().replace("helical", "circular") + "\n" + out.read_text()
    )
    assert tube.helical_laws[0].stiffness == pytest.approx(1.3, rel=0.05)
    free = tmp_path / "free.toml"
    result = runner.invoke(
        app,
        [
            *("calibrate", "trilinear", str(DATA / "cft_trilinear"), "-o", str(free)),
            *("--breakpoints", "free", "--bootstrap", "0", "--fold-set", "helical", "-q"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "[laws.helical]" in free.read_text() and "breakpoints: free" in free.read_text()


def test_calibrate_options_override_the_config(tmp_path: Path) -> None:
    """Geometry from --config (R = 4 mm: k doubles for pressure data), overridden by --radius."""
    config = tmp_path / "specimens.toml"
    config.write_text("[geometry]\nradius = 4.0\nn_folds = 1\n[units]\npressure = 'kPa'\n")
    base = ["calibrate", "linear", str(DATA / "cft_linear"), "--bootstrap", "0", "-q"]
    ks = []
    for extra in ([], ["--config", str(config)], ["--config", str(config), "--radius", "2"]):
        out = tmp_path / f"law{len(ks)}.toml"
        result = runner.invoke(app, [*base, "-o", str(out), *extra])
        assert result.exit_code == 0, result.output
        tube = load_config_text(
            GEOMETRY + out.read_text() + out.read_text().replace("helical", "circular")
        )
        ks.append(tube.helical_laws[0].stiffness)
    # pressure → force scales with R², fold length with R: k ∝ R for pressure data
    assert ks[1] == pytest.approx(2 * ks[0], rel=1e-4) and ks[2] == pytest.approx(ks[0])


def test_calibration_caveats_reach_the_terminal_and_the_law_block(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A linear law on bistable data, and intervals from one specimen, are warned of on
    stderr (with --quiet too) and in the written block."""
    out = tmp_path / "law.toml"
    args = ["calibrate", "linear", str(DATA / "cft_trilinear"), "-o", str(out), "-q"]
    with pytest.raises(SystemExit) as info:
        main([*args, "--bootstrap", "0"])
    assert info.value.code == 0
    err = capsys.readouterr().err
    assert "warning: the data are bistable: the median force falls by 1.65 N (78%" in err
    assert "RMS residual 1.05 N is 49% of the force range" in err
    assert "Traceback" not in err
    assert out.read_text().startswith("# warning: the data are bistable")
    single = tmp_path / "one"
    single.mkdir()
    (single / "s.csv").write_bytes((DATA / "cft_linear" / "specimen_01.csv").read_bytes())
    args = ["calibrate", "linear", str(single), "-o", str(out), "-q", "--bootstrap", "5"]
    with pytest.raises(SystemExit) as info:
        main(args)
    assert info.value.code == 0
    err = capsys.readouterr().err
    assert err.count("warning:") == 1 and "from a single specimen" in err
    assert "# warning: the bootstrap intervals come from a single specimen" in out.read_text()


def test_bad_data_is_a_red_message_naming_file_and_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = tmp_path / "data"
    data.mkdir()
    rows = [f"{0.01 * i:.2f},{0.1 * i:.2f}" for i in range(8)]
    rows[4] = "0.04,n/a"
    (data / "specimen_01.csv").write_text("displacement,force\n" + "\n".join(rows) + "\n")
    with pytest.raises(SystemExit) as info:
        main(["calibrate", "linear", str(data), "-o", str(tmp_path / "law.toml")])
    assert info.value.code == EXIT_BIPLAN_ERROR
    err = capsys.readouterr().err
    assert "specimen_01.csv, row 6" in err and "non-numeric" in err and "Traceback" not in err
    assert not (tmp_path / "law.toml").exists()
    (data / "specimen_01.csv").write_text("displacement [mm],force [kN]\n" + "\n".join(rows[:4]))
    with pytest.raises(SystemExit):
        main(["calibrate", "linear", str(data), "-o", str(tmp_path / "law.toml")])
    assert "unit mismatch" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # a linear CFT has one phase: no trilinear fit
        main(["calibrate", "trilinear", str(DATA / "cft_linear"), "-o", str(tmp_path / "x")])
    assert "two phases" in capsys.readouterr().err


def test_validate_overlays_prediction_on_the_band(tmp_path: Path) -> None:
    """A coarse run (12 steps to 3 mm) of the semi-bistable design against the MFT data."""
    out = tmp_path / "val"
    result = runner.invoke(
        app,
        [
            *("validate", str(CONFIG), str(DATA / "mft_semi_bistable"), "--out", str(out)),
            *("--steps", "12", "--max-displacement", "3", "--quiet"),
        ],
    )
    assert result.exit_code == 0, result.output
    assert "RMS error" in result.output and "Phase-1 peak: predicted" in result.output
    assert (out / "validation.png").read_bytes().startswith(PNG_SIGNATURE)
    with (out / "validation.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    compared = [r for r in rows if r["residual"] != "nan"]
    assert compared and all(float(r["displacement"]) <= 3.0 for r in compared)
    rms = float(result.output.split("RMS error ")[1].split(" N")[0])
    # The synthetic MFT data come from this model: phase 1 agrees to within the scatter.
    assert rms < 0.25
    with (out / "prediction.csv").open(newline="") as fh:
        assert len(list(csv.reader(fh))) == 13


def test_validate_rejects_missing_data(tmp_path: Path) -> None:
    result = runner.invoke(app, ["validate", str(CONFIG), str(tmp_path / "none")])
    assert result.exit_code != 0
    assert isinstance(result.exception, biplan.BiplanError | SystemExit)
