"""Bad requests on the command line fail first: one line naming what was typed, exit status 2,
no traceback, and nothing solved, compiled, enumerated or swept before.

Every test here runs in-process and never reaches a solver: the ``no_solve`` fixture makes
building a model, sweeping, enumerating, fitting or reading a result fail the test.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import biplan
from biplan.cli.main import EXIT_BIPLAN_ERROR, main

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "examples" / "semi_bistable.toml"
FULLY = ROOT / "examples" / "fully_bistable_4.toml"
DATA = ROOT / "examples" / "data"
STABILITY_GRID = ["--displacement", "0.1", "--C", "1"]


def _forbidden(*_: object, **__: object) -> None:
    raise AssertionError("the request reached the solver before it was refused")


@pytest.fixture
def no_solve(monkeypatch: pytest.MonkeyPatch) -> None:
    """Building a model, a sweep, a state enumeration, a fit or reading a result fails."""
    import biplan.analysis.maps.sweeps
    import biplan.analysis.response.quasistatic
    import biplan.analysis.states.search
    import biplan.calibration.calibrate
    import biplan.io.results
    import biplan.reproduction.report

    monkeypatch.setattr(biplan, "Model", _forbidden)
    monkeypatch.setattr(biplan.analysis.maps.sweeps, "sweep", _forbidden)
    monkeypatch.setattr(biplan.analysis.states.search, "enumerate_states", _forbidden)
    monkeypatch.setattr(biplan.analysis.response.quasistatic, "displacement_sweep", _forbidden)
    monkeypatch.setattr(biplan.calibration.calibrate, "calibrate_trilinear", _forbidden)
    monkeypatch.setattr(biplan.io.results, "load_result", _forbidden)
    monkeypatch.setattr(biplan.reproduction.report, "run_reproduction", _forbidden)


def _refused(capsys: pytest.CaptureFixture[str], args: list[str], *needles: str) -> str:
    """Run ``biplan ARGS``; check exit status 2, one line on stderr holding every needle, no
    traceback; return that line."""
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    captured = capsys.readouterr()
    text = captured.out + captured.err
    assert info.value.code == EXIT_BIPLAN_ERROR, text
    assert "Traceback" not in text
    lines = [line for line in captured.err.splitlines() if line.strip()]
    assert len(lines) == 1, captured.err
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


# --- 1. the output location -----------------------------------------------------------------
def _commands(out: Path) -> dict[str, list[str]]:
    """Every subcommand with an output location, writing to ``out``."""
    return {
        "demo": ["demo", "--out", out],
        "respond": ["respond", CONFIG, "--out", out],
        "states": ["states", FULLY, "--out", out],
        "validate": ["validate", CONFIG, DATA / "mft_semi_bistable", "--out", out],
        "map design": ["map", "design", CONFIG, "--b", "0.5", "--C", "1", "--out", out],
        "map stability": ["map", "stability", CONFIG, *STABILITY_GRID, "--out", out],
        "reproduce": ["reproduce", "--out", out],
        "plot": ["plot", CONFIG, "--kind", "response", "--out", out / "fig.png"],
        "calibrate": ["calibrate", "trilinear", DATA / "cft_trilinear", "--out", out],
    }


COMMANDS = list(_commands(Path("x")))


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("where", ["/proc/biplan-out", "/", "/usr", "/etc/biplan"])
def test_system_directory_is_refused(
    no_solve: None, capsys: pytest.CaptureFixture[str], command: str, where: str
) -> None:
    args = _commands(Path(where))[command]
    out = args[args.index("--out") + 1]
    _refused(capsys, args, "--out", repr(str(out)), "system director")


@pytest.mark.parametrize("command", COMMANDS)
def test_output_inside_a_file_is_refused(
    no_solve: None, tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    line = _refused(capsys, _commands(blocker / "sub")[command], "--out", "is a file")
    assert str(blocker) in line
    assert not (tmp_path / "sub").exists()


@pytest.mark.parametrize("command", [c for c in COMMANDS if c not in ("plot", "calibrate")])
def test_existing_file_where_a_directory_is_expected_is_refused(
    no_solve: None, tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    blocker = tmp_path / "out"
    blocker.write_text("keep me")
    _refused(capsys, _commands(blocker)[command], "--out", str(blocker), "existing file")
    assert blocker.read_text() == "keep me"


def test_directory_where_a_written_file_is_expected_is_refused(
    no_solve: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "out" / "response.nc").mkdir(parents=True)
    args = ["respond", CONFIG, "--out", tmp_path / "out"]
    _refused(capsys, args, "--out", "response.nc is a directory")
    (tmp_path / "fig.png").mkdir()
    args = ["plot", CONFIG, "--kind", "response", "--out", tmp_path / "fig.png"]
    _refused(capsys, args, "--out", "existing directory")


@pytest.mark.parametrize("command", ["respond", "map design", "plot", "calibrate"])
def test_unwritable_location_is_refused(
    no_solve: None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    command: str,
) -> None:
    """The permission test itself (root may write anywhere, so it is faked here)."""
    from biplan.cli import _checks

    monkeypatch.setattr(_checks, "_writable", lambda folder: Path(folder) != tmp_path)
    _refused(capsys, _commands(tmp_path / "new")[command], "--out", f"{tmp_path} is not writable")


# --- 2. values out of range are refused, never replaced or ignored ---------------------------
@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["respond", CONFIG, "--max-step", "0"], ("--max-step", "0.0", "≥ 0.05")),
        (["respond", CONFIG, "--step", "0.2"], ("--step", "0.2", "≤ 0.1", "--max-step")),
        (["respond", CONFIG, "--dynamic", "--damping-ratio", "-1"],
         ("--damping-ratio", "-1.0", "≥ 0")),
        (["respond", CONFIG, "--dynamic", "--hold", "-1"], ("--hold", "-1.0", "≥ 0 s")),
        (["respond", CONFIG, "--dynamic", "--time-step", "5"], ("--time-step", "5.0", "(0, 2]")),
        (["respond", CONFIG, "--dynamic", "--rate", "0"], ("--rate", "0.0", "non-zero")),
        (["respond", CONFIG, "--stop", "0"], ("--stop", "0.0", "non-zero")),
        (["respond", CONFIG, "--max-steps", "0"], ("--max-steps", "0", "≥ 1")),
        (["respond", CONFIG, "--control", "displacement", "--method", "stable", "--step",
          "0.001"], ("--step", "0.001", "9000 steps", "--max-steps 2000")),
        (["map", "design", CONFIG, "--b", "0.5", "--C", "1", "--workers", "0"],
         ("--workers", "0", "≥ 1")),
        (["map", "design", CONFIG, "--b", "0.5", "--C", "1", "--chunk-size", "0"],
         ("--chunk-size", "0", "≥ 1")),
        (["map", "design", CONFIG, "--b", "0.5", "--C", "1", "--steps", "1"],
         ("--steps", "1", "[2, 512]")),
        (["map", "stability", CONFIG, "--displacement", "0.1", "--C", "1", "--max-equilibria",
          "0"], ("--max-equilibria", "0", "≥ 1")),
        (["calibrate", "trilinear", DATA / "cft_trilinear", "--seed", "-1"],
         ("--seed", "-1", "≥ 0")),
        (["plot", CONFIG, "--kind", "tube", "--out", "x.png", "--elev", "nan"],
         ("--elev", "nan", "finite")),
    ],
)  # fmt: skip
def test_value_out_of_range_is_refused(
    no_solve: None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    args: list[str],
    needles: tuple[str, ...],
) -> None:
    monkeypatch.chdir(tmp_path)
    _refused(capsys, args, *needles)


@pytest.mark.parametrize(
    ("args", "option"),
    [
        (["plot", CONFIG, "--kind", "response", "--out", "a.png", "--stride", "0"], "--stride"),
        (["plot", CONFIG, "--kind", "response", "--out", "a.png", "--dpi", "5"], "--dpi"),
        (["calibrate", "linear", DATA / "cft_linear", "--bootstrap", "-1"], "--bootstrap"),
        (["calibrate", "linear", DATA / "cft_linear", "--n-folds", "0"], "--n-folds"),
        (["respond", CONFIG, "--max-steps", "x"], "--max-steps"),
    ],
)
def test_typer_range_errors_name_the_option_without_traceback(
    no_solve: None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    args: list[str],
    option: str,
) -> None:
    """Options with simple bounds are checked by Typer: a usage error (status 2) that names
    the option, never a traceback."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    captured = capsys.readouterr()
    assert info.value.code == 2
    assert f"Invalid value for '{option}'" in captured.err
    assert "Traceback" not in captured.out + captured.err


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["respond", CONFIG, "--damping-ratio", "0.1"], ("--damping-ratio", "0.1", "--dynamic")),
        (["respond", CONFIG, "--rate", "1"], ("--rate", "1.0", "without --dynamic")),
        (["respond", CONFIG, "--dynamic", "--stop", "3"], ("--stop", "3.0", "with --dynamic")),
        (["respond", CONFIG, "--control", "displacement", "--method", "stable", "--max-step",
          "0.3"], ("--max-step", "0.3", "--method stable")),
        (["map", "design", CONFIG, "--b", "0.5", "--C", "1", "--workers", "2", "--threads",
          "2"], ("--threads", "2", "--workers > 1")),
        (["map", "design", CONFIG, "--b", "0.5", "--C", "1", "--scheduler", "tcp://h:1",
          "--workers", "3"], ("--workers", "3", "--scheduler")),
    ],
)  # fmt: skip
def test_option_that_would_be_ignored_is_refused(
    no_solve: None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    args: list[str],
    needles: tuple[str, ...],
) -> None:
    monkeypatch.chdir(tmp_path)
    _refused(capsys, args, *needles, "no effect")


