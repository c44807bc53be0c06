"""The ramp response of every design of a design map, step by step, and its terminal shape.

A design map (:mod:`biplan.analysis.maps.design_map`) stores per design only the terminal
endpoint values of the force ramp. :func:`ramp_curves` follows the same ramp again, by the
same compiled calls (:func:`~biplan.analysis.maps.design_map.ramp_batches`), and keeps what
the map drops: the force and load-point displacement of every converged load step, and the
terminal configuration. A design whose ramp fails at a snap is finished as the map finishes it
(``after_snap = "dynamic"``: :func:`~biplan.analysis.response.ramp_dynamics.continue_ramp` from its
last
equilibrium), and that part of its curve is the trajectory's (at most
:data:`MAX_DYNAMIC_POINTS` points).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan.analysis.maps.design_map import ForceRamp, ramp_batches
from biplan.analysis.response.ramp_dynamics import continue_ramp
from biplan.model.tube import Tube

__all__ = ["MAX_DYNAMIC_POINTS", "RampCurve", "map_designs", "map_ramp", "ramp_curves"]

#: An xarray.Dataset (a design map).
Dataset = Any

#: Most points kept of the dynamic finish of one design.
MAX_DYNAMIC_POINTS = 200


@dataclass(frozen=True)
class RampCurve:
    """One design's response to the force ramp.

    Attributes
    ----------
    force, displacement : ndarray, shape (k,)
        End force F [N] and load-point displacement U [mm] of the converged quasi-static steps.
    dynamic_force, dynamic_displacement : ndarray, shape (m,)
        The same along the dynamic finish after a snap (empty when there was none).
    q : ndarray, shape (n_q,)
        Terminal configuration (the last converged state when the ramp was not finished).
    dynamic : int
        0 quasi-static to the end, 1 finished by generalized-α, 2 by backward Euler.
    completed : bool
        Whether the ramp reached its terminal force.
    """

    force: np.ndarray
    displacement: np.ndarray
    dynamic_force: np.ndarray
    dynamic_displacement: np.ndarray
    q: np.ndarray
    dynamic: int
    completed: bool


def _thin(n: int) -> np.ndarray:
    stride = max(1, int(np.ceil(n / MAX_DYNAMIC_POINTS)))
    index = np.arange(0, n, stride)
    return index if n == 0 or index[-1] == n - 1 else np.r_[index, n - 1]


def ramp_curves(tubes: Sequence[Tube], ramp: ForceRamp, batch: int = 16) -> list[RampCurve]:
    """The ramp response of every tube (in order), as the design map computes it.

    Parameters
    ----------
    tubes : sequence of Tube
        The designs.
    ramp : ForceRamp
        The map's ramp (its ``settings`` attribute).
    batch : int
        Designs per batch of :func:`~biplan.analysis.maps.design_map.ramp_batches` (the
        curves do not depend on it).

    Returns
    -------
    list of RampCurve
    """
    curves: list[RampCurve | None] = [None] * len(tubes)
    forces = ramp.forces
    empty = np.zeros(0)
    for part, models, records, z_last in ramp_batches(tubes, ramp, batch):
        ok, _, _, _, zp, _ = records
        for row, i in enumerate(part):
            model, good = models[row], ok[row]
            nq = model.n_coordinates
            curve = RampCurve(forces[good], zp[row][good], empty, empty, z_last[row][:nq], 0,
                              bool(good.all()))  # fmt: skip
            if not good.all() and good[0] and ramp.after_snap == "dynamic":
                k = int(np.flatnonzero(good)[-1])
                traj = continue_ramp(
                    model, z_last[row], float(ramp.times[k]), rate=ramp.rate,
                    duration=ramp.duration, damping_ratio=ramp.damping_ratio,
                    time_step=ramp.time_step, spectral_radius=ramp.spectral_radius,
                )  # fmt: skip
                thin = _thin(len(traj.force))
                curve = RampCurve(
                    curve.force,
                    curve.displacement,
                    np.asarray(traj.force)[thin],
                    np.asarray(traj.displacement)[thin],
                    np.asarray(traj.q)[-1] if traj.completed else curve.q,
                    2 if traj.method.startswith("backward-euler") else 1,
                    bool(traj.completed),
                )
            curves[i] = curve
    return [c for c in curves if c is not None]


def map_ramp(dataset: Dataset) -> ForceRamp:
    """The ramp a design map was computed with (its ``setting_*`` attributes, written by
    :func:`biplan.analysis.maps.sweeps.sweep` from :meth:`ResponseEvaluator.describe`)."""
    a = dataset.attrs
    names = {
        "rate": "rate_N_per_s", "duration": "duration_s", "n_steps": "n_steps",
        "snap_factor": "snap_factor", "atol": "atol", "max_steps": "max_steps",
        "max_backtracks": "max_backtracks", "free_steps": "free_steps",
        "after_snap": "after_snap", "damping_ratio": "damping_ratio",
        "time_step": "time_step_s", "spectral_radius": "spectral_radius",
    }  # fmt: skip
    kwargs: dict[str, Any] = {}
    for field, key in names.items():
        if f"setting_{key}" in a:
            value = a[f"setting_{key}"]
            kwargs[field] = value if isinstance(value, str) else value.item()
    return ForceRamp(**kwargs)


def map_designs(design: Tube, dataset: Dataset) -> list[Tube | None]:
    """The design of every point of a design map over its grid axes (row-major, the order of
    the map's variables), from the tube it was swept from; None where a design is invalid."""
    from biplan._errors import ConfigError
    from biplan.analysis.maps.sweeps import Grid, apply_values

    dims = dataset["u_z"].dims
    grid = Grid.of(**{d: np.asarray(dataset[d].values, dtype=float) for d in dims})
    tubes: list[Tube | None] = []
    for i in range(grid.size):
        try:
            tubes.append(apply_values(design, grid.point(i)))
        except ConfigError:
            tubes.append(None)
    return tubes
