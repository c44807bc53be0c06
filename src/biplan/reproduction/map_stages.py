"""The map stages of ``biplan reproduce`` (:mod:`biplan.reproduction.stages`): Fig. 3 A.1's
force-ramp design map and the first-instability map over (b, C), and Fig. 3 A.3's stability
map at b = 0.58, each through the sweep API (:func:`run_map_python`) into ``<stage>/map.nc``
and its figure; and the semi-bistable design under the run's TPC sign reading
(:func:`semi_design`), which every stage of the semi-bistable tube starts from.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from biplan.reproduction import figures
from biplan.reproduction.facts import PAPER_B
from biplan.reproduction.settings import INSTABILITY_UP_TO, Settings

if TYPE_CHECKING:
    from biplan.reproduction.stages import StageContext

__all__ = [
    "run_map_python",
    "semi_design",
    "stage_design_map",
    "stage_instability_map",
    "stage_stability_map",
]


def semi_design(ctx: StageContext) -> Any:
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


def stage_design_map(ctx: StageContext) -> None:
    from biplan.analysis.maps.design_map import ForceRamp, ResponseEvaluator

    ev = ResponseEvaluator(ForceRamp(n_steps=ctx.settings.ramp_steps))
    ds = run_map_python(semi_design(ctx), _design_grid(ctx.settings), ev, ctx.out / "design_map", 4)
    figures.design_map_figure(ds, ctx.out / "fig3_A1_design_maps.png")
    ctx.results.design_map = ds


def stage_instability_map(ctx: StageContext) -> None:
    from biplan.analysis.maps.instability_map import InstabilityEvaluator

    ev = InstabilityEvaluator(up_to=INSTABILITY_UP_TO)
    grid = _design_grid(ctx.settings)
    ds = run_map_python(semi_design(ctx), grid, ev, ctx.out / "instability_map", 4)
    figures.instability_figure(ds, ctx.out / "fig3_A1_first_instability.png")
    ctx.results.instability_map = ds


def stage_stability_map(ctx: StageContext) -> None:
    from biplan.analysis.maps.stability_map import StabilityEvaluator
    from biplan.analysis.maps.sweeps import Grid, apply_values

    s = ctx.settings
    tube = apply_values(semi_design(ctx), {"b": PAPER_B})
    grid = Grid.of(C=_logspace(s.stability_c), displacement=_linspace(s.stability_u))
    ds = run_map_python(tube, grid, StabilityEvaluator(), ctx.out / "stability_map", grid.shape[1])
    figures.stability_figure(ds, ctx.out / "fig3_A3_stability_map.png")
    ctx.results.stability_map = ds
