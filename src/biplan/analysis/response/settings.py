"""What :func:`biplan.analysis.response.run.respond` runs: a quasi-static method with its path
settings, or a dynamic load ramp.

Plain data, light to import (no JAX, no model): ``biplan respond`` offers these choices and
checks its options before it loads a tube. Load-parameter values are in the library's units:
force F [N], displacement U [mm], pressure p [MPa = N/mm²].
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

__all__ = ["Method", "QuasiStatic", "Ramp"]


class Method(enum.StrEnum):
    """How a quasi-static response is traced.

    * ``STABLE`` — what a test under this control does: under force or pressure control the
      stable branches, each snap located and landed
      (:func:`~biplan.analysis.response.loadcontrol.load_response`); under displacement
      control the stable-branch sweep of a testing machine
      (:func:`~biplan.analysis.response.quasistatic.displacement_sweep`).
    * ``ARCLENGTH`` — a numerical method, not a test: the equilibrium path through unstable
      states by pseudo-arclength continuation.
    * ``STEPPING`` — load steps, stopping at the first limit point.
    """

    STABLE = "stable"
    ARCLENGTH = "arclength"
    STEPPING = "stepping"


@dataclass(frozen=True)
class QuasiStatic:
    """A quasi-static response to ``stop``.

    Parameters
    ----------
    stop : float
        End value of the load parameter: F [N], U [mm] or p [MPa]; non-zero.
    method : Method
        How the response is traced.
    step : float
        Initial path step (arclength units); for the stable displacement sweep the
        displacement per step [mm].
    max_step : float
        Largest path step (arclength units; unused by the stable displacement sweep).
    max_steps : int
        Most path steps (the stable displacement sweep: most sweep steps).
    stop_at_snap : bool
        ``Method.STABLE`` under force or pressure control: end at the first snap.
    """

    stop: float
    method: Method = Method.STABLE
    step: float = 0.05
    max_step: float = 0.1
    max_steps: int = 2000
    stop_at_snap: bool = False

    @property
    def sweep_steps(self) -> int:
        """Steps of the stable displacement sweep: ⌈|stop| / step⌉, at least one."""
        return max(math.ceil(abs(self.stop) / self.step), 1)


@dataclass(frozen=True)
class Ramp:
    """A dynamic load ramp Λ(t) = ``rate`` · t for 0 ≤ t ≤ ``duration``, then held at
    Λ = ``rate`` · ``duration`` for ``hold`` seconds.

    Parameters
    ----------
    rate : float
        Λ̇: N/s, mm/s or MPa/s; non-zero.
    duration : float
        Ramp duration [s] > 0.
    hold : float
        Hold after the ramp [s] ≥ 0.
    time_step : float
        Time step h [s] of the backward-Euler scheme, 0 < h ≤ ``duration`` + ``hold``.
    damping_ratio : float
        Rayleigh damping as the damping ratio ζ ≥ 0 of the first natural mode at half the
        final load (0: undamped).
    """

    rate: float
    duration: float = 2.0
    hold: float = 0.0
    time_step: float = 0.01
    damping_ratio: float = 0.05

    @property
    def top(self) -> float:
        """The final load Λ = ``rate`` · ``duration`` (N, mm or MPa)."""
        return self.rate * self.duration

    @property
    def times(self) -> tuple[float, ...]:
        """Breakpoints of Λ(t) [s]: the ramp, and the hold when there is one."""
        d = self.duration
        return (0.0, d) if self.hold == 0 else (0.0, d, d + self.hold)

    @property
    def values(self) -> tuple[float, ...]:
        """Λ at :attr:`times` (N, mm or MPa)."""
        return (0.0, self.top) if self.hold == 0 else (0.0, self.top, self.top)
