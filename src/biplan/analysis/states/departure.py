"""Departure actuation: the end load at which a stable state loses stability, and where it snaps.

``departure_force(model, z_start, target)`` ramps the end force (or the end displacement) from
zero, in the direction that moves the load point toward the target state, solving the KKT
system at every step from the previous state (the compiled Newton,
:func:`biplan.solvers.iteration.newton`). The departure state is followed while it stays *the
same branch and stable*: the Newton solve converges, the coordinates move continuously (no
jump to another branch), and the reduced Hessian is positive definite (MODEL §12; under
displacement control with the end constraint active). The first step that breaks this is
bracketed and bisected: the critical load is the last load at which the branch is still
stable — under force control a limit point of the force, where the tube snaps.

The snap is then followed by proximal-point descent (bias ½κ‖q − q_prev‖² with κ → 0, as
:func:`biplan.analysis.response.quasistatic.proximal_descent`) at a load just past the critical
one, and the landed state is unloaded to zero load the same way. It lands in the target when
every fold has the target's majority phase.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from biplan._errors import ConfigError, ResultStatus, check_integer, check_range
from biplan.analysis.response.quasistatic import SUB_TOLERANCE, inexact_newton
from biplan.model.assembly import Load, Model
from biplan.solvers import iteration, observation
from biplan.solvers.newton import Newton, Status
from biplan.solvers.observation import Observation

__all__ = ["Departure", "DepartureStatus", "Ramp", "departure_force"]


class DepartureStatus(ResultStatus):
    """Outcome of :func:`departure_force`."""

    FOUND = "found", "the state loses stability on the ramp", True
    NO_LOSS = "no_loss_of_stability", "no loss of stability up to the end of the ramp"
    START_NOT_STABLE = "start_not_stable", "the start state is not stable at zero load"


@dataclass(frozen=True)
class Ramp:
    """Load ramp of :func:`departure_force`.

    Parameters
    ----------
    displacement_control : bool
        Ramp the end displacement U [mm] instead of the end force F [N].
    stop : float
        Largest |F| [N] or |U| [mm] tried, > 0.
    n_steps : int
        Ramp steps up to ``stop``, ≥ 2.
    bisections : int
        Bisections of the bracketing step, ≥ 0.
    jump : float
        A change of any coordinate larger than this [mm or rad] in one step is a jump to
        another branch, > 0.
    overshoot : float
        The snap is followed under the critical load increased by this fraction of it
        (just past a limit point the driving force vanishes), > 0.
    kappa : float
        Initial bias stiffness κ [N/mm] of the snap and unloading relaxations, > 0.
    max_relaxations : int
        Proximal steps of a relaxation at most, ≥ 1.
    newton : Newton
    """

    displacement_control: bool = False
    stop: float = 5.0
    n_steps: int = 50
    bisections: int = 20
    jump: float = 0.05
    overshoot: float = 0.05
    kappa: float = 10.0
    max_relaxations: int = 500
    newton: Newton = field(default_factory=Newton)

    def __post_init__(self) -> None:
        check_range("Ramp.stop", self.stop, low=0.0)
        check_range("Ramp.jump", self.jump, low=0.0)
        check_range("Ramp.overshoot", self.overshoot, low=0.0)
        for name, low in (("n_steps", 2), ("bisections", 0), ("max_relaxations", 1)):
            object.__setattr__(
                self, name, check_integer(f"Ramp.{name}", getattr(self, name), low=low)
            )
        check_range("Ramp.kappa", self.kappa, low=0.0)


@dataclass(frozen=True)
class Departure:
    """Where the departure state loses stability under a load ramp, and where it lands.

    Attributes
    ----------
    status : DepartureStatus
    message : str
    force : float
        End force [N] at the loss of stability (the reaction under displacement control);
        NaN when none was found.
    displacement : float
        Load-point displacement z_p [mm] there (NaN when none).
    displacement_control : bool
    z_critical : ndarray or None
        Last stable state of the branch (packed, under the critical load).
    z_landed : ndarray or None
        State reached after the snap and unloading to zero load.
    landed_bits : tuple of int or None
        Majority phase of every fold of the landed state (helical then circular; 1 open).
    lands_in_target : bool or None
        Whether the landed state has the target's fold phases (None without a target).
    """

    status: DepartureStatus
    message: str
    force: float
    displacement: float
    displacement_control: bool
    z_critical: np.ndarray | None = field(repr=False, default=None)
    z_landed: np.ndarray | None = field(repr=False, default=None)
    landed_bits: tuple[int, ...] | None = None
    lands_in_target: bool | None = None


class _Stepper:
    """Newton solves and stability checks at one load value."""

    def __init__(self, model: Model, ramp: Ramp) -> None:
        self.model, self.ramp = model, ramp
        self.system = model.system()
        self.settings = ramp.newton.loop_settings()
        # the proximal sub-problems are solved inexactly (as in quasistatic.proximal_descent)
        self.sub_settings = inexact_newton(ramp.newton).loop_settings()
        self.d = 1.0 if ramp.displacement_control else 0.0

    def load(self, value: float) -> Load:
        f, u = (0.0, value) if self.d else (value, 0.0)
        return Load(f, u, self.d)

    def solve(
        self, z: np.ndarray, value: float, bias: tuple[np.ndarray, float] | None = None
    ) -> tuple[np.ndarray, bool]:
        """Newton at ``value`` from z (``bias``: (anchor, κ) of a biased problem of
        :meth:`proximal_descent`, solved inexactly: ``SUB_STEPS`` iterations, converged below
        ``SUB_TOLERANCE``)."""
        f, u = (0.0, value) if self.d else (value, 0.0)
        system = self.system.at(f, u, self.d)
        settings = self.settings
        if bias is not None:
            system, settings = system.with_bias(*bias), self.sub_settings
        out = iteration.solve_system(system, z, settings)
        zn, r, status = out[0], out[1], int(out[5])
        converged = status == Status.CONVERGED.value
        if bias is None:
            return zn, converged
        return zn, converged or float(np.max(np.abs(r))) <= SUB_TOLERANCE

    def observe(self, z: np.ndarray, value: float) -> Observation:
        f, u = (0.0, value) if self.d else (value, 0.0)
        return observation.observe(
            self.model, z[None], Load(np.array([f]), np.array([u]), np.array([self.d]))
        )

    def follow(self, z: np.ndarray, value: float) -> tuple[np.ndarray, bool]:
        """Solve at ``value`` from z; ok when converged, continuous and stable."""
        nq = self.model.n_coordinates
        zn, ok = self.solve(z, value)
        if not ok or np.max(np.abs(zn[:nq] - z[:nq])) > self.ramp.jump:
            return zn, False
        return zn, bool(self.observe(zn, value).min_eigenvalue[0] > 1e-8)

    def proximal_descent(self, z: np.ndarray, value: float) -> np.ndarray:
        """Adaptive proximal-point descent at ``value`` (an implicit gradient flow): bias
        ½κ‖q − q_prev‖² anchored at the previous iterate; κ shrinks after a converged step and
        grows after a failed one (a biased problem that is not convex), down to 1e-6 κ_0. The
        biased problems are solved inexactly
        (:func:`biplan.analysis.response.quasistatic.proximal_descent`); the state returned is a
        final unbiased solve to ``atol`` (the last anchor if that fails)."""
        nq = self.model.n_coordinates
        kappa, floor = self.ramp.kappa, 1e-6 * self.ramp.kappa
        for _ in range(self.ramp.max_relaxations):
            zn, ok = self.solve(z, value, (z[:nq].copy(), kappa))
            if not (ok and np.all(np.isfinite(zn))):
                kappa *= 4.0
                continue
            moved = float(np.max(np.abs(zn[:nq] - z[:nq])))
            z = zn
            if moved < 1e-9:  # the anchor is stationary: an unbiased equilibrium
                break
            kappa = max(0.5 * kappa, floor)
        zn, ok = self.solve(z, value)
        return zn if ok else z


def _bits(model: Model, z: np.ndarray) -> tuple[int, ...]:
    obs = observation.observe(model, z[None])
    phase = np.asarray(obs.phase_fraction[0])
    return tuple(int(b) for b in phase[:, 2] > phase[:, 0])


def departure_force(
    model: Model,
    z_start: np.ndarray,
    target: np.ndarray | tuple[int, ...] | None = None,
    ramp: Ramp | None = None,
    *,
    direction: float | None = None,
) -> Departure:
    """End force (or displacement) at which ``z_start`` loses stability, and where it snaps.

    Parameters
    ----------
    model : Model
    z_start : array_like (n_z,)
        A stable equilibrium at zero load (packed state).
    target : array_like (n_z,) or tuple of int, optional
        The target state (packed) or its fold bits (helical then circular, 1 open).
    ramp : Ramp, optional
    direction : float, optional
        Sign of the ramp; default: toward the target's load-point displacement (+1 when no
        target is given).

    Returns
    -------
    Departure
        ``status`` NO_LOSS when the branch stays stable up to ``ramp.stop``.
    """
    ramp = Ramp() if ramp is None else ramp
    z0 = np.asarray(z_start, dtype=float)
    if z0.shape != (model.n_unknowns,):
        raise ConfigError("z_start", z0.shape, f"a packed state ({model.n_unknowns},)")
    target_bits: tuple[int, ...] | None = None
    sign = 1.0 if direction is None else float(np.sign(direction) or 1.0)
    if target is not None:
        t = np.asarray(target, dtype=float)
        if t.shape == (model.n_unknowns,):
            target_bits = _bits(model, t)
            if direction is None:
                dz = model.load_displacement(t[: model.n_coordinates]) - model.load_displacement(
                    z0[: model.n_coordinates]
                )
                sign = 1.0 if dz >= 0 else -1.0
        else:
            target_bits = tuple(int(b) for b in t)
    st = _Stepper(model, ramp)
    u0 = model.load_displacement(z0[: model.n_coordinates]) if ramp.displacement_control else 0.0
    z, ok = st.follow(z0, u0)
    nan = float("nan")
    if not ok:
        return Departure(
            DepartureStatus.START_NOT_STABLE,
            "the start is not a stable equilibrium at zero load",
            nan,
            nan,
            ramp.displacement_control,
        )
    values = u0 + sign * ramp.stop * np.linspace(0.0, 1.0, ramp.n_steps + 1)
    lo, z_lo, hi = values[0], z, None
    for v in values[1:]:
        zn, ok = st.follow(z_lo, v)
        if not ok:
            hi = v
            break
        lo, z_lo = v, zn
    if hi is None:
        return Departure(
            DepartureStatus.NO_LOSS,
            f"stable up to {sign * ramp.stop:g} {'mm' if st.d else 'N'}",
            nan,
            nan,
            ramp.displacement_control,
        )
    for _ in range(ramp.bisections):
        mid = 0.5 * (lo + hi)
        zn, ok = st.follow(z_lo, mid)
        if ok:
            lo, z_lo = mid, zn
        else:
            hi = mid
    obs = st.observe(z_lo, lo)
    force, disp = float(obs.force[0]), float(obs.displacement[0])
    landed = st.proximal_descent(z_lo, hi + ramp.overshoot * (hi - values[0]))
    # release the end: relax under zero end force
    free = _Stepper(
        model, Ramp(kappa=ramp.kappa, max_relaxations=ramp.max_relaxations, newton=ramp.newton)
    )
    landed = free.proximal_descent(landed, 0.0)
    bits = _bits(model, landed)
    return Departure(
        DepartureStatus.FOUND,
        f"loses stability at F = {force:.6g} N, z_p = {disp:.6g} mm",
        force,
        disp,
        ramp.displacement_control,
        z_critical=z_lo,
        z_landed=landed,
        landed_bits=bits,
        lands_in_target=None if target_bits is None else bits == target_bits,
    )
