"""Pictures of every result type: headless runs, content checks, animations, CLI, and one image
regression per figure type.

Image regressions compare a low-resolution PNG with ``tests/baseline/<name>.png`` by the RMS
pixel difference (0–255 scale). Regenerate the baselines after an intended change with
``BIPLAN_UPDATE_BASELINES=1 pytest tests/test_visual.py``.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import imageio.v3 as iio
import imageio_ffmpeg
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from typer.testing import CliRunner

import biplan
from _datasets import result_dataset, states_dataset
from biplan.cli.main import EXIT_BIPLAN_ERROR, app, main
from biplan.plot import cylinder, development, development_panels, force_displacement
from biplan.plot.animation import _frames, animate, frame_indices
from biplan.plot.diagnostics import (
    energy_by_fold_set,
    measured_band,
    min_eigenvalue,
    phase_fractions,
)
from biplan.plot.gallery import gallery, open_helical_folds

BASELINES = Path(__file__).parent / "baseline"
UPDATE = os.environ.get("BIPLAN_UPDATE_BASELINES") == "1"
#: RMS pixel difference [0–255] tolerated (anti-aliasing, font hinting, solver round-off).
RMS_TOLERANCE = 6.0
BASELINE_DPI = 50
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


# --- datasets ----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def path_states(model6, reference6):
    """Equilibria of the semi-bistable tube along a displacement ramp (phase 1 → phase 2)."""
    qs, forces, sol = [reference6.q], [reference6.force], reference6
    for u in np.linspace(0.6, 8.0, 9):
        sol = biplan.solve_equilibrium(
            model6, biplan.Newton(), sol, biplan.Load.of_displacement(u), throw=False
        )
        qs.append(sol.q)
        forces.append(sol.force)
    return np.array(qs), np.array(forces)


@pytest.fixture(scope="module")
def path_ds(model6, path_states):
    return result_dataset(model6, *path_states)


@pytest.fixture(scope="module")
def trajectory_ds(model6, path_states):
    qs, forces = path_states
    return result_dataset(model6, qs, forces, times=np.linspace(0.0, 0.09, len(qs)))


def test_phase_map_of_a_sweep_is_drawn_over_the_displacement(path_ds) -> None:
    """A stable-branch sweep's U only grows, so its phase map runs over U; a path's (which may
    turn back at limit points) over the step index."""
    from biplan.analysis.response.quasistatic import SWEEP_KIND

    assert phase_fractions(path_ds).get_xlabel() == "step"
    sweep = path_ds.assign_attrs(kind=SWEEP_KIND)
    ax = phase_fractions(sweep)
    assert ax.get_xlabel() == "$U$ [mm]"
    mesh = next(c for c in ax.collections if c.get_gid() == "phase-fractions")
    u = sweep["displacement"].values
    assert mesh.get_coordinates()[0, 0, 0] < u[0] < u[-1] < mesh.get_coordinates()[0, -1, 0]


def _opened(model, helical=(), circular=()) -> np.ndarray:
    """A configuration of the fully bistable tube with the given folds opened."""
    n = model.layout.n_modules
    q = model.zeros()
    for m in helical:
        trial = []
        for phi in (-0.1, 0.1):
            qq = q.copy()
            qq[3 * m + 1] = phi
            trial.append((model.helical_boundary(qq)[m].mean(), phi))
        q[3 * m + 1] = max(trial)[1]
    for c in circular:
        q[3 * n + c] = 1.5
    return q


@pytest.fixture(scope="module")
def states_ds(model4):
    specs = {
        "00": ((), ()),
        "2A": ((), (0, 1, 2)),
        "66": ((3, 1), (2, 0)),
        "1B": ((2, 0), (1, 0)),
        "40": ((3,), ()),
        "55": ((3, 2, 1), (2,)),
    }
    qs = [_opened(model4, h, c) for h, c in specs.values()]
    return states_dataset(model4, np.array(qs), list(specs))


def _curve(ds) -> SimpleNamespace:
    n = ds["force"].size
    return SimpleNamespace(
        displacement=ds["displacement"].values,
        force=ds["force"].values,
        stable=ds["stable"].values.astype(bool),
        switched=np.zeros(n, dtype=bool),
    )


# --- image regression ------------------------------------------------------------------------
def check_image(fig: Figure, name: str) -> None:
    """Compare ``fig`` with its baseline PNG by RMS pixel difference (or write the baseline)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=BASELINE_DPI)
    baseline = BASELINES / f"{name}.png"
    if UPDATE:
        BASELINES.mkdir(exist_ok=True)
        baseline.write_bytes(buf.getvalue())
        return
    if not baseline.exists():
        pytest.fail(f"no baseline {baseline.name}; run with BIPLAN_UPDATE_BASELINES=1")
    actual = iio.imread(buf.getvalue(), extension=".png")[..., :3].astype(float)
    expected = iio.imread(baseline)[..., :3].astype(float)
    assert actual.shape == expected.shape, f"{name}: size {actual.shape} != {expected.shape}"
    rms = float(np.sqrt(np.mean((actual - expected) ** 2)))
    assert rms <= RMS_TOLERANCE, f"{name}: RMS pixel difference {rms:.2f} > {RMS_TOLERANCE}"


