"""``biplan respond`` in-process: files, columns, dynamic runs, errors."""

from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest
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
    # to 1 mm the tube never leaves phase 1: its largest force is no peak
    assert "phase 1 not left (largest force" in result.output
    assert "phase-1 peak force" not in result.output


def test_respond_dynamic_pressure(tmp_path: Path) -> None:
    out = tmp_path / "dyn"
    args = ["respond", str(CONFIG), "--control", "pressure", "--dynamic", "--rate", "50"]
    result = runner.invoke(
        app, [*args, "--duration", "0.1", "--time-step", "0.02", "--out", str(out), "--quiet"]
    )
    assert result.exit_code == 0, result.output
    header = _header(out / "response.csv")
    assert header[0] == "t" and set(header) >= REQUIRED
    from PIL import Image

    with Image.open(out / "response.png") as png:  # F–z_p beside F(t), z_p(t)
        assert png.width > 1.8 * png.height


def test_respond_rejects_a_missing_config(tmp_path: Path) -> None:
    result = runner.invoke(app, ["respond", str(tmp_path / "nope.toml")])
    assert result.exit_code != 0


def test_bifurcation_note_names_the_first_bifurcation_only_when_there_is_one() -> None:
    from types import SimpleNamespace

    from biplan.cli.respond import bifurcation_note
    from biplan.solvers.path_results import Event

    limit = Event("limit point", 3, 1.5, 2.1, 1.5)
    bif = Event("bifurcation", 8, 1.54, 2.126, 1.54)
    assert bifurcation_note(SimpleNamespace(events=(limit,))) is None
    assert bifurcation_note(SimpleNamespace()) is None  # a trajectory has no events
    note = bifurcation_note(SimpleNamespace(events=(limit, bif, bif)))
    assert note is not None
    assert "2 bifurcation(s)" in note and "z_p = 1.54 mm, F = 2.13 N" in note
    assert "--method stable" in note


