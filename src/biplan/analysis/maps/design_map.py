"""Force-controlled design map (paper Fig. 3 A.1; SI "Semi-Bistable MFT Design Maps").

Every grid point is a tube loaded by the monotonic end-force ramp F(t) = Ḟ t, 0 ≤ t ≤ T
(Ḟ = 0.8 N/s, T = 2 s, F_f = 1.6 N by default) from the relaxed reference. The map records
the terminal endpoint displacements u_z/l₀ and u_r/l₀ (l₀ = N l), whether and when stability
was lost, and the solve status.

Reading (documented in docs/maps.md): the ramp is followed **quasi-statically** — Newton load
stepping at the ramp's force levels F_k = Ḟ t_k, each step warm-started from the previous
equilibrium, one compiled call per design on its System (:func:`biplan.solvers.batch.ramp`,
:mod:`biplan.analysis.maps.design_kernels`). The paper's ramp is dynamic, but the tube's
inertia is tiny (μ = 3.6e-10 t/mm², lowest periods ~ms against a 2 s ramp), so between snaps
the dynamic response is the quasi-static one; a generalized-α run would need ~200 adaptive
steps per point and costs ~10× more. Where stability is lost the two readings can differ in the
branch reached after the snap; such points are flagged (``stability_lost``) and the time is
recorded (``time_lost``). Loss of stability at step k: λ_min(H_r) ≤ 0 at the equilibrium, a
failed step (no nearby equilibrium: a limit point was passed) or a snap (the load-point
displacement increment of the step exceeds ``snap_factor`` × the mean increment of the
preceding steps).

:func:`response_point` is the scalar (one design, one Newton solve per step) reference of the
map's ramp; the test-suite checks that both agree.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from biplan._errors import ConfigError, check_integer, check_range
from biplan.analysis.maps.design_kernels import point_solvers, ramp_compiled
from biplan.analysis.response.ramp_dynamics import continue_ramp
from biplan.model.assembly import Load, Model
from biplan.model.tube import Tube
from biplan.solvers.newton import Newton, Status, solve_equilibrium

__all__ = ["ForceRamp", "ResponseEvaluator", "ramp_batches", "response_point"]

#: Readings of a failed load step (a passed limit point): see ``ForceRamp.after_snap``.
AFTER_SNAP = ("dynamic", "stop")


@dataclass(frozen=True)
class ForceRamp:
    """The force ramp of the design map and how it is followed.

    Parameters
    ----------
    rate : float
        Ḟ [N/s] (paper 0.8), finite and ≠ 0.
    duration : float
        T [s] (paper 2), > 0; terminal force F_f = Ḟ T [N].
    n_steps : int
        Load steps over [0, T] (≥ 2); the step times are t_k = k T / n_steps.
    snap_factor : float
        A step whose load-point displacement increment exceeds this multiple of the mean
        increment of the steps before is a snap (> 1).
    atol : float
        Newton tolerance on ‖r‖∞ (N, mm).
    max_steps : int
        Newton iterations per load step.
    max_backtracks : int
        Line-search halvings per Newton step.
    free_steps : int
        Newton watchdog steps per load step (:class:`~biplan.solvers.newton.Newton`): full
        steps without the line-search test, falling back to the best iterate. The first load
        steps open the contacts that all touch in the reference (gap 0); there the line search
        rejects full semismooth-Newton steps that converge (docs/maps.md). ≥ 0.
    after_snap : {"dynamic", "stop"}
        What a design does when a load step fails (a force limit point was passed: no nearby
        equilibrium). ``"dynamic"`` (default; the paper's maps are the dynamic response):
        the rest of the ramp is integrated with the generalized-α scheme from the last
        equilibrium (:mod:`biplan.analysis.response.ramp_dynamics`) and the terminal state is the
        post-snap one (``dynamic`` = 1 in the map; 2 where the generalized-α run failed and
        backward Euler finished it, see
        :func:`~biplan.analysis.response.ramp_dynamics.continue_ramp`).
        ``"stop"``: the point ends there with
        status ``not_converged`` and NaN terminal values.
    damping_ratio : float
        ζ of the first mode (at half the last converged force) for the Rayleigh damping of
        the dynamic finish, in (0, 1).
    time_step : float
        Nominal generalized-α step h [s] of the dynamic finish, > 0.
    spectral_radius : float
        ρ∞ ∈ [0, 1] of the dynamic finish (default 0: asymptotic annihilation). A fold that
        snaps open drives others into contact at metres per second; with the contacts held at
        position level the impact leaves a spurious velocity jump that ρ∞ = 0.8 keeps
        ringing (on the six-module design at 2.4 N every step then failed down to 2.4 µs),
        while ρ∞ = 0 removes it within a step (perfectly inelastic impact) and stays second
        order on the resolved modes. The terminal (settled) state is the map's output.
    """

    rate: float = 0.8
    duration: float = 2.0
    n_steps: int = 16
    snap_factor: float = 8.0
    atol: float = 1e-9
    max_steps: int = 60
    max_backtracks: int = 12
    free_steps: int = 8
    after_snap: str = "dynamic"
    damping_ratio: float = 0.05
    time_step: float = 0.01
    spectral_radius: float = 0.0

    def __post_init__(self) -> None:
        r = check_range("ramp.rate", self.rate)
        if r == 0:
            raise ConfigError("ramp.rate", r, "a finite non-zero rate [N/s]")
        check_range("ramp.duration", self.duration, low=0.0)
        check_range("ramp.snap_factor", self.snap_factor, low=1.0)
        object.__setattr__(
            self, "n_steps", check_integer("ramp.n_steps", self.n_steps, low=2, high=512)
        )
        object.__setattr__(
            self, "free_steps", check_integer("ramp.free_steps", self.free_steps, low=0)
        )
        if self.after_snap not in AFTER_SNAP:
            raise ConfigError("ramp.after_snap", self.after_snap, " or ".join(AFTER_SNAP))
        check_range("ramp.damping_ratio", self.damping_ratio, low=0.0, high=1.0)
        check_range("ramp.time_step", self.time_step, low=0.0)
        check_range("ramp.spectral_radius", self.spectral_radius, low=0.0, high=1.0,
                    low_open=False, high_open=False)  # fmt: skip
        self.newton()

    @property
    def times(self) -> np.ndarray:
        """Step times t_k [s], k = 0 … n_steps."""
        return np.linspace(0.0, self.duration, self.n_steps + 1)

    @property
    def forces(self) -> np.ndarray:
        """Step forces F_k = Ḟ t_k [N]."""
        return self.rate * self.times

    def newton(self) -> Newton:
        return Newton(
            atol=self.atol,
            max_steps=self.max_steps,
            max_backtracks=self.max_backtracks,
            free_steps=self.free_steps,
        )


def _summarise(
    ramp: ForceRamp,
    ok: np.ndarray,
    first_bad: np.ndarray,
    u_z: np.ndarray,
    u_r: np.ndarray,
    zp: np.ndarray,
    min_eig: np.ndarray,
    l0: np.ndarray,
) -> dict[str, np.ndarray]:
    """Per point (rows) from per-step (columns) records of the ramp."""
    n = ok.shape[0]
    times = ramp.times
    status = np.zeros(n, dtype=np.int64)
    lost_step = np.full(n, -1)
    for i in range(n):
        bad = np.flatnonzero(~ok[i])
        if bad.size:
            code = int(first_bad[i, bad[0]])
            status[i] = 2 if code == Status.NONFINITE.value else 1
        dz = np.abs(np.diff(zp[i]))
        snap = np.zeros(ok.shape[1], dtype=bool)
        for k in range(2, ok.shape[1]):
            mean = float(np.mean(dz[: k - 1]))
            snap[k] = ok[i, k] and dz[k - 1] > ramp.snap_factor * max(mean, 1e-12)
        unstable = ok[i] & (min_eig[i] <= 0.0)
        flagged = np.flatnonzero(unstable | snap | ~ok[i])
        if flagged.size:
            lost_step[i] = int(flagged[0])
    good = status == 0
    nan = np.nan
    return {
        "u_z": np.where(good, u_z[:, -1] / l0, nan),
        "u_r": np.where(good, u_r[:, -1] / l0, nan),
        "stability_lost": np.where(good, (lost_step >= 0).astype(float), nan),
        "time_lost": np.where(lost_step >= 0, times[np.maximum(lost_step, 0)], nan),
        "min_eigenvalue": np.where(good, np.min(np.where(ok, min_eig, np.inf), axis=1), nan),
        "status": status,
        "dynamic": np.zeros(n, dtype=np.int64),
    }


def _finish_after_snap(
    ramp: ForceRamp,
    model: Model,
    ok: np.ndarray,
    min_eig: np.ndarray,
    z_last: np.ndarray,
    res: dict[str, np.ndarray],
    row: int,
) -> None:
    """``after_snap = "dynamic"``: a point whose ramp failed after ≥ 1 converged step is
    finished by :func:`continue_ramp` from its last equilibrium ``z_last``; ``res[...][row]``
    is updated in place (terminal u_z/l₀, u_r/l₀, status; stability counts as lost at the
    failed step; λ_min over the quasi-static equilibria and the terminal state)."""
    if ramp.after_snap != "dynamic" or res["status"][row] == 0 or not ok[0]:
        return
    k = int(np.flatnonzero(ok)[-1])
    traj = continue_ramp(
        model, z_last, float(ramp.times[k]), rate=ramp.rate, duration=ramp.duration,
        damping_ratio=ramp.damping_ratio, time_step=ramp.time_step,
        spectral_radius=ramp.spectral_radius,
    )  # fmt: skip
    res["dynamic"][row] = 2 if traj.method.startswith("backward-euler") else 1
    if not traj.completed:
        return
    l0 = model.tube.initial_length
    res["status"][row] = 0
    res["u_z"][row] = traj.u_z[-1] / l0
    res["u_r"][row] = traj.u_r[-1] / l0
    res["stability_lost"][row] = 1.0
    res["min_eigenvalue"][row] = min(float(np.min(min_eig[ok])), float(traj.min_eigenvalue[-1]))


@dataclass(frozen=True)
class ResponseEvaluator:
    """Terminal response of the force ramp at every grid point (see module docstring)."""

    ramp: ForceRamp = ForceRamp()
    name: str = "force_ramp_response"
    load_axes: tuple[str, ...] = ()

    def variables(self, design: Tube) -> dict[str, tuple[tuple[str, ...], str, str]]:
        return {
            "u_z": ((), "1", "terminal axial endpoint displacement u_z / l0"),
            "u_r": ((), "1", "terminal radial endpoint displacement u_r / l0"),
            "stability_lost": ((), "1", "1 if stability was lost during the ramp, else 0"),
            "time_lost": ((), "s", "first ramp time at which stability was lost"),
            "min_eigenvalue": ((), "N*mm", "smallest reduced-Hessian eigenvalue on the ramp"),
            "status": ((), "1", "0 ok; see flag_meanings"),
            "dynamic": (
                (),
                "1",
                "after a failed step the ramp was finished dynamically: 0 no, "
                "1 generalized-alpha, 2 backward Euler (generalized-alpha failed)",
            ),
        }

    def dim_sizes(self, design: Tube) -> dict[str, int]:
        return {}

    def describe(self) -> dict[str, Any]:
        r = self.ramp
        return {
            "solver": "quasi-static Newton load stepping on the force ramp (compiled System)",
            "rate_N_per_s": r.rate,
            "duration_s": r.duration,
            "n_steps": r.n_steps,
            "snap_factor": r.snap_factor,
            "atol": r.atol,
            "max_steps": r.max_steps,
            "max_backtracks": r.max_backtracks,
            "free_steps": r.free_steps,
            "after_snap": r.after_snap,
            "damping_ratio": r.damping_ratio,
            "time_step_s": r.time_step,
            "spectral_radius": r.spectral_radius,
        }

    def finish(self, ds: Any) -> Any:
        return ds

    def evaluate(
        self, tubes: Sequence[Tube], loads: Sequence[Mapping[str, float]], batch: int
    ) -> dict[str, np.ndarray]:
        """The ramp of ``tubes``: one compiled call per design, ``batch`` designs at a time
        (:func:`ramp_batches`)."""
        n = len(tubes)
        out: dict[str, np.ndarray] | None = None
        for part, models, (ok, bad, uz, ur, zp, min_eig), z_last in ramp_batches(
            tubes, self.ramp, batch
        ):
            l0 = np.asarray([tubes[i].initial_length for i in part])
            res = _summarise(self.ramp, ok, bad, uz, ur, zp, min_eig, l0)
            for row in range(len(part)):
                _finish_after_snap(self.ramp, models[row], ok[row], min_eig[row], z_last[row], res,
                                   row)  # fmt: skip
            if out is None:
                out = {k: np.empty((n, *v.shape[1:]), v.dtype) for k, v in res.items()}
            for k, v in res.items():
                out[k][part] = v
        assert out is not None
        return out


def ramp_batches(
    tubes: Sequence[Tube], ramp: ForceRamp, batch: int
) -> Iterator[tuple[list[int], list[Model], tuple[np.ndarray, ...], np.ndarray]]:
    """The quasi-static ramp of ``tubes``, ``batch`` designs at a time (the designs of one
    layout together): one compiled call per design on its System
    (:func:`~biplan.analysis.maps.design_kernels.ramp_compiled`); ``batch`` only sets how
    many designs each yield holds, not the results.

    Yields
    ------
    part : list of int
        Indices into ``tubes`` of this call's designs.
    models : list of Model
        Their models.
    records : tuple of ndarray, each (len(part), n_steps + 1)
        Per design and load step: converged, the failing status (−1 none), u_z, u_r [mm], the
        load-point displacement [mm] and λ_min of the reduced Hessian [N/mm] (only the
        converged steps are meaningful).
    z_last : ndarray, shape (len(part), n_z)
        The last converged packed state of each design.
    """
    groups: dict[Any, list[int]] = {}
    for i, t in enumerate(tubes):
        groups.setdefault(t.layout, []).append(i)
    newton = ramp.newton()
    for which in groups.values():
        models = [Model(tubes[i]) for i in which]
        for lo in range(0, len(which), batch):
            part, chunk = which[lo : lo + batch], models[lo : lo + batch]
            records, z_last = ramp_compiled(chunk, ramp.forces, newton)
            yield part, chunk, records, z_last


def response_point(tube: Tube, ramp: ForceRamp | None = None) -> dict[str, float]:
    """Scalar reference of :class:`ResponseEvaluator` for one design: the same chord
    iterations and one Newton solve per load step (``solve_equilibrium``), observed with a
    fresh evaluation of each Hessian (an independent check of the Jacobian-block stability
    test of the map's ramp), on the design's compiled System
    (:func:`~biplan.analysis.maps.design_kernels.point_solvers`).

    Returns
    -------
    dict
        The same keys as the map's variables, as Python floats (``status`` an int).
    """
    ramp = ramp or ForceRamp()
    model = Model(tube)
    solver = ramp.newton()
    jacobian, chord_start, observe = point_solvers(model, ramp.atol)
    z = np.asarray(model.pack(model.zeros()))
    jac = jacobian(z, Load.of_force(float(ramp.forces[0])))
    ok, first_bad, zs = [], [], []
    alive = True
    for f in ramp.forces:
        load = Load.of_force(float(f))
        start = chord_start(z, jac, load)
        sol = solve_equilibrium(model, solver, start, load)
        good = alive and sol.converged and bool(np.all(np.isfinite(sol.z)))
        first_bad.append(sol.status.value if alive and not good else -1)
        ok.append(good)
        zs.append(sol.z if good else z)
        if good:
            z = np.asarray(sol.z)
            jac = jacobian(z, load)
        alive = good
    forces = ramp.forces
    obs = observe(np.asarray(zs), Load(forces, 0.0 * forces, 0.0))
    res = _summarise(
        ramp,
        np.asarray([ok]),
        np.asarray([first_bad]),
        obs.u_z[None],
        obs.u_r[None],
        obs.displacement[None],
        obs.min_eigenvalue[None],
        np.asarray([tube.initial_length]),
    )
    _finish_after_snap(ramp, model, np.asarray(ok), obs.min_eigenvalue, z, res, 0)
    return {k: (int(v[0]) if k in ("status", "dynamic") else float(v[0])) for k, v in res.items()}