def test_image_development(model6, path_ds) -> None:
    q = path_ds["q"].values[5]
    check_image(development(model6, q, guides=True, reference=True).figure, "development")


def test_image_development_panels(model6, path_ds) -> None:
    qs = path_ds["q"].values[[0, -1]]
    fig = development_panels(model6, qs, titles=["reference", "stretched"], color_by="phase")
    check_image(fig, "development_panels")


def test_image_tube(model6, path_ds) -> None:
    check_image(cylinder(model6, path_ds["q"].values[-1], colorbar=True).figure, "tube")


def test_image_response(path_ds) -> None:
    ax = force_displacement(_curve(path_ds))
    u = path_ds["displacement"].values
    measured_band(u, 0.9 * path_ds["force"].values, 0.1 + 0.0 * u, ax=ax)
    check_image(ax.figure, "response")


@pytest.mark.parametrize(
    ("name", "draw"),
    [("energy", energy_by_fold_set), ("eigenvalue", min_eigenvalue), ("phases", phase_fractions)],
)
def test_image_diagnostics(trajectory_ds, name, draw) -> None:
    check_image(draw(trajectory_ds).figure, name)


def test_image_gallery(model4, states_ds) -> None:
    check_image(gallery(states_ds, model4, ncols=3), "gallery")


# --- headless runs and content ----------------------------------------------------------------
@pytest.mark.parametrize("kind", ["path", "trajectory"])
def test_plots_run_on_every_result_type(request, model6, kind) -> None:
    ds = request.getfixturevalue(f"{kind}_ds")
    q = ds["q"].values[-1]
    xunit = "[mm]" if kind == "path" else "[s]"
    for ax in (energy_by_fold_set(ds), min_eigenvalue(ds, symlog=True)):
        assert isinstance(ax, Axes) and xunit in ax.get_xlabel() and "[N" in ax.get_ylabel()
    ax = phase_fractions(ds, phase="spinodal")
    assert [t.get_text() for t in ax.get_yticklabels()] == list(ds["fold"].values)
    assert isinstance(force_displacement(_curve(ds)), Axes)
    assert isinstance(development(model6, q, color_by="phase"), Axes)
    assert cylinder(model6, q).name == "3d"
    for fig in plt.get_fignums():
        plt.figure(fig).canvas.draw()


def test_plots_run_on_a_state_catalogue(model4, states_ds) -> None:
    q = states_ds["q"].values[2]
    assert isinstance(gallery(states_ds, model4, color_by="elongation"), Figure)
    assert isinstance(development(model4, q, color_by="phase", guides=True), Axes)
    cylinder(model4, q, color_by="phase", colorbar=True).figure.canvas.draw()


