"""First-instability map: where a force-controlled test first loses stability, per design.

At every grid point (a design: b, C or any sweepable quantity, :mod:`biplan.analysis.maps.grid`)
:func:`~biplan.analysis.response.loadcontrol.first_snap` follows the stable branch from the relaxed
reference under a rising end force, up to :attr:`InstabilityEvaluator.up_to`, and locates the
first loss of stability (the phase-1 peak): its force F* [N], the load-point displacement U*
[mm] there and what was lost (a limit point of the force or a bifurcation). A design that
stays stable up to ``up_to`` has F* = NaN and ``found`` = 0; a design whose response could
not be followed has ``status`` 1 (a failed point, counted by the sweep).

The points are independent serial solves (one compiled layout for a grid of one design
family): the map costs one first-snap search per point, about 0.3–1 s warm for six modules.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan._errors import BiplanError, check_range
from biplan.analysis.response.loadcontrol import first_snap
from biplan.model.assembly import Model
from biplan.model.tube import Tube
from biplan.solvers.path_results import Critical

__all__ = ["CRITICAL", "InstabilityEvaluator"]

#: Codes of the ``critical`` variable (what was lost at F*).
CRITICAL = {Critical.LIMIT_POINT: 1, Critical.BIFURCATION: 2, Critical.LOSS_OF_STABILITY: 3}


@dataclass(frozen=True)
class InstabilityEvaluator:
    """First loss of stability under force control at every grid point (module docstring).

    Parameters
    ----------
    up_to : float
        Highest end force [N] of the search, > 0.
    """

    up_to: float = 3.0
    name: str = "first_instability"
    load_axes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "up_to", check_range("up_to", self.up_to, low=0.0))

    def variables(self, design: Tube) -> dict[str, tuple[tuple[str, ...], str, str]]:
        codes = ", ".join(f"{v} {k}" for k, v in CRITICAL.items())
        return {
            "force": ((), "N", "end force F* at the first loss of stability (NaN: none)"),
            "displacement": ((), "mm", "load-point displacement U* there"),
            "found": ((), "1", f"1 if stability was lost below {self.up_to:g} N, else 0"),
            "critical": ((), "1", f"what was lost: 0 nothing, {codes}"),
            "status": ((), "1", "0 ok; 1 the response could not be followed"),
        }

    def dim_sizes(self, design: Tube) -> dict[str, int]:
        return {}

    def describe(self) -> dict[str, Any]:
        return {
            "solver": "force-controlled response (load_response), to the first located snap",
            "up_to_N": self.up_to,
        }

    def finish(self, ds: Any) -> Any:
        return ds

    def evaluate(
        self, tubes: Sequence[Tube], loads: Sequence[Mapping[str, float]], batch: int
    ) -> dict[str, np.ndarray]:
        """One first-snap search per design (``loads`` and ``batch`` are not used)."""
        n = len(tubes)
        out = {
            "force": np.full(n, np.nan),
            "displacement": np.full(n, np.nan),
            "found": np.zeros(n, dtype=np.int64),
            "critical": np.zeros(n, dtype=np.int64),
            "status": np.zeros(n, dtype=np.int64),
        }
        for i, tube in enumerate(tubes):
            try:
                snap = first_snap(Model(tube), self.up_to)
            except BiplanError:
                out["status"][i] = 1
                continue
            if snap is None:
                continue
            out["force"][i] = snap.force
            out["displacement"][i] = snap.displacement_before
            out["found"][i] = 1
            out["critical"][i] = CRITICAL.get(snap.critical, 3)
        return out
