"""``biplan reproduce --out DIR [--quick]``: every panel the paper's models produce, and a report.

Runs, each as an isolated stage (a stage that fails is recorded in the report with its error
and the command goes on):

* ``semi`` — the validated semi-bistable design (SI Table calib) under displacement control
  (stable-branch sweep to 11 mm): ``semi_sweep.csv`` and ``.nc``, ``fig3_B_snapshots.png``
  (phase 1, the transformation, phase 2; planar developments above, 3D tubes below);
* ``validation`` — the sweep against the measured ± 1 SD band (``--measured DIR`` of specimen
  CSVs, default a synthetic band made from the sweep with specimen scatter):
  ``fig3_A2_force_displacement.png``, ``validation.csv``;
* ``design_map`` — Fig. 3 A.1, the force-ramp design map over (b, C): ``design_map/map.nc``,
  ``fig3_A1_design_maps.png``; b spans its admissible range (0.30–0.95 at the Table's R and
  l) and C is log-spaced from 0.05 to 3, so that the map shows where the transformation
  completes within the ramp (low C);
* ``instability_map`` — the first-instability force F* over the same (b, C) grid (force
  control, the first located loss of stability up to 3 N; not a panel of the paper, the
  evidence of its claim A.2 "within the ramp"): ``instability_map/map.nc``,
  ``fig3_A1_first_instability.png``;
* ``stability_map`` — Fig. 3 A.3 at b = 0.58 (C log-spaced from 0.05 to 3):
  ``stability_map/map.nc``, ``fig3_A3_stability_map.png``;
* ``states`` — Fig. 4, the fully bistable four-module tube, by ``biplan states`` in a child
  process with a time limit (a hung enumeration cannot stop the run): ``states/``
  (states.csv, seeds.csv, states.nc, hierarchy.nc, transitions.graphml),
  ``fig4_A_transitions.png``,
  ``fig4_B_endpoint_space.png``, ``fig4_C_distributions.png`` and ``si_distributions.png``;
* ``calibration`` — SI S10, trilinear and linear CFT calibrations on synthetic specimens of the
  table's laws: ``si_cft_calibration.png``, ``cft_calibration.csv``;
* ``movie`` — the Movie S1 analogue, the paper's force ramp (0.8 N/s, 2 s, generalized-α):
  ``ramp.nc``, ``movie_S1.mp4`` (``.gif`` when ffmpeg is unavailable).
* ``explorer`` — the interactive pages of ``biplan explore`` beside the figures:
  ``explorer.html`` (the state catalogue), ``explorer_design_map.html`` and
  ``explorer_ramp.html`` (each written where its stage's result exists).

Then ``REPRODUCTION.md``: every claim of :data:`biplan.reproduction.claims.CLAIMS` with our value,
a computed verdict and the reason, one table per figure, linking the figures.

``--quick`` runs coarse grids and short runs (minutes cold, each kernel compiles once; see
docs/reproduction.md); the default is the paper's resolution, with a progress bar.
"""

from __future__ import annotations

import csv
import shutil
import subprocess
import sys
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape

from biplan._errors import ConfigError
from biplan.cli._checks import output_directory
from biplan.reproduction.claims import (
    RAMP_FORCE,
    CalibrationFacts,
    MovieFacts,
    Results,
    SemiBistableFacts,
    StateFacts,
    ValidationFacts,
    assess,
    report_markdown,
)

__all__ = ["FIGURE_FILES", "Settings", "reproduce", "run_stages", "state_facts"]

DPI = 200
#: End of the semi-bistable displacement sweep [mm]: past the last fold snap (≈ 8.7 mm), so
#: that phase 2 is resolved (the synthetic MFT specimens also reach ≈ 11 mm).
SWEEP_END = 11.0
#: Values of ``--tpc-sign`` (those of :class:`biplan.options.TpcSign`; the options module is
#: not imported here, it imports JAX).
TPC_SIGNS = ("geometric", "as_printed")
#: Highest end force [N] of the first-instability map's search (above the Table design's
#: F* = 2.13 N, so the map shows how far each design is from the paper's 1.6 N ramp).
INSTABILITY_UP_TO = 3.0