@pytest.mark.parametrize(
    ("kind", "out", "needles"),
    [
        ("response", "o", ("'o'", "no suffix", ".png", ".pdf", ".svg")),
        ("response", "o.xyz", ("'o.xyz'", "suffix .xyz", ".png")),
        ("animation", "o.png", ("'o.png'", ".gif, .mp4")),
        ("tube", "o.gif.txt", ("suffix .txt", ".vtu", ".pvd")),
    ],
)
def test_plot_suffix_is_refused_naming_the_supported_ones(
    no_solve: None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    kind: str,
    out: str,
    needles: tuple[str, ...],
) -> None:
    monkeypatch.chdir(tmp_path)
    _refused(capsys, ["plot", CONFIG, "--kind", kind, "--out", out], "--out", *needles)
    assert not list(tmp_path.iterdir())  # nothing written (no o.png)


# --- 3. messages name what the user typed ------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "typed", "internal"),
    [
        (["respond", CONFIG, "--dynamic", "--duration", "-1"],
         "invalid --duration = -1.0: must be > 0 s", "load.times"),
        (["respond", CONFIG, "--step", "-0.1"], "invalid --step = -0.1", "ArcLength"),
        (["map", "design", CONFIG, "--b", "0.5", "--C", "1", "--rate", "0"],
         "invalid --rate = 0.0", "ramp."),
        (["map", "design", CONFIG, "--b", "0.5", "--C", "1", "--after-snap", "jump"],
         "invalid --after-snap = 'jump'", "ramp."),
        (["map", "design", CONFIG, "--b", "0.5", "--C", "-1"], "invalid --C = -1.0", "grid."),
        (["map", "stability", CONFIG, "--displacement", "0.1", "--C", "1", "--b", "5"],
         "invalid --b = 5.0", "helical_angle"),
        (["map", "stability", CONFIG, "--displacement", "0.1", "--C", "1", "--seeding", "x"],
         "invalid --seeding = 'x'", "search."),
        (["calibrate", "trilinear", DATA / "cft_trilinear", "--confidence", "1.5"],
         "invalid --confidence = 1.5: must be in (0, 1)", "invalid confidence"),
        (["calibrate", "trilinear", DATA / "cft_trilinear", "--radius", "-2"],
         "invalid --radius = -2.0: must be > 0 mm", "invalid radius"),
        (["validate", CONFIG, DATA / "mft_semi_bistable", "--min-points", "1"],
         "invalid --min-points = 1", "min_points"),
    ],
)  # fmt: skip
def test_message_names_the_option_not_the_internal_parameter(
    no_solve: None,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    args: list[str],
    typed: str,
    internal: str,
) -> None:
    monkeypatch.chdir(tmp_path)
    line = _refused(capsys, args, typed)
    assert internal not in line


