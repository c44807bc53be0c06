"""Small-vibration modes about a stable equilibrium.

With N the null-space basis of the active constraints (as for stability, MODEL §12), the
reduced stiffness K_r = Nᵀ K N and mass M_r = Nᵀ M N give the natural angular frequencies
ω_i² = eig(K_r, M_r) [rad/s]. They set the time scale of snap-through (a period of order
0.1–1 ms against the paper's 2 s ramp) and the mass-proportional Rayleigh coefficient
α_R = 2 ζ ω_1 that gives the first mode a damping ratio ζ.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from biplan._errors import ConfigError
from biplan.analysis.stability import reduced_hessian
from biplan.model.assembly import Load, Model
from biplan.solvers.dynamics import mass_matrix_at
from biplan.solvers.newton import Solution, solve_equilibrium

__all__ = [
    "PROBE_HALVINGS",
    "Modes",
    "check_damping_ratio",
    "natural_modes",
    "rayleigh_at",
    "rayleigh_for_damping_ratio",
]


@dataclass(frozen=True)
class Modes:
    """Natural modes of a stable equilibrium.

    Attributes
    ----------
    angular_frequency : ndarray
        ω_i [rad/s], ascending.
    shapes : ndarray (n_q, n_modes)
        Mode shapes in q, M-orthonormal.
    """

    angular_frequency: np.ndarray
    shapes: np.ndarray

    @property
    def frequency(self) -> np.ndarray:
        """f_i = ω_i / 2π [Hz]."""
        return self.angular_frequency / (2.0 * np.pi)

    @property
    def period(self) -> np.ndarray:
        """T_i = 2π / ω_i [s]."""
        return 2.0 * np.pi / self.angular_frequency


def natural_modes(model: Model, solution: Solution) -> Modes:
    """Natural modes about a converged, stable equilibrium.

    Raises
    ------
    ConfigError
        If the solution is not converged, or not stable (a negative ω² has no frequency).
    """
    if not solution.converged:
        raise ConfigError("solution", solution.status.name, "a converged Solution")
    k_r, basis = reduced_hessian(model, solution)
    if basis.shape[1] == 0:
        return Modes(np.zeros(0), np.zeros((model.n_coordinates, 0)))
    m_r = basis.T @ mass_matrix_at(model, solution.q) @ basis
    w2, vec = scipy.linalg.eigh(k_r, 0.5 * (m_r + m_r.T))
    if w2[0] <= 0:
        raise ConfigError("solution", f"λ_min = {w2[0]:.3g}", "a stable equilibrium (ω² > 0)")
    return Modes(np.sqrt(w2), basis @ vec)


def check_damping_ratio(ratio: float) -> None:
    """Refuse a damping ratio ζ outside (0, 1) (:class:`ConfigError` naming ``damping_ratio``)."""
    if not 0 < ratio < 1:
        raise ConfigError("damping_ratio", ratio, "a damping ratio in (0, 1)")


def rayleigh_for_damping_ratio(modes: Modes, ratio: float) -> float:
    """α_R [1/s] of D = α_R M that damps the first mode with ratio ζ (ζ_1 = α_R / 2ω_1)."""
    check_damping_ratio(ratio)
    if modes.angular_frequency.size == 0:
        raise ConfigError("modes", "none (every contact locked)", "at least one free mode")
    return 2.0 * ratio * float(modes.angular_frequency[0])


#: Halvings of a probe load that :func:`rayleigh_at` tries when the probe lies past the start
#: branch's limit point (no converged, stable state there from the start).
PROBE_HALVINGS = 4


def rayleigh_at(model: Model, start: Solution, probe: Load, damping_ratio: float) -> float:
    """α_R [1/s] that gives the first natural mode of the equilibrium under ``probe`` the
    damping ratio ζ.

    Every dynamic workflow (a force-controlled test's ramp after a snap, ``biplan respond
    --dynamic``, the demo's ramp) probes at half its largest load: on the start's branch,
    below the limit point, where a mode is free (in the unloaded tube every contact touches
    and locks every mode). Where half the largest load is past the start branch's first limit
    point (a tube that snaps early, e.g. the fully bistable one at 0.49 N under a 1.6 N
    ramp), the Newton solve from the start finds no stable state there; the probe is then
    halved again, at most :data:`PROBE_HALVINGS` times, and the first load that gives a
    converged, stable state with a free mode is used.

    Parameters
    ----------
    model : Model
    start : Solution
        Start of the Newton solve of the probe state.
    probe : Load
        The load of the probe state.
    damping_ratio : float
        ζ in (0, 1).

    Raises
    ------
    ConfigError
        If ζ is outside (0, 1), or no probe load (``probe`` and its halvings) gives a
        converged, stable state with a free mode; the message names the loads tried.
    """
    check_damping_ratio(damping_ratio)
    tried: list[str] = []
    for k in range(PROBE_HALVINGS + 1):
        scale = 0.5**k
        load = Load(probe.force * scale, probe.displacement * scale, probe.displacement_control)
        state = solve_equilibrium(model, None, start, load)
        try:
            return rayleigh_for_damping_ratio(natural_modes(model, state), damping_ratio)
        except ConfigError as err:
            if load.displacement_control:
                tried.append(f"U = {float(load.displacement):.4g} mm: {err.value}")
            else:
                tried.append(f"F = {float(load.force):.4g} N: {err.value}")
    raise ConfigError(
        "probe load of the damping ratio",
        "; ".join(tried),
        "a load with a converged, stable state and a free mode on the start's branch (where "
        "none has one, damping ratio 0: undamped)",
    )
