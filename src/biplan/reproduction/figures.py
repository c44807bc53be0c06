"""The figure files of ``biplan reproduce``: one function per PNG the stages write.

Each draws with :mod:`biplan.plot` into a new figure and writes it at :data:`DPI`
(:mod:`biplan.plot.files`); the Fig. 4 figures are those of ``biplan states``, copied by the
states stage.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from biplan.reproduction.facts import RAMP_FORCE

__all__ = [
    "DPI",
    "FIGURE_FILES",
    "calibration_figure",
    "design_map_figure",
    "instability_figure",
    "snapshot_figure",
    "stability_figure",
    "validation_figure",
]

#: Resolution of the reproduction's PNGs [dots per inch].
DPI = 200

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


def snapshot_figure(model: Any, path: Any, snaps: Mapping[str, int], file: Path) -> None:
    """Fig. 3 B: the snapshot states of a displacement sweep, planar developments above and
    3D tubes below, on one elongation colour scale.

    Parameters
    ----------
    model : Model
    path : QuasiStaticPath
        The sweep.
    snaps : mapping
        Panel name → step index (:func:`biplan.reproduction.facts.snapshot_steps`).
    file : Path
    """
    from biplan.plot import cylinder, development, elongation_norm
    from biplan.plot.files import pyplot, save
    from biplan.plot.response import FONT_SIZE

    qs = [path.solutions[k].q for k in snaps.values()]
    fig = pyplot().figure(figsize=(7.0, 6.0), layout="constrained")
    norm = elongation_norm(model, qs)
    for i, (key, k) in enumerate(snaps.items()):
        title = f"{key}: U = {path.displacement[k]:.2f} mm, F = {path.force[k]:.2f} N"
        ax = fig.add_subplot(2, 3, i + 1)
        development(model, qs[i], ax=ax, norm=norm, colorbar=False)
        ax.set_title(title, fontsize=FONT_SIZE)
        ax3 = fig.add_subplot(2, 3, i + 4, projection="3d")
        cylinder(model, qs[i], ax=ax3, norm=norm)
    save(fig, file, dpi=DPI)


def validation_figure(comparison: Any, file: Path) -> None:
    """Fig. 3 A.2: the predicted force–displacement curve on the band
    (:class:`~biplan.calibration.validation.BandComparison`)."""
    from biplan.plot import validation_band
    from biplan.plot.files import figure_file
    from biplan.plot.response import COLUMN_FIGSIZE

    with figure_file(file, dpi=DPI, figsize=COLUMN_FIGSIZE) as (_, ax):
        validation_band(comparison, ax=ax)


def design_map_figure(ds: Any, file: Path) -> None:
    """Fig. 3 A.1: u_z/l₀ and u_r/l₀ of the force-ramp design map over (b, C), side by side."""
    from biplan.plot.files import figure_file
    from biplan.plot.maps import design_map

    with figure_file(file, dpi=DPI, ncols=2, figsize=(7.0, 2.8)) as (_, axes):
        design_map(ds, "u_z", ax=axes[0])
        design_map(ds, "u_r", ax=axes[1])


def instability_figure(ds: Any, file: Path) -> None:
    """The first-instability force F* [N] over (b, C), the paper's 1.6 N ramp highlighted."""
    from biplan.plot.files import figure_file
    from biplan.plot.maps import design_map
    from biplan.plot.response import COLUMN_FIGSIZE

    with figure_file(file, dpi=DPI, figsize=COLUMN_FIGSIZE) as (_, ax):
        design_map(ds, "force", ax=ax, highlight=RAMP_FORCE)


def stability_figure(ds: Any, file: Path) -> None:
    """Fig. 3 A.3: mono/bi/multistable regions over (U/l₀, C)."""
    from biplan.plot.files import figure_file
    from biplan.plot.maps import stability_map
    from biplan.plot.response import COLUMN_FIGSIZE

    with figure_file(file, dpi=DPI, figsize=COLUMN_FIGSIZE) as (_, ax):
        stability_map(ds, ax=ax)


def calibration_figure(runs: Sequence[tuple[str, Any]], file: Path) -> None:
    """SI S10: the trilinear (A) and linear (B) CFT calibrations side by side.

    Parameters
    ----------
    runs : sequence of (str, Calibration)
        ``trilinear`` and ``linear`` with their calibration, in that order.
    file : Path
    """
    from biplan.plot import calibration_band
    from biplan.plot.files import figure_file

    with figure_file(file, dpi=DPI, ncols=2, figsize=(7.0, 2.8)) as (_, axes):
        for ax, (kind, result) in zip(axes, runs, strict=True):
            calibration_band(result, ax=ax)
            ax.set_title(f"({'A' if kind == 'trilinear' else 'B'}) {kind} CFT", fontsize=8)