#: The figure files written, by figure key of :data:`biplan.reproduction.claims.FIGURES`.
FIGURE_FILES = {
    "fig3": (
        "fig3_A1_design_maps.png",
        "fig3_A1_first_instability.png",
        "fig3_A2_force_displacement.png",
        "fig3_A3_stability_map.png",
        "fig3_B_snapshots.png",
    ),
    "fig4": ("fig4_A_transitions.png", "fig4_B_endpoint_space.png", "fig4_C_distributions.png"),
    "si": ("si_distributions.png", "si_cft_calibration.png", "movie_S1.mp4"),
}


@dataclass(frozen=True)
class Settings:
    """Resolution of a run (``--quick`` or the paper's).

    Grids are (start, stop, points): b and the displacement evenly spaced, C log-spaced
    (``design_c``, ``stability_c``: it spans almost two decades).
    """

    sweep_steps: int
    design_b: tuple[float, float, int]
    design_c: tuple[float, float, int]
    ramp_steps: int
    stability_c: tuple[float, float, int]
    stability_u: tuple[float, float, int]
    bootstrap: int
    movie_frames: int
    time_step: float
    states_timeout: float
    tpc_sign: str = "geometric"  # ModelOptions.tpc_sign of every design (MODEL §7, V1)

    @classmethod
    def quick(cls) -> Settings:
        return cls(
            sweep_steps=44,
            design_b=(0.30, 0.95, 3),
            design_c=(0.05, 3.0, 3),
            ramp_steps=16,
            stability_c=(0.05, 3.0, 3),
            stability_u=(0.01, 0.1, 3),
            bootstrap=20,
            movie_frames=12,
            time_step=0.04,
            states_timeout=600.0,
        )

    @classmethod
    def full(cls) -> Settings:
        return cls(
            sweep_steps=150,
            design_b=(0.30, 0.95, 27),
            design_c=(0.05, 3.0, 25),
            ramp_steps=32,
            stability_c=(0.05, 3.0, 20),
            stability_u=(0.005, 0.2, 20),
            bootstrap=200,
            movie_frames=100,
            time_step=0.01,
            states_timeout=3600.0,
        )


@dataclass
class _Context:
    out: Path
    settings: Settings
    measured: Path | None
    results: Results = field(default_factory=Results)
    semi_path: Any = None
    semi_model: Any = None


def _save(fig: Any, file: Path) -> None:
    import matplotlib.pyplot as plt

    try:
        fig.savefig(file, dpi=DPI)
    finally:
        plt.close(fig)


def _semi(ctx: _Context) -> Any:
    """The semi-bistable design under the run's TPC sign reading."""
    import biplan
    from biplan.options import TpcSign

    options = biplan.ModelOptions(tpc_sign=TpcSign(ctx.settings.tpc_sign))
    return biplan.designs.semi_bistable(options)


def _linspace(spec: tuple[float, float, int]) -> list[float]:
    return [float(x) for x in np.linspace(*spec)]


def _logspace(spec: tuple[float, float, int]) -> list[float]:
    return [float(x) for x in np.geomspace(*spec)]


def _design_grid(s: Settings) -> Any:
    """The (b, C) grid of the design and first-instability maps: b even, C log-spaced."""
    from biplan.analysis.maps.sweeps import Grid

    return Grid.of(b=_linspace(s.design_b), C=_logspace(s.design_c))


# --- stages ----------------------------------------------------------------------------------
def _stage_semi(ctx: _Context) -> None:
    import biplan
    from biplan.analysis.response.quasistatic import displacement_sweep
    from biplan.io.results import save_netcdf, save_sweep_csv, sweep_dataset

    tube = _semi(ctx)
    model = biplan.Model(tube)
    ref = biplan.relaxed_reference(model)
    n = ctx.settings.sweep_steps
    path = displacement_sweep(model, np.linspace(SWEEP_END / n, SWEEP_END, n), start=ref)
    save_sweep_csv(path, ctx.out / "semi_sweep.csv")
    dataset = sweep_dataset(path, model)
    save_netcdf(dataset, ctx.out / "semi_sweep.nc")  # biplan plot semi_sweep.nc --kind phases
    phases = dataset["phase_fraction"].sel(phase="spinodal").values
    facts = SemiBistableFacts(
        b=float(tube.b),
        C=float(tube.C),
        initial_length=float(tube.initial_length),
        displacement=np.asarray(path.displacement, dtype=float),
        force=np.asarray(path.force, dtype=float),
        u_z=np.asarray(path.u_z, dtype=float),
        u_r=np.asarray(path.u_r, dtype=float),
        theta=np.asarray(path.theta, dtype=float),
        stable=np.asarray(path.stable, dtype=bool),
        switched=np.asarray(path.switched, dtype=bool),
        spinodal=np.asarray(phases[:, model.layout.n_modules :], dtype=float),
    )
    ctx.semi_path, ctx.semi_model = path, model
    ctx.results.semi = facts
    _snapshot_figure(model, path, facts, ctx.out / "fig3_B_snapshots.png")


