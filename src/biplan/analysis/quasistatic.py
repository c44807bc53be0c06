"""Displacement-controlled quasi-static sweep with stable-branch selection.

Each step prescribes the load-point displacement U_k, warm-starts Newton from the previous
equilibrium and classifies the result with the reduced Hessian. When the equilibrium reached
is unstable (for example the symmetric state of folds in series past the force peak), the
sweep perturbs it along the unstable eigenmodes (both signs, growing amplitudes), re-solves at
the same U_k and keeps the stable equilibrium of lowest energy — the branch a
displacement-controlled test jumps to. If none is found, the unstable equilibrium is recorded
as such. Path following through limit points (arc length) lives in the continuation solver.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from biplan._errors import ConfigError
from biplan.assembly import Load, Model
from biplan.analysis.stability import Stability, Verdict, classify, reduced_hessian
from biplan.solvers.newton import Newton, Solution, Status, relaxed_reference, solve_equilibrium

__all__ = ["QuasiStaticPath", "displacement_sweep"]

_AMPLITUDES = (1e-3, 1e-2, 5e-2, 0.2)


@dataclass(frozen=True)
class QuasiStaticPath:
    """A recorded quasi-static path (one entry per step).

    Attributes
    ----------
    displacement : ndarray
        Prescribed load-point displacement U [mm].
    force : ndarray
        End reaction force F [N].
    u_z, u_r, theta : ndarray
        Endpoint displacements [mm] and slope [rad].
    energy : ndarray
        Strain energy Π [N·mm].
    min_eigenvalue : ndarray
        Smallest reduced-Hessian eigenvalue (+inf when contact-locked).
    stable : ndarray of bool
    status : tuple of Status
    switched : ndarray of bool
        True where the sweep left an unstable equilibrium for a stable one.
    solutions : tuple of Solution
    """

    displacement: np.ndarray
    force: np.ndarray
    u_z: np.ndarray
    u_r: np.ndarray
    theta: np.ndarray
    energy: np.ndarray
    min_eigenvalue: np.ndarray
    stable: np.ndarray
    status: tuple[Status, ...]
    switched: np.ndarray
    solutions: tuple[Solution, ...] = field(repr=False)

    @property
    def n_steps(self) -> int:
        return len(self.displacement)


def _stabilise(
    model: Model, sol: Solution, stab: Stability, solver: Newton
) -> tuple[Solution, Stability, bool]:
    """Try to replace an unstable equilibrium by a stable one at the same load."""
    h, basis = reduced_hessian(model, sol)
    eig, vec = np.linalg.eigh(h)
    modes = [basis @ vec[:, i] for i in range(len(eig)) if eig[i] < 0]
    best: tuple[Solution, Stability] | None = None
    for mode in modes:
        for amp in _AMPLITUDES:
            for sign in (1.0, -1.0):
                z = sol.z.copy()
                z[: model.n_coordinates] += sign * amp * mode
                trial = solve_equilibrium(model, solver, z, sol.load)
                if not trial.converged:
                    continue
                st = classify(model, trial)
                if st.verdict is Verdict.STABLE and (best is None or trial.energy < best[0].energy):
                    best = (trial, st)
        if best is not None:
            return best[0], best[1], True
    return sol, stab, False


def displacement_sweep(
    model: Model,
    displacements: np.ndarray,
    solver: Newton | None = None,
    start: Solution | None = None,
    *,
    select_stable: bool = True,
) -> QuasiStaticPath:
    """Sweep the prescribed end displacement through ``displacements`` [mm].

    Parameters
    ----------
    model : Model
    displacements : array_like
        Finite load-point displacements U [mm], in the order to visit.
    solver : Newton, optional
    start : Solution, optional
        Starting equilibrium; default the relaxed reference.
    select_stable : bool
        Leave unstable equilibria for stable ones at the same U (see module docstring).

    Returns
    -------
    QuasiStaticPath
        Failed steps are recorded with their status; the sweep continues from the last
        converged equilibrium.
    """
    u = np.asarray(displacements, dtype=float).ravel()
    if u.size == 0 or not np.all(np.isfinite(u)):
        raise ConfigError("displacements", displacements, "a non-empty array of finite mm values")
    solver = solver or Newton()
    current = start if start is not None else relaxed_reference(model, solver)
    rows: list[tuple] = []
    sols: list[Solution] = []
    for target in u:
        sol = solve_equilibrium(model, solver, current, Load.of_displacement(float(target)))
        switched = False
        if sol.converged:
            stab = classify(model, sol)
            if select_stable and stab.verdict is Verdict.UNSTABLE:
                sol, stab, switched = _stabilise(model, sol, stab, solver)
            current = sol
            e = model.endpoint(sol.q)
            rows.append(
                (target, sol.force, e.u_z, e.u_r, e.theta, sol.energy, stab.min_eigenvalue,
                 stab.stable, sol.status, switched)
            )
        else:
            nan = float("nan")
            rows.append((target, nan, nan, nan, nan, nan, nan, False, sol.status, False))
        sols.append(sol)
    cols = list(zip(*rows, strict=True))
    return QuasiStaticPath(
        displacement=np.asarray(cols[0]),
        force=np.asarray(cols[1]),
        u_z=np.asarray(cols[2]),
        u_r=np.asarray(cols[3]),
        theta=np.asarray(cols[4]),
        energy=np.asarray(cols[5]),
        min_eigenvalue=np.asarray(cols[6]),
        stable=np.asarray(cols[7], dtype=bool),
        status=tuple(cols[8]),
        switched=np.asarray(cols[9], dtype=bool),
        solutions=tuple(sols),
    )
