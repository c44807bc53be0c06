"""The stages of ``biplan reproduce``: every panel the paper's models produce.

Each stage is isolated (:func:`run_stages`: a stage that fails is recorded with its error and
the run goes on) and fills the :class:`~biplan.reproduction.facts.Results` field of its name:

* ``semi`` — the validated semi-bistable design (SI Table calib) under displacement control
  (stable-branch sweep to :data:`~biplan.reproduction.settings.SWEEP_END`): ``semi_sweep.csv``
  and ``.nc``, ``fig3_B_snapshots.png`` (phase 1, the transformation, phase 2; planar
  developments above, 3D tubes below);
* ``validation`` — the sweep against the measured ± 1 SD band (``measured``: a folder of
  specimen CSVs; default a synthetic band made from the sweep with specimen scatter):
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
  ``fig4_A_transitions.png``, ``fig4_B_endpoint_space.png``, ``fig4_C_distributions.png`` and
  ``si_distributions.png``;
* ``calibration`` — SI S10, trilinear and linear CFT calibrations on synthetic specimens of the
  table's laws: ``si_cft_calibration.png``, ``cft_calibration.csv``;
* ``movie`` — the Movie S1 analogue, the paper's force ramp (0.8 N/s, 2 s, generalized-α):
  ``ramp.nc``, ``movie_S1.mp4`` (``.gif`` when ffmpeg is unavailable).

The map stages live in :mod:`biplan.reproduction.map_stages`. The command adds the interactive
pages of ``biplan explore`` as a last stage (:mod:`biplan.cli.reproduce`). Heavy modules (JAX,
matplotlib) are imported by the stages themselves, so that importing this module stays cheap.
"""

from __future__ import annotations

import csv
import shutil
import subprocess
import sys
import time
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from biplan.calibration.validation import write_comparison
from biplan.reproduction import figures
from biplan.reproduction.facts import (
    CalibrationFacts,
    MovieFacts,
    Results,
    SemiBistableFacts,
    ValidationFacts,
    state_facts,
)
from biplan.reproduction.map_stages import (
    run_map_python,
    semi_design,
    stage_design_map,
    stage_instability_map,
    stage_stability_map,
)
from biplan.reproduction.settings import SWEEP_END, Settings
from biplan.reproduction.validation import synthetic_band

__all__ = ["EXPLORER_PAGES", "STAGES", "Stage", "StageContext", "run_map_python", "run_stages"]


@dataclass
class StageContext:
    """What the stages share. Not frozen: each stage adds its results.

    Attributes
    ----------
    out : Path
        The output folder.
    settings : Settings
    measured : Path or None
        Folder of measured specimen CSVs for the validation stage.
    results : Results
        Filled by the stages.
    semi_path, semi_model : QuasiStaticPath, Model
        The semi-bistable sweep and its model (None until the ``semi`` stage ran).
    """

    out: Path
    settings: Settings
    measured: Path | None
    results: Results = field(default_factory=Results)
    semi_path: Any = None
    semi_model: Any = None


@dataclass(frozen=True)
class Stage:
    """One stage: what the progress bar says while it runs, and what it runs."""

    description: str
    run: Callable[[StageContext], None]


# --- stages ----------------------------------------------------------------------------------
def _stage_semi(ctx: StageContext) -> None:
    import biplan
    from biplan.analysis.response.quasistatic import displacement_sweep
    from biplan.io.results import save_netcdf, save_sweep_csv, sweep_dataset

    tube = semi_design(ctx)
    model = biplan.Model(tube)
    ref = biplan.relaxed_reference(model, throw=True)
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
    figures.snapshot_figure(model, path, facts.snapshots(), ctx.out / "fig3_B_snapshots.png")


def _stage_validation(ctx: StageContext) -> None:
    from biplan.calibration.band import band_statistics
    from biplan.calibration.files import SpecimenFormat, read_specimens
    from biplan.calibration.validation import compare_to_band

    path = ctx.semi_path
    if path is None:
        raise RuntimeError("needs the semi-bistable sweep (stage semi failed)")
    if ctx.measured is not None:
        radius = ctx.semi_model.tube.development.radius
        band = band_statistics(read_specimens(ctx.measured, SpecimenFormat(), radius=radius))
        source = f"measured specimens in {ctx.measured}"
    else:
        band = synthetic_band(path)
        source = "synthetic band from this model's sweep, 5 specimens"
    comparison = compare_to_band(band, path.displacement, path.force)
    write_comparison(comparison, ctx.out / "validation.csv")
    figures.validation_figure(comparison, ctx.out / "fig3_A2_force_displacement.png")
    ctx.results.validation = ValidationFacts(
        rms=comparison.rms,
        fraction_outside=comparison.fraction_outside,
        n_compared=comparison.n_compared,
        synthetic=ctx.measured is None,
        source=source,
    )


def _stage_states(ctx: StageContext) -> None:
    """Runs ``biplan states`` on the fully bistable design, with the laws inferred from Fig. 4
    under the run's TPC sign (``designs.FullyBistableLaws.INFERRED_FIG4`` under the geometric
    sign: they meet the paper's u_z/l0 of 66 and 1B, and every statement the provisional laws
    meet; ``INFERRED_FIG4_PRINTED`` under ``as_printed``, where the former lose 66: the best
    set of the printed-sign law search; docs/fidelity.md), in a child process
    (with a time limit: a hung or crashed enumeration cannot stop the other stages), then
    reads its files."""
    import biplan
    from biplan.io.config import dump_config
    from biplan.options import ChainAttachment, TpcSign

    folder = ctx.out / "states"
    folder.mkdir(parents=True, exist_ok=True)
    config = folder / "fully_bistable.toml"
    sign = TpcSign(ctx.settings.tpc_sign)
    options = biplan.ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT, tpc_sign=sign)
    inferred = biplan.designs.FullyBistableLaws
    laws = inferred.INFERRED_FIG4_PRINTED if sign is TpcSign.AS_PRINTED else inferred.INFERRED_FIG4
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


