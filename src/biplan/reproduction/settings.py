"""How finely ``biplan reproduce`` runs: the grids, steps and limits of ``--quick`` and of the
paper's resolution, side by side.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

__all__ = ["INSTABILITY_UP_TO", "SWEEP_END", "Resolution", "Settings"]

#: End of the semi-bistable displacement sweep [mm]: past the last fold snap (≈ 8.7 mm), so
#: that phase 2 is resolved (the synthetic MFT specimens also reach ≈ 11 mm).
SWEEP_END = 11.0
#: Highest end force [N] of the first-instability map's search (above the Table design's
#: F* = 2.13 N, so the map shows how far each design is from the paper's 1.6 N ramp).
INSTABILITY_UP_TO = 3.0


class Resolution(enum.StrEnum):
    """A run's resolution: ``--quick`` or the paper's."""

    QUICK = "quick"
    FULL = "full"

    @property
    def description(self) -> str:
        """The resolution in words (for the report)."""
        if self is Resolution.QUICK:
            return "quick (coarse grids, short runs)"
        return "full (the paper's resolution)"


#: Settings of each resolution: field of :class:`Settings` → (quick, full).
_BY_RESOLUTION: dict[str, tuple[Any, Any]] = {
    "sweep_steps": (44, 150),
    "design_b": ((0.30, 0.95, 3), (0.30, 0.95, 27)),
    "design_c": ((0.05, 3.0, 3), (0.05, 3.0, 25)),
    "ramp_steps": (16, 32),
    "stability_c": ((0.05, 3.0, 3), (0.05, 3.0, 20)),
    "stability_u": ((0.01, 0.1, 3), (0.005, 0.2, 20)),
    "bootstrap": (20, 200),
    "movie_frames": (12, 100),
    "time_step": (0.04, 0.01),
    "states_timeout": (600.0, 3600.0),
}


@dataclass(frozen=True)
class Settings:
    """Resolution of a run (:meth:`of`).

    Grids are (start, stop, points): b and the displacement evenly spaced, C log-spaced
    (``design_c``, ``stability_c``: it spans almost two decades).

    Attributes
    ----------
    sweep_steps : int
        Steps of the semi-bistable displacement sweep to :data:`SWEEP_END`.
    design_b, design_c : tuple
        b and C of the design and first-instability maps.
    ramp_steps : int
        Steps of each design's force ramp on the design map.
    stability_c, stability_u : tuple
        C and the end displacement U/l₀ of the stability map.
    bootstrap : int
        Bootstrap resamples of each CFT calibration.
    movie_frames : int
        Frames of Movie S1 (about).
    time_step : float
        Time step of the force ramp [s].
    states_timeout : float
        Time limit of the state enumeration [s].
    tpc_sign : str
        ``ModelOptions.tpc_sign`` of every design (MODEL §7, V1), a value of
        :class:`biplan.options.TpcSign` (not imported here: the options module imports JAX).
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
    tpc_sign: str = "geometric"

    @classmethod
    def of(cls, resolution: Resolution, tpc_sign: str = "geometric") -> Settings:
        """The settings of ``resolution`` (quick: minutes cold; full: the paper's grids)."""
        column = (Resolution.QUICK, Resolution.FULL).index(resolution)
        return cls(**{k: v[column] for k, v in _BY_RESOLUTION.items()}, tpc_sign=tpc_sign)