def test_diagnostics_content(path_ds, trajectory_ds) -> None:
    assert len(energy_by_fold_set(path_ds).lines) == 3
    ax = energy_by_fold_set(trajectory_ds)
    assert [ln.get_label() for ln in ax.lines][-2:] == ["kinetic", "energy balance"]
    np.testing.assert_allclose(ax.lines[2].get_ydata(), trajectory_ds["energy"].values)
    ax = min_eigenvalue(path_ds)
    n_unstable_runs = np.sum(np.diff(np.r_[0, 1 - path_ds["stable"].values, 0]) == 1)
    assert sum(ln.get_gid() == "unstable" for ln in ax.lines) == n_unstable_runs
    ax = phase_fractions(path_ds)
    mesh = next(c for c in ax.collections if c.get_gid() == "phase-fractions")
    expected = path_ds["phase_fraction"].sel(phase="open").values.T
    np.testing.assert_allclose(np.asarray(mesh.get_array()).reshape(expected.shape), expected)
    with pytest.raises(ValueError, match="phase"):
        phase_fractions(path_ds, phase="molten")
    if not np.all(np.diff(path_ds["displacement"].values) > 0):
        with pytest.raises(ValueError, match="monotonic"):
            phase_fractions(path_ds, x="displacement")
    with pytest.raises(ValueError, match="variable"):
        energy_by_fold_set(path_ds, x="nothing")
    with pytest.raises(ValueError, match="shapes"):
        measured_band([0.0, 1.0], [1.0], [0.1, 0.1])


def test_development_guides_and_panels(model6, path_ds) -> None:
    n = model6.layout.n_modules
    ax = development(model6, path_ds["q"].values[4], guides=True)
    rails = next(c for c in ax.collections if c.get_gid() == "guides")
    assert len(rails.get_segments()) == 2 * n
    pivots = next(ln for ln in ax.lines if ln.get_gid() == "pivots")
    np.testing.assert_allclose(
        pivots.get_xydata()[:, ::-1],
        model6.global_nodes(path_ds["q"].values[4])[:, [0, 6]].reshape(-1, 2),
    )
    fig = development_panels(model6, path_ds["q"].values[[0, -1]], titles=["a", "b"])
    panels = [a for a in fig.axes if a.get_title()]
    assert [a.get_title() for a in panels] == ["a", "b"] and len(fig.axes) == 3
    assert panels[0].get_xlim() == panels[1].get_xlim()


def test_cylinder_fold_colouring(model6, path_ds) -> None:
    q = path_ds["q"].values[-1]
    ax = cylinder(model6, q)
    folds = next(c for c in ax.collections if c.get_gid() == "cylinder-folds")
    values = np.asarray(folds.get_array())
    w = np.r_[*(np.r_[w0, w1] for w0, w1, _ in model6.circular_fields(q))]
    w = np.r_[w, model6.helical_boundary(q).ravel()]
    assert values.min() >= w.min() - 1e-12 and values.max() <= w.max() + 1e-12
    ax = cylinder(model6, q, color_by="phase")
    gids = {c.get_gid() for c in ax.collections}
    assert {"cylinder", "cylinder-edges", "cylinder-folds", "cylinder-linear-folds"} <= gids
    assert "cylinder-folds" not in {
        c.get_gid() for c in cylinder(model6, q, color_by=None).collections
    }
    with pytest.raises(ValueError, match="color_by"):
        cylinder(model6, q, color_by="energy")


def test_gallery_follows_the_hierarchy(model4, states_ds) -> None:
    fig = gallery(states_ds, model4)
    titles = [a.get_title().split("\n")[0] for a in fig.axes if a.name == "3d"]
    assert sorted(titles) == sorted(states_ds["label"].values)
    q = {str(lab): states_ds["q"].values[i] for i, lab in enumerate(states_ds["label"].values)}
    u_z = {str(lab): states_ds["u_z"].values[i] for i, lab in enumerate(states_ds["label"].values)}
    keys = [(open_helical_folds(model4, q[t]), u_z[t]) for t in titles]
    assert keys == sorted(keys)
    assert [k[0] for k in keys] == [0, 0, 1, 2, 2, 3]