def _stage_calibration(ctx: StageContext) -> None:
    from biplan.calibration.calibrate import (
        CalibrationOptions,
        calibrate_linear,
        calibrate_trilinear,
    )
    from biplan.calibration.synthetic import Scatter, synthetic_specimens
    from biplan.designs import SEMI_BISTABLE_TABLE as T
    from biplan.laws import LinearLaw, TrilinearLaw

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
    with (ctx.out / "cft_calibration.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["law", "parameter", "unit", "value", "low", "high", "table"])
        for kind, result, truth in runs:
            for e in result.estimates:
                w.writerow([kind, e.name, e.unit, e.value, e.low, e.high, truth.get(e.name, "")])
    figures.calibration_figure(
        [(kind, result) for kind, result, _ in runs], ctx.out / "si_cft_calibration.png"
    )
    ctx.results.calibration = tuple(
        CalibrationFacts(
            kind,
            {e.name: (e.value, e.low, e.high) for e in result.estimates},
            truth,
            float(result.fit.rms),
            noise,
            True,
        )
        for kind, result, truth in runs
    )


def _stage_movie(ctx: StageContext) -> None:
    import biplan
    from biplan.analysis.modes import rayleigh_at
    from biplan.io.results import dataset, save_netcdf
    from biplan.plot.animation import animate

    model = ctx.semi_model or biplan.Model(semi_design(ctx))
    ref = biplan.relaxed_reference(model, throw=True)
    alpha = rayleigh_at(model, ref, biplan.Load.of_force(0.8), 0.05)
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


#: Stages in order: name (the :class:`Results` field it fills) → stage.
#: Explorer pages written beside the figures: file → the result it explores (in the output).
EXPLORER_PAGES = {
    "explorer.html": "states/states.nc",
    "explorer_design_map.html": "design_map/map.nc",
    "explorer_ramp.html": "ramp.nc",
}


def _stage_explorer(ctx: StageContext) -> None:
    """The pages of ``biplan explore`` of the catalogue, the design map and the ramp, each
    where its stage wrote its result."""
    from biplan.plot.explorer import write_page
    from biplan.plot.explorer.source import explorer_page, read_explorable

    missing = []
    for name, source in EXPLORER_PAGES.items():
        file = ctx.out / source
        if not file.is_file():
            missing.append(source)
            continue
        write_page(explorer_page(read_explorable(file), file), ctx.out / name)
    if missing:
        raise FileNotFoundError(f"no explorer page of {', '.join(missing)} (its stage failed)")


STAGES: dict[str, Stage] = {
    "semi": Stage("semi-bistable sweep and snapshots (Fig. 3 B)", _stage_semi),
    "validation": Stage("force–displacement vs band (Fig. 3 A.2)", _stage_validation),
    "design_map": Stage("design map over (b, C) (Fig. 3 A.1)", stage_design_map),
    "instability_map": Stage("first-instability force over (b, C)", stage_instability_map),
    "stability_map": Stage("stability map at b = 0.58 (Fig. 3 A.3)", stage_stability_map),
    "states": Stage("fully bistable states and transitions (Fig. 4)", _stage_states),
    "calibration": Stage("CFT calibration (SI)", _stage_calibration),
    "movie": Stage("force ramp and Movie S1", _stage_movie),
    "explorer": Stage("interactive explorer pages (biplan explore)", _stage_explorer),
}


def run_stages(
    out: Path,
    settings: Settings,
    *,
    measured: Path | None = None,
    only: tuple[str, ...] | None = None,
    advance: Callable[[str], None] | None = None,
    stages: Mapping[str, Stage] = STAGES,
) -> tuple[Results, dict[str, float]]:
    """Run the stages (all, or ``only``) in order.

    A stage that raises leaves its results None and records ``type: message`` in
    ``results.errors`` under the stage name, which is also the name of the
    :class:`~biplan.reproduction.facts.Results` field it fills (the full traceback in
    ``out/errors.log``).

    Parameters
    ----------
    out : Path
        The output folder (existing).
    settings : Settings
    measured : Path, optional
        Folder of measured semi-bistable MFT specimen CSVs (default: a synthetic band).
    only : tuple of str, optional
        Names of the stages to run.
    advance : callable, optional
        Called with a stage's description before it runs.
    stages : mapping
        Name → stage, in order; default :data:`STAGES`.

    Returns
    -------
    results : Results
    timings : dict
        Stage name → seconds.
    """
    ctx = StageContext(out, settings, measured)
    timings: dict[str, float] = {}
    for name, stage in stages.items():
        if only is not None and name not in only:
            continue
        if advance is not None:
            advance(stage.description)
        t0 = time.perf_counter()
        try:
            stage.run(ctx)
        except Exception as err:  # record, report, go on
            ctx.results.errors[name] = f"{type(err).__name__}: {err}"
            with (out / "errors.log").open("a") as fh:
                fh.write(f"--- stage {name}\n{traceback.format_exc()}\n")
        timings[name] = time.perf_counter() - t0
    return ctx.results, timings
