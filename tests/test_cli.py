"""The ``biplan`` command, run in-process."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import biplan
from biplan.cli.main import EXIT_BIPLAN_ERROR, app, main

runner = CliRunner()
COLUMNS = [
    "displacement",
    "force",
    "u_z",
    "u_r",
    "theta",
    "energy",
    "min_eigenvalue",
    "stable",
    "status",
    "switched",
]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("demo") / "out"
    result = runner.invoke(
        app, ["demo", "--out", str(out), "--steps", "12", "--quiet", "--no-animate"]
    )
    return result, out


def test_help() -> None:
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0
    assert "demo" in result.output
    result = runner.invoke(app, ["demo", "--help"])
    assert result.exit_code == 0
    for option in ("--out", "--steps", "--quiet"):
        assert option in result.output


def _commands(command: object, path: list[str]) -> list[tuple[list[str], object]]:
    subcommands = getattr(command, "commands", None)
    if subcommands is None:
        return [(path, command)]
    return [c for name, sub in subcommands.items() for c in _commands(sub, [*path, name])]


def test_every_option_help_is_shown_verbatim() -> None:
    """Rich markup must not eat units: ``[s]`` is Rich's strike-through tag, so an unescaped
    "Time step [s]." would be shown as "Time step ."."""
    import re

    import typer

    def squash(text: str) -> str:
        return re.sub(r"[\s│╭╮╰╯─]", "", text)

    commands = _commands(typer.main.get_command(app), [])
    assert len(commands) >= 10
    for path, command in commands:
        result = runner.invoke(app, [*path, "--help"], env={"COLUMNS": "250"})
        assert result.exit_code == 0, path
        shown = squash(result.output)
        for param in command.params:  # type: ignore[attr-defined]
            text = getattr(param, "help", None)
            if text:
                assert squash(text.replace("\\[", "[")) in shown, (path, param.name, text)


def test_version() -> None:
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert biplan.__version__ in result.output


def test_demo_exits_cleanly_and_summarises(demo_run) -> None:
    result, _ = demo_run
    assert result.exit_code == 0, result.output
    assert result.exception is None
    assert "┏" not in result.output  # --quiet: no table
    # one phase-1 peak: the located first loss of stability, the same in both summary lines
    # and equal to the first snap of the force-controlled response (first_snap)
    text = " ".join(result.output.split())
    heads = re.findall(r"[Pp]hase.1 peak force ([\d.]+) ± (\S+) N", text)
    assert len(heads) == 2 and heads[0][0] == heads[1][0], text
    import biplan
    from biplan.analysis.response.loadcontrol import first_snap

    peak = first_snap(biplan.Model(biplan.designs.semi_bistable()))
    assert peak is not None and f"{peak.force:.4f}" == heads[0][0]
    assert "spinodal regime" in result.output
    assert "at 1.6 N (end of the ramp): u_z/l0 = " in result.output


def test_demo_writes_ramp_and_path(demo_run) -> None:
    _, out = demo_run
    for name in ("ramp", "path"):
        assert (out / f"{name}.nc").stat().st_size > 1000
        header = (out / f"{name}.csv").read_text().splitlines()[1].split(",")
        assert {"force", "u_z", "u_r", "theta", "energy", "min_eigenvalue", "stable"} <= set(header)
    assert "t" in (out / "ramp.csv").read_text().splitlines()[1].split(",")
    assert (out / "response.png").read_bytes().startswith(PNG_SIGNATURE)


def test_demo_writes_pngs(demo_run) -> None:
    _, out = demo_run
    for name in ("force_displacement.png", "development.png", "cylinder.png"):
        data = (out / name).read_bytes()
        assert data.startswith(PNG_SIGNATURE), name
        assert len(data) > 10_000, name


def test_demo_csv(demo_run) -> None:
    _, out = demo_run
    with (out / "demo.csv").open(newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == COLUMNS
    body = rows[1:]
    assert len(body) == 12
    u = np.array([float(r[0]) for r in body])
    np.testing.assert_allclose(u, np.linspace(0.75, 9.0, 12))
    assert {r[7] for r in body} <= {"0", "1"}
    assert {r[8] for r in body} <= {s.name for s in biplan.Status}
    converged = [r for r in body if r[8] == "CONVERGED"]
    assert converged, "no converged step"
    # Phase 1 starts on the stable closed branch with a positive (tensile) reaction.
    assert body[0][7] == "1" and float(body[0][1]) > 0


def test_biplan_error_is_a_red_message_not_a_traceback(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def broken(*_: object, **__: object) -> biplan.Tube:
        raise biplan.ConfigError("radius", -1.0, "> 0 mm")

    monkeypatch.setattr(biplan.designs, "semi_bistable", broken)
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--out", str(tmp_path / "out"), "--steps", "2", "--quiet"])
    assert exit_info.value.code == EXIT_BIPLAN_ERROR == 2
    assert not (tmp_path / "out").exists()  # the input is checked before anything is written
    err = capsys.readouterr().err
    assert "error:" in err and "invalid radius = -1.0: must be > 0 mm" in err
    assert "Traceback" not in err


def test_usage_errors_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    result = runner.invoke(app, ["demo", "--steps", "1", "--out", str(tmp_path)])
    assert result.exit_code == 2
    result = runner.invoke(app, ["demo", str(tmp_path / "missing.toml"), "--out", str(tmp_path)])
    assert result.exit_code == 2
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--out", str(blocker / "sub"), "--steps", "2"])
    assert exit_info.value.code == EXIT_BIPLAN_ERROR
    err = capsys.readouterr().err
    assert "--out" in err and f"{blocker} is a file" in err and "Traceback" not in err


def test_main_help_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["--help"])
    assert exit_info.value.code == 0
    assert "demo" in capsys.readouterr().out


def test_compile_refuses_a_negative_job_count(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["compile", "--jobs", "-1"])
    assert exit_info.value.code == EXIT_BIPLAN_ERROR
    assert "invalid --jobs = -1: must be an integer ≥ 0" in capsys.readouterr().err


def test_compile_workloads_run_and_report_failures(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A workload of ``biplan compile`` runs the drivers it names (here in this process, its
    kernels cached by the suite) without announcing the compile itself (the command does);
    a failing one is reported with its error, not raised."""
    from biplan._compile import numba_cache
    from biplan.cli import compile as compile_cmd
    from biplan.model import system

    assert compile_cmd.FIRST in compile_cmd.WORKLOADS
    assert compile_cmd.BESIDE_FIRST in compile_cmd.WORKLOADS
    monkeypatch.setattr(system, "_ANNOUNCED", [])
    monkeypatch.setattr(numba_cache, "is_warm", lambda: False)
    done = compile_cmd._run("path")
    assert done.name == "path" and done.error is None and done.seconds > 0.0
    assert "compiling the element kernels" not in capsys.readouterr().err

    def broken() -> None:
        raise ValueError("no such tube")

    monkeypatch.setitem(compile_cmd.WORKLOADS, "broken", broken)
    failed = compile_cmd._run("broken")
    assert failed.error == "ValueError: no such tube"


def test_the_one_time_compile_is_announced_once_with_the_compile_command(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """With nothing of this install cached, the first System of a process says that the
    kernels compile once and where they are cached, and points to ``biplan compile``; a
    second System says nothing; a warm cache says nothing."""
    from biplan._compile import numba_cache
    from biplan.model import system

    monkeypatch.setattr(system, "_ANNOUNCED", [])
    monkeypatch.setattr(numba_cache, "is_warm", lambda: False)
    system._announce_compile()
    system._announce_compile()
    err = capsys.readouterr().err
    assert err.count("biplan: compiling the element kernels") == 1
    assert "`biplan compile` compiles all of them at once" in err
    assert str(numba_cache.cache_dir()) in err
    monkeypatch.setattr(system, "_ANNOUNCED", [])
    monkeypatch.setattr(numba_cache, "is_warm", lambda: True)
    system._announce_compile()
    assert capsys.readouterr().err == ""