def _snapshot_figure(model: Any, path: Any, facts: SemiBistableFacts, file: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from biplan.plot import cylinder, development, elongation_norm
    from biplan.plot.response import FONT_SIZE

    snaps = facts.snapshots()
    qs = [path.solutions[k].q for k in snaps.values()]
    fig = plt.figure(figsize=(7.0, 6.0), layout="constrained")
    norm = elongation_norm(model, qs)
    for i, (key, k) in enumerate(snaps.items()):
        title = f"{key}: U = {path.displacement[k]:.2f} mm, F = {path.force[k]:.2f} N"
        ax = fig.add_subplot(2, 3, i + 1)
        development(model, qs[i], ax=ax, norm=norm, colorbar=False)
        ax.set_title(title, fontsize=FONT_SIZE)
        ax3 = fig.add_subplot(2, 3, i + 4, projection="3d")
        cylinder(model, qs[i], ax=ax3, norm=norm)
    _save(fig, file)


def _synthetic_band(path: Any, seed: int = 11) -> Any:
    """A five-specimen band from the model's own sweep with specimen scatter (as in
    examples/data/make_synthetic.py): phase 1 (up to the first snap,
    :func:`~biplan.analysis.response.summary.phase_one_end`), phase 2 after the last snap."""
    from biplan.analysis.response.summary import phase_one_end
    from biplan.calibration.specimens import Segment, Specimen, band_statistics
    from biplan.calibration.synthetic import sample_segment

    ok = np.isfinite(path.force) & path.stable
    first = phase_one_end(path.force, path.stable, path.switched)
    snaps = np.flatnonzero(path.switched)
    u, f = np.asarray(path.displacement), np.asarray(path.force)
    parts = [("1", u[:first], f[:first])]
    if snaps.size:
        tail = np.arange(snaps[-1], u.size)
        tail = tail[ok[tail]]
        parts.append(("2", u[tail], f[tail]))
    rng = np.random.default_rng(seed)
    specimens = []
    for i in range(5):
        s_f, s_u = float(np.exp(0.05 * rng.normal())), float(np.exp(0.03 * rng.normal()))
        segs = []
        for label, uu, ff in parts:
            if uu.size < 3:
                continue
            x = sample_segment(rng, float(uu[0]), float(uu[-1]), int(rng.integers(40, 61)), 0.3)
            y = s_f * np.interp(x, uu, ff) + 0.02 * rng.normal(size=x.size)
            segs.append(Segment(s_u * x, y, label))
        specimens.append(Specimen(f"synthetic_{i + 1:02d}", tuple(segs)))
    return band_statistics(specimens)


def _stage_validation(ctx: _Context) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from biplan.calibration.files import SpecimenFormat, read_specimens
    from biplan.calibration.specimens import band_statistics
    from biplan.calibration.validation import compare_to_band
    from biplan.cli.validate import write_comparison
    from biplan.plot import validation_band
    from biplan.plot.response import COLUMN_FIGSIZE

    path = ctx.semi_path
    if path is None:
        raise RuntimeError("needs the semi-bistable sweep (stage semi failed)")
    if ctx.measured is not None:
        radius = ctx.semi_model.tube.development.radius
        band = band_statistics(read_specimens(ctx.measured, SpecimenFormat(), radius=radius))
        source = f"measured specimens in {ctx.measured}"
    else:
        band = _synthetic_band(path)
        source = "synthetic band from this model's sweep, 5 specimens"
    comparison = compare_to_band(band, path.displacement, path.force)
    write_comparison(comparison, ctx.out / "validation.csv")
    fig, ax = plt.subplots(figsize=COLUMN_FIGSIZE, layout="constrained")
    validation_band(comparison, ax=ax)
    _save(fig, ctx.out / "fig3_A2_force_displacement.png")
    ctx.results.validation = ValidationFacts(
        rms=comparison.rms,
        fraction_outside=comparison.fraction_outside,
        n_compared=comparison.n_compared,
        synthetic=ctx.measured is None,
        source=source,
    )


def run_map_python(design: Any, grid: Any, evaluator: Any, out: Path, chunk_size: int) -> Any:
    """Run one map through the sweep API and store it as ``out/map.nc`` (the one place that
    calls the maps machinery)."""
    from biplan.analysis.maps.sweeps import sweep
    from biplan.io.config import dump_config
    from biplan.io.sweepstore import save_map

    ds = sweep(design, grid, evaluator, chunk_size=chunk_size)
    ds.attrs["config"] = dump_config(design)
    out.mkdir(parents=True, exist_ok=True)
    save_map(ds, out / "map.nc")
    return ds


def _stage_design_map(ctx: _Context) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from biplan.analysis.maps.design_map import ForceRamp, ResponseEvaluator
    from biplan.plot.maps import design_map

    ev = ResponseEvaluator(ForceRamp(n_steps=ctx.settings.ramp_steps))
    ds = run_map_python(_semi(ctx), _design_grid(ctx.settings), ev, ctx.out / "design_map", 4)
    fig, axes = plt.subplots(1, 2, figsize=(7.0, 2.8), layout="constrained")
    design_map(ds, "u_z", ax=axes[0])
    design_map(ds, "u_r", ax=axes[1])
    _save(fig, ctx.out / "fig3_A1_design_maps.png")
    ctx.results.design_map = ds


def _stage_instability_map(ctx: _Context) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from biplan.analysis.maps.instability_map import InstabilityEvaluator
    from biplan.plot.maps import design_map
    from biplan.plot.response import COLUMN_FIGSIZE

    ev = InstabilityEvaluator(up_to=INSTABILITY_UP_TO)
    grid = _design_grid(ctx.settings)
    ds = run_map_python(_semi(ctx), grid, ev, ctx.out / "instability_map", 4)
    fig, ax = plt.subplots(figsize=COLUMN_FIGSIZE, layout="constrained")
    design_map(ds, "force", ax=ax, highlight=RAMP_FORCE)
    _save(fig, ctx.out / "fig3_A1_first_instability.png")
    ctx.results.instability_map = ds


def _stage_stability_map(ctx: _Context) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from biplan.analysis.maps.stability_map import StabilityEvaluator
    from biplan.analysis.maps.sweeps import Grid, apply_values
    from biplan.plot.maps import stability_map
    from biplan.plot.response import COLUMN_FIGSIZE
    from biplan.reproduction.claims import PAPER_B

    s = ctx.settings
    tube = apply_values(_semi(ctx), {"b": PAPER_B})
    grid = Grid.of(C=_logspace(s.stability_c), displacement=_linspace(s.stability_u))
    ds = run_map_python(tube, grid, StabilityEvaluator(), ctx.out / "stability_map", grid.shape[1])
    fig, ax = plt.subplots(figsize=COLUMN_FIGSIZE, layout="constrained")
    stability_map(ds, ax=ax)
    _save(fig, ctx.out / "fig3_A3_stability_map.png")
    ctx.results.stability_map = ds


def _stage_states(ctx: _Context) -> None:
    """Runs ``biplan states`` on the fully bistable design, with the laws inferred from Fig. 4
    (``designs.FullyBistableLaws.INFERRED_FIG4``: they meet the paper's u_z/l0 of 66 and 1B,
    and every statement the provisional laws meet; docs/fidelity.md), in a child process
    (with a time limit: a hung or crashed enumeration cannot stop the other stages), then
    reads its files."""
    import biplan
    from biplan.io.config import dump_config

    folder = ctx.out / "states"
    folder.mkdir(parents=True, exist_ok=True)
    config = folder / "fully_bistable.toml"
    from biplan.options import ChainAttachment, TpcSign

    sign = TpcSign(ctx.settings.tpc_sign)
    options = biplan.ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT, tpc_sign=sign)
    laws = biplan.designs.FullyBistableLaws.INFERRED_FIG4
    tube = biplan.designs.fully_bistable(options, laws=laws)
    config.write_text(dump_config(tube), encoding="utf-8")
    command = [sys.executable, "-m", "biplan", "states", str(config), "--out", str(folder), "-q"]
    try:
        done = subprocess.run(
            command, capture_output=True, text=True, timeout=ctx.settings.states_timeout
        )
    except subprocess.TimeoutExpired:
        raise TimeoutError(
            f"`biplan states` did not finish within {ctx.settings.states_timeout:.0f} s"
        ) from None
    if done.returncode:
        tail = (done.stderr or done.stdout).strip().splitlines()[-3:]
        raise RuntimeError(f"`biplan states` exited with {done.returncode}: {' '.join(tail)}")
    for src, dst in (
        ("transitions.png", "fig4_A_transitions.png"),
        ("endpoint_space.png", "fig4_B_endpoint_space.png"),
        ("distributions.png", "fig4_C_distributions.png"),
        ("distributions.png", "si_distributions.png"),
    ):
        shutil.copyfile(folder / src, ctx.out / dst)
    ctx.results.states = state_facts(folder)