def test_respond_stable_branch_sweep(tmp_path: Path) -> None:
    """``--method stable``: the testing machine's view — stable equilibria only, the first
    circular fold snapping open near U = 1.6 mm (force drop), labelled files written."""
    import numpy as np
    import xarray as xr

    import biplan
    from biplan.io.results import SWEEP_CSV_COLUMNS

    out = tmp_path / "stable"
    args = ["respond", str(CONFIG), "--control", "displacement", "--method", "stable"]
    result = runner.invoke(app, [*args, "--stop", "2.5", "--step", "0.25", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "stable-branch sweep to U = 2.5 mm: 10 steps" in result.output
    header = _header(out / "response.csv")
    assert tuple(header) == SWEEP_CSV_COLUMNS and set(header) >= REQUIRED
    with xr.open_dataset(out / "response.nc", engine="h5netcdf") as ds:
        ds = ds.load()
    assert ds.attrs["kind"] == "stable-branch sweep" and "[laws.circular]" in ds.attrs["config"]
    assert ds["q"].dims == ("step", "coordinate") and ds.sizes["step"] == 10
    assert (ds["stable"].values == 1).all() and (ds["status"].values == 0).all()
    force = ds["force"].values
    snap = int(np.argmax(ds["switched"].values))
    assert ds["switched"].values.any() and 1.25 <= ds["displacement"].values[snap] <= 2.0
    assert force[snap] < 0.5 * force[snap - 1]  # the fold snapped open: the force dropped
    # the summary's phase-1 peak is the located first loss of stability under force control:
    # at least the largest force recorded before the first snap, the same as `respond
    # --control force` reports (test_respond_force_default_is_the_load_controlled_test)
    peak = re.search(r"phase-1 peak force ([\d.]+) ± (\S+) N at z_p = ([\d.]+) mm",
                     result.output)  # fmt: skip
    assert peak is not None
    assert force[snap - 1] - 1e-4 <= float(peak[1]) <= force[snap - 1] * 1.01
    assert ds["displacement"].values[snap - 1] <= float(peak[3]) <= ds["displacement"].values[snap]
    # biplan plot draws it (snaps dotted)
    drawn = runner.invoke(app, ["plot", str(out / "response.nc"), "--kind", "response",
                                "--out", str(out / "again.png")])  # fmt: skip
    assert drawn.exit_code == 0, drawn.output
    assert (out / "again.png").read_bytes()[:4] == b"\x89PNG"
    # every fold's energy and branch fractions: one circular fold opens at the snap
    n_h = sum(str(f).startswith("helical") for f in ds["fold"].values)
    assert n_h == 6 and ds.sizes["fold"] == 12  # six helical, six circular (base fold + 5)
    np.testing.assert_allclose(ds["fold_energy"].sum("fold"), ds["energy"], rtol=1e-9)
    np.testing.assert_allclose(ds["helical_energy"] + ds["circular_energy"], ds["energy"],
                               rtol=1e-9)  # fmt: skip
    open_ = ds["phase_fraction"].sel(phase="open").values  # (step, fold)
    assert (open_[:snap] < 0.5).all()
    assert (open_[snap, :n_h] < 0.5).all() and (open_[snap, n_h:] > 0.5).sum() == 1
    for kind in ("phases", "energy", "eigenvalue"):
        drawn = runner.invoke(app, ["plot", str(out / "response.nc"), "--kind", kind,
                                    "--out", str(out / f"{kind}.png")])  # fmt: skip
        assert drawn.exit_code == 0, drawn.output
        assert (out / f"{kind}.png").read_bytes()[:4] == b"\x89PNG"
    anim = ["--kind", "animation", "--stride", "4", "--dpi", "40", "--out", str(out / "a.gif")]
    drawn = runner.invoke(app, ["plot", str(out / "response.nc"), *anim])
    assert drawn.exit_code == 0, drawn.output
    from PIL import Image

    with Image.open(out / "a.gif") as gif:
        assert gif.n_frames == 3  # steps 0, 4, 8
    # refused before solving when it cannot apply
    bad = runner.invoke(app, [*args, "--stop-at-snap", "--out", str(out)])
    assert isinstance(bad.exception, biplan.ConfigError) and "--stop-at-snap" in str(bad.exception)
    bad = runner.invoke(app, [*args, "--step", "0", "--out", str(out)])
    assert isinstance(bad.exception, biplan.ConfigError) and "--step" in str(bad.exception)


def test_respond_force_default_is_the_load_controlled_test(tmp_path: Path) -> None:
    """``respond --control force`` (default method stable) up to the first snap: stable
    states only, the snap reported with its tolerance, the same peak as the displacement
    sweep's summary; a run that ends short of --stop exits 1 with the reason."""
    import xarray as xr

    out = tmp_path / "force"
    args = ["respond", str(CONFIG), "--control", "force", "--stop-at-snap", "--out", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "stable response (what a load-controlled test does)" in result.output
    assert "stopped at the first snap" in result.output
    snap = re.search(r"snap at ([\d.]+) ± \S+ N", result.output)
    peak = re.search(r"phase-1 peak force ([\d.]+) ±", result.output)
    assert snap is not None and peak is not None and snap[1] == peak[1]
    assert 2.0 < float(peak[1]) < 2.2
    assert {"segment", "switched"} <= set(_header(out / "response.csv"))
    with xr.open_dataset(out / "response.nc", engine="h5netcdf") as ds:
        assert (ds["stable"].values == 1).all() and "snap at" in ds.attrs["snaps"]
        assert float(ds["force"].max()) == pytest.approx(float(peak[1]), abs=1e-4)
    sweep = runner.invoke(app, ["respond", str(CONFIG), "--control", "displacement", "--stop",
                                "2", "--step", "0.25", "--out", str(tmp_path / "d")])  # fmt: skip
    assert sweep.exit_code == 0, sweep.output
    assert f"phase-1 peak force {peak[1]} ±" in sweep.output
    short = runner.invoke(app, [*args[:-3], "--max-steps", "3", "--out", str(tmp_path / "s")])
    assert short.exit_code == 1
    assert "ended short of --stop" in short.output and "maximum number of steps" in short.output
    assert (tmp_path / "s" / "response.nc").is_file()


def test_respond_writes_its_files_without_xarray(tmp_path: Path) -> None:
    """The default response (and its netCDF file) in a new process imports neither JAX nor
    xarray, pandas or Dask (about 0.8 s of imports: docs/performance.md)."""
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from biplan.cli.main import app\n"
        f"argv = ['respond', {str(CONFIG)!r}, '--out', {str(tmp_path)!r}, '--quiet']\n"
        "try:\n"
        "    app(argv)\n"
        "except SystemExit as e:\n"
        "    assert e.code in (0, None), e.code\n"
        "heavy = {'jax', 'xarray', 'pandas', 'dask'}\n"
        "print(sorted({m.split('.')[0] for m in sys.modules} & heavy))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().splitlines()[-1] == "[]"
    import xarray as xr

    with xr.open_dataset(tmp_path / "response.nc", engine="h5netcdf") as ds:
        assert ds.attrs["kind"] == "path" and ds.sizes["step"] > 10
        assert "[geometry]" in ds.attrs["config"]


def test_a_stable_sweep_says_where_and_why_its_steps_failed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A sweep whose every step failed exits 1 with an error line naming the first failed
    step's U and the solver's reason (a one-module tube without base fold is contact-locked
    under tension: nothing can be pulled); one that went on past a failed step warns with the
    same, and exits 0."""
    import biplan
    from biplan.analysis.response import quasistatic
    from biplan.io.config import dump_config

    locked = tmp_path / "one_module.toml"
    locked.write_text(dump_config(biplan.designs.fully_bistable(n_modules=1)), encoding="utf-8")
    args = ["respond", str(locked), "--control", "displacement", "--stop", "0.5"]
    result = runner.invoke(app, [*args, "--step", "0.25", "--out", str(tmp_path / "a")])
    assert result.exit_code == 1, result.output
    assert "2 of 2 steps failed; the first at U = 0.25 mm: " in result.output
    assert "error: the response ended short of --stop" in result.output
    assert "after" in result.output and "‖r‖∞" in result.output  # the solver's own message

    advance = quasistatic._advance

    def one_fails(model, solver, current, target, select_stable, depth=0):  # type: ignore[no-untyped-def]
        if target == 0.5 and depth == 0:  # a real failed solve: one Newton step, no retry
            one_step = biplan.Newton(max_steps=1, contact_restart=False)
            load = biplan.Load.of_displacement(target)
            return biplan.solve_equilibrium(model, one_step, current, load), None, False
        return advance(model, solver, current, target, select_stable, depth)

    monkeypatch.setattr(quasistatic, "_advance", one_fails)
    args = ["respond", str(CONFIG), "--control", "displacement", "--stop", "1.0"]
    result = runner.invoke(app, [*args, "--step", "0.25", "--out", str(tmp_path / "b")])
    assert result.exit_code == 0, result.output
    assert "warning: 1 of 4 steps failed; the first at U = 0.5 mm: maximum number" in (
        result.output
    )