def test_config_error_names_the_toml_key(
    no_solve: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(CONFIG.read_text().replace("pitch = 3.6", "pitch = -3.6"))
    _refused(capsys, ["respond", bad, "--out", tmp_path / "o"], "geometry.pitch = -3.6", "> 0")
    geometry = tmp_path / "cft.toml"
    geometry.write_text("[geometry]\nn_folds = 0\n")
    args = ["calibrate", "linear", DATA / "cft_linear", "--config", geometry]
    _refused(capsys, [*args, "--out", tmp_path / "law.toml"], "geometry.n_folds = 0", "≥ 1")


# --- 4. sizes out of proportion -------------------------------------------------------------
def _tube_file(folder: Path, n_modules: int) -> Path:
    text = CONFIG.read_text()
    assert "n_modules = 6" in text
    file = folder / f"tube{n_modules}.toml"
    file.write_text(text.replace("n_modules = 6", f"n_modules = {n_modules}"))
    return file


@pytest.mark.parametrize("command", ["respond", "states", "map design"])
def test_tube_beyond_the_largest_is_refused_before_any_work(
    no_solve: None, tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    big = _tube_file(tmp_path, 10_000)
    args = {
        "respond": ["respond", big, "--out", tmp_path / "o"],
        "states": ["states", big, "--out", tmp_path / "o"],
        "map design": ["map", "design", big, "--b", "0.5", "--C", "1", "--out", tmp_path / "o"],
    }[command]
    _refused(capsys, args, "geometry.n_modules = 10000", "an integer in [1, 400]")


def test_large_tube_warns_with_its_cost_before_the_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Loading a 200-module tube warns (CostWarning, with the estimate); the CLI prints it as
    one line before anything else happens (here a refused --max-points)."""
    from biplan.analysis.maps.cost import tube_cost

    large = _tube_file(tmp_path, 200)
    with pytest.warns(biplan.CostWarning, match=r"geometry.n_modules = 200 is a large tube"):
        tube = biplan.load_config(large)
    assert tube.n_modules == 200
    cost = tube_cost(200)
    assert 150 < cost.cold_start < 319 and 8.46 < cost.step < 54  # between 192 and 384
    args = ["map", "design", large, "--b", "0.5", "--C", "1", "--max-points", "0"]
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in [*args, "--out", tmp_path / "m"]])
    assert info.value.code == EXIT_BIPLAN_ERROR
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 2 and "Traceback" not in err
    assert lines[0].startswith("warning: ") and "to compile and" in lines[0]
    assert "per solved state" in lines[0]
    assert "invalid --max-points = 0" in lines[1]
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        biplan.load_config(_tube_file(tmp_path, 48))  # the largest example: no warning


def test_grid_beyond_max_points_is_refused_with_its_cost(
    no_solve: None, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    args = ["map", "design", CONFIG, "--b", "0.4:0.6:1000", "--C", "0.5:3:1000", "--threads",
            "2", "--out", tmp_path / "m"]  # fmt: skip
    line = _refused(capsys, args, "--max-points = 100000", "1000000 points",
                    "1000 --b × 1000 --C", "on 2 core(s)")  # fmt: skip
    assert " min on" in line or " h on" in line or "days on" in line  # a long run
    args = ["map", "stability", CONFIG, "--displacement", "0.01:0.4:400", "--C", "0.5:3:300",
            "--max-points", "100000", "--out", tmp_path / "s"]  # fmt: skip
    _refused(capsys, args, "--max-points = 100000", "120000 points", "300 --C × 400")
    assert not (tmp_path / "m").exists() and not (tmp_path / "s").exists()


def test_long_grid_is_warned_of_with_its_cost(capsys: pytest.CaptureFixture[str]) -> None:
    from biplan.analysis.maps.stability_map import StabilityEvaluator
    from biplan.analysis.maps.sweeps import Grid
    from biplan.cli.maps import WARN_SECONDS, check_size

    tube, ev = biplan.load_config(CONFIG), StabilityEvaluator()
    axes = ("--C", "--displacement")
    grid = Grid.of(C="0.5:3:300", displacement="0.01:0.4:300")  # 90,000 points
    seconds = check_size(grid, tube, ev, 100_000, 2, axes)
    assert seconds is not None and seconds > WARN_SECONDS
    err = capsys.readouterr().err
    assert err.startswith("warning: 90000 points (300 --C × 300 --displacement values): about ")
    assert len(err.strip().splitlines()) == 1
    small = Grid.of(C="0.5:3:10", displacement="0.01:0.4:10")
    assert check_size(small, tube, ev, 100_000, 2, axes) < WARN_SECONDS
    assert capsys.readouterr().err == ""


def test_cost_estimates_follow_the_measurements() -> None:
    from biplan.analysis.maps.cost import (
        MAP_POINT_RATE,
        MEASURED_TUBES,
        duration,
        map_seconds,
        tube_cost,
    )

    for n, cold, step in MEASURED_TUBES:
        assert tube_cost(n).cold_start == pytest.approx(cold)
        assert tube_cost(n).step == pytest.approx(step)
    assert tube_cost(1000).step > tube_cost(384).step > tube_cost(192).step
    rate = MAP_POINT_RATE["force_ramp_response"]  # points/s per core, six modules
    assert map_seconds("force_ramp_response", 60, 6, 2) == pytest.approx(30 / rate)
    assert map_seconds("force_ramp_response", 60, 48, 2) == pytest.approx(
        30 / rate * tube_cost(48).step / tube_cost(6).step
    )
    assert map_seconds("unknown", 60, 6, 2) is None
    assert [duration(s) for s in (0.31, 40, 720, 20_000, 400_000)] == [
        "0.31 s", "40 s", "12 min", "5.6 h", "4.6 days"]  # fmt: skip


# --- 7. state labels of ``biplan path`` -------------------------------------------------------
@pytest.mark.parametrize(
    ("start", "target", "bad"),
    [("2A", "zz", "TARGET = 'zz'"), ("2a", "1B2", "TARGET = '1B2'"),
     ("80", "1B", "START = '80'"), ("0x2A", "1B", "START = '0x2A'"),
     ("2A.1", "1B", "START = '2A.1'")],
)  # fmt: skip
def test_path_labels_are_checked_before_enumerating(
    no_solve: None, capsys: pytest.CaptureFixture[str], start: str, target: str, bad: str
) -> None:
    _refused(capsys, ["path", FULLY, start, target], bad, "2 hexadecimal digits from 00 to 7F")


def test_path_label_with_the_wrong_number_of_bits_is_refused(
    no_solve: None, capsys: pytest.CaptureFixture[str]
) -> None:
    """The semi-bistable tube has six bistable folds (two digits, 00 to 3F): '2A' is one of
    its states, '7F' (seven bits) and '1' (one digit) are not."""
    _refused(capsys, ["path", CONFIG, "2a", "7F"], "TARGET = '7F'", "00 to 3F", "6 bistable")
    _refused(capsys, ["path", CONFIG, "1", "2A"], "START = '1'", "2 hexadecimal digits")


def _catalogue(
    folder: Path,
    names: tuple[str, ...] = ("2A", "2B", "0A"),
    config: Path = FULLY,
    edit: tuple[str, str] | None = None,
) -> Path:
    """A states.nc of the tube of ``config`` (``edit`` replaces a string of its text) written
    as ``biplan states`` writes it, with made-up states ``names`` (no solve)."""
    from biplan.analysis.states.catalogue import (
        Enumeration,
        Outcome,
        SeedOutcome,
        StableState,
        StateCatalogue,
    )
    from biplan.analysis.states.labels import bistable_folds, label_to_bits
    from biplan.io.config import dump_config, load_config_text

    text = config.read_text()
    tube = load_config_text(text if edit is None else text.replace(*edit))
    model = biplan.Model(tube)
    folds = bistable_folds(tube)
    n_q, n_folds = model.n_coordinates, len(tube.folds())
    states = tuple(
        StableState(name=n, label=n, bits=label_to_bits(n, len(folds)), q=np.full(n_q, 0.1 * k),
                    z=np.full(n_q + 3, 0.1 * k), energy=0.5 * k, u_z=0.2 * k, u_r=0.01 * k,
                    theta=0.03 * k, min_eigenvalue=1.0 + k, phase_fraction=np.zeros((n_folds, 3)),
                    seeds=(n,))
        for k, n in enumerate(names)
    )  # fmt: skip
    seeds = tuple(
        SeedOutcome(seed=s.name, seed_bits=s.bits, reached_bits=s.bits, outcome=Outcome.STABLE,
                    state=s.name, min_eigenvalue=s.min_eigenvalue, residual=0.0, message="")
        for s in states
    )  # fmt: skip
    catalogue = StateCatalogue(model, folds, states, seeds, np.zeros((0, n_q + 3)), np.zeros(0),
                               Enumeration(), 1.5)  # fmt: skip
    ds = catalogue.to_dataset()
    ds.attrs["config"] = dump_config(tube)
    folder.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(folder / "states.nc", engine="h5netcdf")
    return folder / "states.nc"


@pytest.fixture(scope="module")
def catalogues(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Catalogue files of the fully bistable tube: its own, and one of other circular laws
    (written before ``no_solve`` forbids building a model)."""
    folder = tmp_path_factory.mktemp("catalogues")
    edit = ("stiffness = [0.9, -0.37, 0.6]", "stiffness = [0.9, -0.3, 0.6]")
    assert edit[0] in FULLY.read_text()
    return {
        "fully": _catalogue(folder / "fully"),
        "other laws": _catalogue(folder / "other", edit=edit),
    }


def test_catalogue_file_gives_the_catalogue_back(tmp_path: Path) -> None:
    from biplan.io.catalogue import load_catalogue, read_catalogue

    tube = biplan.load_config(FULLY)
    ds = read_catalogue(_catalogue(tmp_path), tube)
    catalogue = load_catalogue(ds, biplan.Model(tube))
    assert catalogue.names == ("2A", "2B", "0A")
    assert catalogue.state("2B").bits == (0, 1, 0, 1, 0, 1, 1)
    np.testing.assert_allclose(catalogue.state("0A").z, 0.2)
    assert catalogue.rows()[1]["Theta"] == pytest.approx(0.5)
    assert [s.state for s in catalogue.seeds] == ["2A", "2B", "0A"]
    assert list(ds["fold"].values) == list(biplan.Model(tube).layout.fold_names)
    assert ds.attrs["bit_folds"].split(", ")[:2] == ["helical 4", "circular 3|4"]


def test_path_reads_the_catalogue_and_names_folds_as_the_files_do(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--states`` replaces the enumeration; each step names its fold as the result files do
    (modules from 1): 2B → 2A switches bit 6 (H₁, "helical 1"), 2A → 0A bit 1 (C₃|₄)."""
    import biplan.analysis.states.search
    import biplan.analysis.states.transitions

    file = _catalogue(tmp_path)
    monkeypatch.setattr(biplan.analysis.states.search, "enumerate_states", _forbidden)

    def barriers(graph, model, catalogue, edges=None, neb=None, departure=False):  # type: ignore[no-untyped-def]
        for u, v in edges:
            graph.edges[u, v].update(forward_from=u, saddle_energy=9.0, mep_status="CONVERGED")
        return graph

    def departures(graph, model, catalogue, steps):  # type: ignore[no-untyped-def]
        found = {
            ("2B", "2A"): (1.25, "found"),
            ("2A", "0A"): (float("nan"), "no_loss_of_stability"),
        }
        for u, v in steps:
            force, status = found[u, v]
            graph.edges[u, v].update(departure_force=force, departure_status=status)
        return graph

    monkeypatch.setattr(biplan.analysis.states.transitions, "annotate_barriers", barriers)
    monkeypatch.setattr(biplan.analysis.states.transitions, "annotate_departures", departures)
    main_exit = None
    try:
        main([str(a) for a in ["path", FULLY, "2b", "0a", "--states", file, "-q"]])
    except SystemExit as info:
        main_exit = info.code
    out = capsys.readouterr().out
    assert main_exit in (None, 0), out
    assert "2B → 2A → 0A" in out
    assert "2B → 2A: fold helical 1, barrier 8.5 N·mm" in out
    assert "2A → 0A: fold circular 3|4, barrier 9 N·mm" in out
    flat = " ".join(out.split())
    assert "(CONVERGED), departure force 1.25 N" in flat  # found on the ramp
    assert "no departure force: no loss of stability up to the end of the ramp" in flat
    assert "nan" not in flat
    names = biplan.Model(biplan.load_config(FULLY)).layout.fold_names
    assert {"helical 1", "circular 3|4"} <= set(names)  # the names of response.nc's fold axis


@pytest.mark.parametrize(
    ("case", "needles"),
    [
        ("missing", ("--states", "an existing file")),
        ("garbage", ("--states", "cannot read it")),
        ("path result", ("--states", "it is a path result")),
        ("other tube", ("--states", "6 modules and 6 bistable folds",
                        "4 modules and 7 bistable folds")),
        ("other laws", ("--states", "fold laws differ")),
        ("state not held", ("TARGET = '66'", "a stable state of", "2A, 2B, 0A")),
    ],
)  # fmt: skip
def test_path_catalogue_is_checked_before_any_work(
    catalogues: dict[str, Path], no_solve: None, tmp_path: Path,
    capsys: pytest.CaptureFixture[str], case: str, needles: tuple[str, ...],
) -> None:  # fmt: skip
    config, start, target = FULLY, "2A", "0A"
    if case == "missing":
        file = tmp_path / "none.nc"
    elif case == "garbage":
        file = tmp_path / "states.nc"
        file.write_bytes(b"not a netCDF file")
    elif case == "path result":
        import xarray as xr

        file = tmp_path / "path.nc"
        xr.Dataset({"force": ("step", [0.0])}, attrs={"kind": "path"}).to_netcdf(file)
    else:
        file = catalogues["other laws" if case == "other laws" else "fully"]
        if case == "other tube":
            config, start, target = CONFIG, "2A", "0A"
        if case == "state not held":
            target = "66"
    _refused(capsys, ["path", config, start, target, "--states", file], *needles)


@pytest.mark.parametrize(
    ("file", "kind", "needles"),
    [
        ("states", "response", ("--kind = 'response'", "one of development, tube, gallery",
                                "a state catalogue")),
        ("states", "phases", ("--kind = 'phases'", "one of development, tube, gallery")),
        ("map", "response", ("--kind = 'response'", "a map (stability_count)",
                             "`biplan map plot` draws a map")),
        ("map", "gallery", ("--kind = 'gallery'", "nothing `biplan plot` draws")),
    ],
)  # fmt: skip
def test_plot_kind_that_does_not_apply_names_the_kinds_that_do(
    catalogues: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch, file: str, kind: str, needles: tuple[str, ...],
) -> None:  # fmt: skip
    import xarray as xr

    import biplan.plot.results

    monkeypatch.setattr(biplan.plot.results, "result_figure", _forbidden)  # nothing is drawn
    monkeypatch.setattr(biplan.plot.results, "model_of", _forbidden)
    path = catalogues["fully"]
    if file == "map":
        path = tmp_path / "map.nc"
        regime = (("C", "displacement"), np.ones((2, 2)))
        xr.Dataset({"regime": regime}, attrs={"quantity": "stability_count"}).to_netcdf(path)
    line = _refused(capsys, ["plot", path, "--kind", kind, "--out", tmp_path / "f.png"], *needles)
    assert str(path) in line
    assert not (tmp_path / "f.png").exists()


def test_state_names_are_read_in_any_case() -> None:
    from biplan.analysis.states.labels import state_name

    tube = biplan.load_config(FULLY)
    assert state_name("START", "2a", tube) == "2A"
    assert state_name("START", " 1b.2", tube) == "1B.2"
    assert state_name("TARGET", "00", tube) == "00"


# --- 5. maps in which points failed --------------------------------------------------------
def _fake_ramp(monkeypatch: pytest.MonkeyPatch, status: list[int]) -> list[int]:
    """Replace the batched force ramp by one that returns ``status`` (by point, in order) and
    zeros; returns the list of batch sizes it was called with."""
    from biplan.analysis.maps.design_map import ResponseEvaluator

    calls: list[int] = []
    codes = iter(status)

    def evaluate(self, tubes, loads, batch):  # type: ignore[no-untyped-def]
        calls.append(len(tubes))
        out = {name: np.zeros(len(tubes)) for name in self.variables(tubes[0])}
        out["status"] = np.array([next(codes) for _ in tubes], dtype=np.int64)
        return out

    monkeypatch.setattr(ResponseEvaluator, "evaluate", evaluate)
    return calls


MAP = ["map", "design", CONFIG, "--b", "0.5,0.55", "--C", "1", "--threads", "1"]


def test_map_where_every_point_failed_exits_non_zero(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _fake_ramp(monkeypatch, [1, 1])
    line = _refused(capsys, [*MAP, "--out", tmp_path / "m", "--quiet"], "every one of the 2")
    assert "failed" in line and str(tmp_path / "m" / "map.nc") in line
    assert (tmp_path / "m" / "map.nc").is_file()  # the statuses are kept


def test_map_with_failed_points_says_how_many(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    _fake_ramp(monkeypatch, [0, 1])
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in [*MAP, "--out", tmp_path / "m", "--quiet"]])
    assert info.value.code == 0
    err = capsys.readouterr().err
    assert "warning: 1 of 2 points failed" in err  # on the terminal, even with --quiet
    assert "b = 0.55, C = 1: not_converged" in " ".join(err.split())  # where and why


# --- 6. resume ------------------------------------------------------------------------------
def _two_chunk_map(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, list[int]]:
    """A finished two-chunk map (fake ramp) in tmp_path/m; returns it and the call log."""
    calls = _fake_ramp(monkeypatch, [0] * 10)
    out = tmp_path / "m"
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in [*MAP, "--chunk-size", "1", "--out", out, "--quiet"]])
    assert info.value.code == 0 and calls == [1, 1]
    calls.clear()
    return out, calls


def test_resume_recomputes_a_truncated_chunk_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    out, calls = _two_chunk_map(tmp_path, monkeypatch)
    chunk = out / "chunks" / "chunk-00001.npz"
    chunk.write_bytes(chunk.read_bytes()[:100])
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in [*MAP, "--chunk-size", "1", "--out", out, "--resume"]])
    captured = capsys.readouterr()
    assert info.value.code == 0, captured.err
    assert "Traceback" not in captured.out + captured.err
    assert "chunk 1" in captured.err and "cannot be read" in captured.err
    assert "computing it again" in captured.err
    assert "1 of 2 chunks reused" in captured.out
    assert calls == [1]  # only the damaged chunk
    assert json.loads((out / "manifest.json").read_text())["finished"] == [0, 1]


def test_resume_without_manifest_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    out, calls = _two_chunk_map(tmp_path, monkeypatch)
    (out / "manifest.json").unlink()
    capsys.readouterr()
    args = [*MAP, "--chunk-size", "1", "--out", out]
    _refused(capsys, [*args, "--resume"], "--out", "manifest.json", "2 chunk files")
    _refused(capsys, args, "--out", "manifest.json")  # nor overwritten without --resume
    assert calls == [] and len(list((out / "chunks").glob("chunk-*.npz"))) == 2


def test_chunk_store_reports_missing_and_unreadable_chunks(tmp_path: Path) -> None:
    from biplan.io.sweepstore import ChunkStore

    desc = {"grid": [1, 2, 3]}
    store = ChunkStore(tmp_path, desc, 3, resume=False)
    for c in range(3):
        store.save(c, {"x": np.full(2, float(c))})
    (tmp_path / "chunks" / "chunk-00001.npz").write_bytes(b"garbage")
    (tmp_path / "chunks" / "chunk-00002.npz").unlink()
    again = ChunkStore(tmp_path, desc, 3, resume=True)
    assert again.reused == 1 and again.done(0) and not again.done(1) and not again.done(2)
    assert "cannot be read" in again.damaged[1] and "missing" in again.damaged[2]
    np.testing.assert_array_equal(again.load(0)["x"], [0.0, 0.0])
    (tmp_path / "manifest.json").write_text("{not json")
    with pytest.raises(biplan.ConfigError, match=r"readable manifest\.json"):
        ChunkStore(tmp_path, desc, 3, resume=True)


def test_chunk_store_reads_back_every_array_exactly(tmp_path: Path) -> None:
    """A chunk archive returns the arrays it was given, dtype and bits (NaN, -0.0, the last
    ulp), and refuses an object array rather than pickling it."""
    from biplan.io.sweepstore import ChunkStore

    rng = np.random.default_rng(3)
    arrays = {
        "z": np.concatenate([rng.standard_normal(5), [np.nan, -0.0, np.inf, 1 + 2**-52]]),
        "status": rng.integers(-(2**62), 2**62, size=(9, 2), dtype=np.int64),
        "stable": rng.random(9) > 0.5,
        "name": np.array(["00", "1B.2", "näme"] * 3),
    }
    store = ChunkStore(tmp_path, {"grid": [1]}, 2, resume=False)
    store.save(0, arrays)
    back = ChunkStore(tmp_path, {"grid": [1]}, 2, resume=True).load(0)
    assert sorted(back) == sorted(arrays)
    for name, arr in arrays.items():
        assert back[name].dtype == arr.dtype and back[name].shape == arr.shape
        assert back[name].tobytes() == arr.tobytes()
    with pytest.raises(TypeError, match="'bad' holds Python objects"):
        store.save(1, {"bad": np.array([{}, None], dtype=object)})
    assert not store.done(1)


def test_chunk_store_resumes_the_netcdf_chunks_of_an_earlier_version(tmp_path: Path) -> None:
    """A run of an earlier biplan stored its chunks as netCDF files; a resumed run reads them
    (the same arrays) instead of computing them again, and writes new chunks as archives."""
    import xarray as xr

    from biplan.io.netcdf import write_netcdf
    from biplan.io.sweepstore import ChunkStore

    desc = {"grid": [1, 2]}
    store = ChunkStore(tmp_path, desc, 2, resume=False)
    store.save(0, {"x": np.array([0.5, -1.0]), "n": np.array([[1, 2]] * 2)})
    (tmp_path / "chunks" / "chunk-00000.npz").unlink()
    old = xr.Dataset({"x": (("point",), [0.5, -1.0]), "n": (("point", "n_1"), [[1, 2]] * 2)})
    write_netcdf(old, tmp_path / "chunks" / "chunk-00000.nc")
    again = ChunkStore(tmp_path, desc, 2, resume=True)
    assert again.reused == 1 and not again.damaged
    np.testing.assert_array_equal(again.load(0)["x"], [0.5, -1.0])
    np.testing.assert_array_equal(again.load(0)["n"], [[1, 2]] * 2)
    again.save(1, {"x": np.zeros(2), "n": np.zeros((2, 2), dtype=np.int64)})
    assert (tmp_path / "chunks" / "chunk-00001.npz").exists()


def test_states_resume_says_what_it_reuses_and_recomputes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``biplan states --resume`` over a damaged chunk names it on stderr, computes it again
    and says how many chunks it reused; the states are those of the first run."""
    config = Path(__file__).parents[1] / "examples" / "fully_bistable_4.toml"
    out = tmp_path / "s"
    args = ["states", str(config), "--out", str(out), "--quiet"]
    with pytest.raises(SystemExit) as info:
        main(args)
    assert info.value.code == 0
    first = (out / "states.csv").read_text()
    chunk = out / "seeds" / "chunks" / "chunk-00000.npz"
    chunk.write_bytes(chunk.read_bytes()[:64])
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main([*args[:-1], "--resume"])
    captured = capsys.readouterr()
    assert info.value.code == 0, captured.err
    assert "chunk 0 of" in captured.err and "cannot be read" in captured.err
    assert "computing it again" in captured.err
    assert "0 of 1 chunks of seeds reused" in captured.out
    assert (out / "states.csv").read_text() == first


def test_states_of_a_tube_without_bistable_folds_is_refused_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A tube whose laws are all monostable has no states to search: one line names CONFIG as
    typed and how many fold laws it has (before, the value shown was the tube's empty name)."""
    import biplan
    from biplan.io.config import dump_config
    from biplan.laws.linear import LinearLaw

    tube = biplan.Tube.uniform(radius=2.0, pitch=3.6, helical_angle=60.0, n_modules=3,
                               helical=LinearLaw(1.3), circular=LinearLaw(0.9))  # fmt: skip
    config = tmp_path / "linear.toml"
    config.write_text(dump_config(tube), encoding="utf-8")
    _refused(capsys, ["states", config, "--out", tmp_path / "s"], f"CONFIG = '{config}'",
             "at least one bistable fold law", "its 6 fold laws are all monostable")  # fmt: skip