# --- animation ---------------------------------------------------------------------------------
@pytest.mark.parametrize(("suffix", "stride"), [(".gif", 1), (".mp4", 4)])
def test_animation_writes_one_frame_per_saved_step(
    model6, trajectory_ds, tmp_path, suffix, stride
) -> None:
    n_saved = trajectory_ds.sizes["time"]
    out = animate(trajectory_ds, model6, tmp_path / f"movie{suffix}", stride=stride, dpi=40)
    n_frames = len(frame_indices(n_saved, stride))
    assert n_frames == -(-n_saved // stride)
    if suffix == ".gif":
        assert iio.imread(out, index=None).shape[0] == n_frames
    else:
        assert imageio_ffmpeg.count_frames_and_secs(str(out))[0] == n_frames


def test_animation_frames_are_full_redraws(model6, path_ds) -> None:
    """Each frame is drawn onto a background drawn once (only what moves is drawn again); its
    pixels are those of drawing the whole figure anew."""
    frames = frame_indices(path_ds.sizes["step"], 3)[:4]
    n = 0
    for image, canvas in _frames(path_ds, model6, frames, "elongation", None, 40.0, (20.0, -60.0)):
        canvas.draw()
        np.testing.assert_array_equal(image, np.asarray(canvas.buffer_rgba())[..., :3])
        n += 1
    assert n == len(frames) == 4


def test_animation_skips_failed_steps(model6, path_ds, tmp_path) -> None:
    """A sweep's failed steps (NaN states), the first one included, get no frame."""
    q = path_ds["q"].values.copy()
    q[[0, 2]] = np.nan
    ds = path_ds.assign(q=(path_ds["q"].dims, q))
    out = animate(ds, model6, tmp_path / "gaps.gif", dpi=40)
    assert iio.imread(out, index=None).shape[0] == path_ds.sizes["step"] - 2
    ds = path_ds.assign(q=(path_ds["q"].dims, np.full_like(q, np.nan)))
    with pytest.raises(ValueError, match="no solved steps"):
        animate(ds, model6, tmp_path / "none.gif")


def test_animation_rejects_bad_input(model6, path_ds, tmp_path) -> None:
    with pytest.raises(ValueError, match=r"\.gif or \.mp4"):
        animate(path_ds, model6, tmp_path / "movie.avi")
    with pytest.raises(ValueError, match="stride"):
        animate(path_ds, model6, tmp_path / "movie.gif", stride=0)


# --- CLI ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def result_files(tmp_path_factory, path_ds, states_ds):
    folder = tmp_path_factory.mktemp("results")
    path_ds.to_netcdf(folder / "path.nc", engine="h5netcdf")
    states_ds.to_netcdf(folder / "states.nc", engine="h5netcdf")
    return folder


@pytest.mark.parametrize(
    ("source", "kind", "out"),
    [
        ("path", "response", "response.png"),
        ("path", "development", "development.png"),
        ("path", "tube", "tube.png"),
        ("path", "tube", "tube.pvd"),
        ("path", "energy", "energy.pdf"),
        ("path", "phases", "phases.png"),
        ("states", "gallery", "gallery.png"),
        ("path", "animation", "ramp.gif"),
    ],
)
def test_cli_plot(result_files, tmp_path, source, kind, out) -> None:
    args = [
        "plot",
        str(result_files / f"{source}.nc"),
        "--kind",
        kind,
        "--out",
        str(tmp_path / out),
    ]
    result = CliRunner().invoke(app, [*args, "--dpi", "40", "--stride", "3"])
    assert result.exit_code == 0, result.output
    assert "wrote" in result.output
    data = (tmp_path / out).read_bytes()
    if out.endswith(".png"):
        assert data.startswith(PNG_SIGNATURE)
    if out.endswith(".pvd"):
        assert len(list((tmp_path / "tube").glob("*.vtu"))) == 4  # steps 0, 3, 6, 9


def test_cli_plot_errors(result_files, tmp_path, capsys) -> None:
    states = str(result_files / "states.nc")
    with pytest.raises(SystemExit) as err:
        main(["plot", states, "--kind", "response", "--out", str(tmp_path / "r.png")])
    assert err.value.code == EXIT_BIPLAN_ERROR
    assert "one of development, tube, gallery for a state catalogue" in capsys.readouterr().err
    with pytest.raises(SystemExit) as err:
        main(["plot", states, "--kind", "animation", "--out", str(tmp_path / "a.png")])
    assert err.value.code == EXIT_BIPLAN_ERROR
    assert "--out" in (msg := capsys.readouterr().err) and "ending in .gif, .mp4" in msg
    result = CliRunner().invoke(
        app, ["plot", states, "--kind", "tube", "--step", "99", "--out", str(tmp_path / "t.png")]
    )
    assert result.exit_code == 2
