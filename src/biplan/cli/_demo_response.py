"""The response part of ``biplan demo``: the paper's force ramp (dynamic) and the
displacement-controlled equilibrium path (quasi-static, pseudo-arclength).

Writes into the output directory:

* ``ramp.nc`` / ``ramp.csv`` — the trajectory under F(t) = 0.8 N/s · t, 0 ≤ t ≤ 2 s
  (generalized-α, h = 10 ms, ρ∞ = 0.8, Rayleigh damping giving the first mode ζ = 5 %);
* ``path.nc`` / ``path.csv`` — the displacement-controlled equilibrium path to 9 mm;
* ``response.png`` — both in the force–displacement plane (unstable stretches dashed,
  located limit points and bifurcations marked);
* ``ramp.gif`` — the animation of the ramp (planar development, 3D tube, F–z_p marker).

and returns the summary lines: the phase-1 peak force, the spinodal span and u_z/l₀, u_r/l₀
at 1.6 N.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from biplan.model.assembly import Model
    from biplan.solvers.path_results import Snap

__all__ = ["run_response"]

#: Frames of the ramp animation (about).
ANIMATION_FRAMES = 50
DAMPING_RATIO = 0.05


def run_response(
    model: Model, out: Path, *, animate: bool = True, peak: Snap | None = None
) -> tuple[list[str], list[Path]]:
    """Run the ramp and the path, write the files; return (summary lines, files).

    ``peak``: the located phase-1 peak (:func:`~biplan.analysis.response.loadcontrol.first_snap`),
    reported instead of the largest force recorded on the path."""
    import biplan
    from biplan.analysis.modes import rayleigh_at
    from biplan.analysis.response.summary import summarize
    from biplan.io.results import dataset, save_csv, save_netcdf

    ref = biplan.relaxed_reference(model, throw=True)
    alpha = rayleigh_at(model, ref, biplan.Load.of_force(0.8), DAMPING_RATIO)
    ramp = biplan.integrate(
        model, biplan.GeneralizedAlpha(time_step=0.01, rayleigh=alpha), ref, t_end=2.0
    )
    path = biplan.trace_path(
        model,
        biplan.ArcLength(initial_step=0.05, max_step=0.1),
        ref,
        biplan.Control.displacement(9.0),
    )
    files = []
    for name, result in (("ramp", ramp), ("path", path)):
        files.append(save_netcdf(dataset(result), out / f"{name}.nc"))
        files.append(save_csv(result, out / f"{name}.csv"))
    files.append(_figure(path, ramp, out / "response.png"))
    if animate:
        from biplan.plot.animation import animate as write_animation

        stride = max(1, len(ramp.time) // ANIMATION_FRAMES)
        files.append(write_animation(dataset(ramp), model, out / "ramp.gif", fps=12, stride=stride))
    s_path = summarize(path, peak=peak)
    s_ramp = summarize(ramp)
    l0 = model.tube.initial_length
    lines = [
        f"ramp 0.8 N/s × 2 s ({ramp.message}); first-mode damping ζ = {DAMPING_RATIO:g} "
        f"(α_R = {alpha:.0f} 1/s)",
        s_path.lines()[0],
        (
            f"spinodal regime (unstable equilibria, displacement control): z_p = "
            f"{s_path.spinodal_start:.3f} … {s_path.spinodal_end:.3f} mm "
            f"(span {s_path.spinodal_span:.3f} mm)"
        ),
        (
            f"at 1.6 N (end of the ramp): u_z/l0 = {ramp.u_z[-1] / l0:.4f}, "
            f"u_r/l0 = {ramp.u_r[-1] / l0:.4f}"
            + ("" if s_ramp.spinodal_span == 0 else " (after a loss of stability)")
        ),
    ]
    return lines, files


def _figure(path: object, ramp: object, file: Path) -> Path:
    from biplan.plot.files import figure_file
    from biplan.plot.response import (
        COLUMN_FIGSIZE,
        SNAP_COLOR,
        force_displacement,
        legend_above,
    )

    with figure_file(file, figsize=COLUMN_FIGSIZE) as (_, ax):
        force_displacement(path, ax=ax, label="equilibrium path (displacement control)")
        ax.plot(
            ramp.displacement,  # type: ignore[attr-defined]
            ramp.force,  # type: ignore[attr-defined]
            "-",
            color=SNAP_COLOR,
            lw=1.0,
            label="force ramp 0.8 N/s (dynamic)",
        )
        ax.set_xlabel(r"load-point displacement $z_p$ [mm]")
        legend_above(ax, fontsize=6, ncol=1)
    return file