def state_facts(folder: Path) -> StateFacts:
    """The :class:`~biplan.reproduction.claims.StateFacts` of a ``biplan states`` output folder
    (states.csv, seeds.csv, hierarchy.nc, transitions.graphml)."""
    import networkx as nx
    import xarray as xr

    from biplan.analysis.states.transitions import pathway
    from biplan.reproduction.claims import PAPER_PATHWAYS

    with (folder / "states.csv").open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    with (folder / "seeds.csv").open(newline="") as fh:
        n_seeds = len(list(csv.DictReader(fh)))
    with xr.open_dataset(folder / "hierarchy.nc", engine="h5netcdf") as h:
        h = h.load()
    graph = nx.read_graphml(folder / "transitions.graphml")
    names = {r["name"] for r in rows}
    pathways: dict[str, tuple[str, ...] | None] = {}
    for name, (a, b) in PAPER_PATHWAYS.items():
        try:
            found = pathway(graph, a, b) if a in names and b in names else None
        except Exception:  # not connected: no pathway
            found = None
        pathways[name] = tuple(found) if found else None  # type: ignore[arg-type]

    def col(key: str, dtype: Any = float) -> np.ndarray:
        return np.asarray([r[key] for r in rows], dtype=dtype)

    l0 = float(h.attrs["initial_length"])
    return StateFacts(
        n_seeds=n_seeds,
        labels=tuple(r["label"] for r in rows),
        u_z=col("u_z") / l0,
        u_r=col("u_r") / l0,
        Theta=col("Theta"),
        n_open_helical=col("n_open_helical", int),
        n_open_circular=col("n_open_circular", int),
        theta_bins=np.asarray(h["Theta_bin"]),
        theta_counts=np.asarray(h["count_Theta"]),
        u_z_bins=np.asarray(h["u_z_bin"]),
        u_z_counts=np.asarray(h["count_u_z"]),
        u_r_bins=np.asarray(h["u_r_bin"]),
        u_r_counts=np.asarray(h["count_u_r"]),
        branches=np.asarray(h["branch"]),
        branch_theta=np.asarray(h["mean_Theta"]),
        branch_rms_u_z=np.asarray(h["rms_u_z_rel"]),
        branch_rms_u_r=np.asarray(h["rms_u_r_rel"]),
        pathways=pathways,
    )


def _stage_calibration(ctx: _Context) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from biplan.calibration.calibrate import (
        CalibrationOptions,
        calibrate_linear,
        calibrate_trilinear,
    )
    from biplan.calibration.synthetic import Scatter, synthetic_specimens
    from biplan.designs import SEMI_BISTABLE_TABLE as T
    from biplan.laws import LinearLaw, TrilinearLaw
    from biplan.plot import calibration_band

    options = CalibrationOptions(n_bootstrap=ctx.settings.bootstrap)
    noise = Scatter().noise
    tri = TrilinearLaw.from_table(T.circular_stiffness, T.circular_transitions)
    lin = LinearLaw(T.helical_stiffness)
    runs = (
        ("trilinear", calibrate_trilinear(synthetic_specimens(tri, seed=1), None, options),
         dict(zip(("k1", "k2", "k3", "l1", "l2"), (*tri.stiffness, *tri.transitions),
                  strict=True))),
        ("linear", calibrate_linear(synthetic_specimens(lin, seed=2), None, options),
         {"k": T.helical_stiffness}),
    )  # fmt: skip
    facts = []
    fig, axes = plt.subplots(1, 2, figsize=(7.0, 2.8), layout="constrained")
    with (ctx.out / "cft_calibration.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["law", "parameter", "unit", "value", "low", "high", "table"])
        for ax, (kind, result, truth) in zip(axes, runs, strict=True):
            calibration_band(result, ax=ax)
            ax.set_title(f"({'A' if kind == 'trilinear' else 'B'}) {kind} CFT", fontsize=8)
            est = {e.name: (e.value, e.low, e.high) for e in result.estimates}
            for e in result.estimates:
                w.writerow([kind, e.name, e.unit, e.value, e.low, e.high, truth.get(e.name, "")])
            facts.append(CalibrationFacts(kind, est, truth, float(result.fit.rms), noise, True))
    _save(fig, ctx.out / "si_cft_calibration.png")
    ctx.results.calibration = tuple(facts)


def _stage_movie(ctx: _Context) -> None:
    import biplan
    from biplan.analysis.modes import natural_modes, rayleigh_for_damping_ratio
    from biplan.io.results import dataset, save_netcdf
    from biplan.plot.animation import animate

    model = ctx.semi_model or biplan.Model(_semi(ctx))
    ref = biplan.relaxed_reference(model)
    probe = biplan.solve_equilibrium(model, None, ref, biplan.Load.of_force(0.8))
    alpha = rayleigh_for_damping_ratio(natural_modes(model, probe), 0.05)
    scheme = biplan.GeneralizedAlpha(time_step=ctx.settings.time_step, rayleigh=alpha)
    ramp = biplan.integrate(model, scheme, ref, t_end=2.0)
    ds = dataset(ramp)
    save_netcdf(ds, ctx.out / "ramp.nc")
    stride = max(1, len(ramp.time) // ctx.settings.movie_frames)
    try:
        file = animate(ds, model, ctx.out / "movie_S1.mp4", fps=12, stride=stride)
    except Exception:  # no ffmpeg writer: fall back to a GIF
        file = animate(ds, model, ctx.out / "movie_S1.gif", fps=12, stride=stride)
    stable = np.asarray(ramp.stable, dtype=bool)
    ctx.results.movie = MovieFacts(
        file=file.name,
        n_frames=len(range(0, len(ramp.time), stride)),
        lost_stability=bool(not stable.all()),
        final_force=float(np.asarray(ramp.force)[-1]),
    )


#: Explorer pages written beside the figures: file → the result it explores (in --out).
EXPLORER_PAGES = {
    "explorer.html": "states/states.nc",
    "explorer_design_map.html": "design_map/map.nc",
    "explorer_ramp.html": "ramp.nc",
}


def _stage_explorer(ctx: _Context) -> None:
    """The interactive pages of ``biplan explore`` of the catalogue, the design map and the
    ramp, each where its stage wrote its result."""
    from biplan.cli.explore import explorer_page, read_explorable
    from biplan.plot.explorer import write_page

    missing = []
    for name, source in EXPLORER_PAGES.items():
        file = ctx.out / source
        if not file.is_file():
            missing.append(source)
            continue
        write_page(explorer_page(read_explorable(file), file), ctx.out / name)
    if missing:
        raise FileNotFoundError(f"no explorer page of {', '.join(missing)} (its stage failed)")


#: Stages in order: name → (description, function).
STAGES: dict[str, tuple[str, Callable[[_Context], None]]] = {
    "semi": ("semi-bistable sweep and snapshots (Fig. 3 B)", _stage_semi),
    "validation": ("force–displacement vs band (Fig. 3 A.2)", _stage_validation),
    "design_map": ("design map over (b, C) (Fig. 3 A.1)", _stage_design_map),
    "instability_map": ("first-instability force over (b, C)", _stage_instability_map),
    "stability_map": ("stability map at b = 0.58 (Fig. 3 A.3)", _stage_stability_map),
    "states": ("fully bistable states and transitions (Fig. 4)", _stage_states),
    "calibration": ("CFT calibration (SI)", _stage_calibration),
    "movie": ("force ramp and Movie S1", _stage_movie),
    "explorer": ("interactive explorer pages (biplan explore)", _stage_explorer),
}


def run_stages(
    out: Path,
    settings: Settings,
    *,
    measured: Path | None = None,
    only: tuple[str, ...] | None = None,
    advance: Callable[[str], None] | None = None,
) -> tuple[Results, dict[str, float]]:
    """Run the stages (all, or ``only``); returns the results and the seconds per stage.

    A stage that raises leaves its results None and records ``type: message`` in
    ``results.errors`` under the stage name, which is also the name of the
    :class:`~biplan.reproduction.claims.Results` field it fills (the full traceback in
    ``out/errors.log``).
    """
    ctx = _Context(out, settings, measured)
    timings: dict[str, float] = {}
    for name, (description, run) in STAGES.items():
        if only is not None and name not in only:
            continue
        if advance is not None:
            advance(description)
        t0 = time.perf_counter()
        try:
            run(ctx)
        except Exception as err:  # record, report, go on
            ctx.results.errors[name] = f"{type(err).__name__}: {err}"
            with (out / "errors.log").open("a") as fh:
                fh.write(f"--- stage {name}\n{traceback.format_exc()}\n")
        timings[name] = time.perf_counter() - t0
    return ctx.results, timings


def reproduce(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output directory (created if missing).")
    ] = Path("reproduction"),
    quick: Annotated[
        bool, typer.Option("--quick", help="Coarse grids and short runs (minutes).")
    ] = False,
    measured: Annotated[
        Path | None,
        typer.Option(
            "--measured",
            help="Measured semi-bistable MFT specimens (CSV dir) for Fig. 3 A.2; "
            "default: a synthetic band.",
            exists=True,
            file_okay=False,
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
    tpc_sign: Annotated[
        str,
        typer.Option(
            "--tpc-sign",
            help="Sign of a TPC's first field: geometric (MODEL §7) or as_printed (the SI's "
            "Eq. VC_w as printed; docs/fidelity.md).",
        ),
    ] = "geometric",
) -> None:
    """Regenerate the paper's figures (Fig. 3, Fig. 4, the supplement's distributions and
    CFT calibration, Movie S1) and write REPRODUCTION.md with a computed verdict per claim."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    if tpc_sign not in TPC_SIGNS:
        raise ConfigError("--tpc-sign", tpc_sign, f"one of {', '.join(TPC_SIGNS)}")
    output_directory(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise typer.BadParameter(f"cannot create {out}: {err}", param_hint="--out") from None
    (out / "errors.log").unlink(missing_ok=True)
    settings = Settings.quick() if quick else Settings.full()
    settings = replace(settings, tpc_sign=tpc_sign)
    console = Console(stderr=True, highlight=False)
    progress = Progress(
        TextColumn("[bold]{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        disable=quiet or not sys.stderr.isatty(),
    )
    t0 = time.perf_counter()
    with progress:
        task = progress.add_task("reproducing", total=len(STAGES))
        started: list[str] = []

        def advance(description: str) -> None:
            if started:
                progress.advance(task)
            started.append(description)
            progress.update(task, description=description)

        results, timings = run_stages(out, settings, measured=measured, advance=advance)
        progress.advance(task)
    assessments = assess(results)
    figures = {k: [f for f in files if (out / f).exists()] for k, files in FIGURE_FILES.items()}
    if results.movie is not None:
        figures["si"] = [f for f in figures["si"] if not f.startswith("movie")] + [
            results.movie.file
        ]
    command = "biplan reproduce --out DIR" + (" --quick" if quick else "")
    if tpc_sign != "geometric":
        command += f" --tpc-sign {tpc_sign}"
    if measured is not None:
        command += f" --measured {measured}"
    mode = "quick (coarse grids, short runs)" if quick else "full (the paper's resolution)"
    notes = [
        f"Mode: {mode}; total {time.perf_counter() - t0:.0f} s.",
        f"Settings: `{settings}`.",
    ]
    text = report_markdown(
        assessments, figures, command=command, errors=results.errors, timings=timings,
        notes=notes,
    )  # fmt: skip
    (out / "REPRODUCTION.md").write_text(text, encoding="utf-8")
    counts: dict[str, int] = {}
    for a in assessments:
        counts[a.finding.verdict.value] = counts.get(a.finding.verdict.value, 0) + 1
    failed = ", ".join(results.errors) or "none"
    Console(quiet=quiet, highlight=False).print(
        f"{len(assessments)} claims: "
        + ", ".join(f"{n} {v}" for v, n in counts.items())
        + f"; failed stages: {escape(failed)}; wrote {escape(str(out / 'REPRODUCTION.md'))}"
    )
