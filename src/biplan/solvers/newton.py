"""Newton solver for the KKT system of a constrained, contact-regularised equilibrium (MODEL §11).

``solve_equilibrium(model, Newton(...), start, load)`` solves r(z) = 0 for z = [q, λ, λ_∂, μ].
Globalisation: Newton direction with Armijo backtracking on the merit ½‖r‖²; when the line
search fails (or the Newton matrix is singular) a Levenberg–Marquardt step on ½‖r‖² is tried
with adaptive damping. The whole loop is one ``jax.lax.while_loop`` compiled once per tube
layout (tolerances and limits are traced), so it is cheap to call repeatedly and ``vmap``-able.
"""

from __future__ import annotations

import enum
import functools
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from biplan._errors import ConfigError, ConvergenceError, check_range
from biplan._jax import jax, jnp
from biplan.assembly import Load, Model, TubeLayout, kernels

__all__ = ["Newton", "Solution", "Status", "relaxed_reference", "solve_equilibrium"]

Array = Any


class Status(enum.Enum):
    """Outcome of a solve."""

    CONVERGED = 0
    MAX_STEPS = 1
    LINE_SEARCH_FAILED = 2
    NONFINITE = 3

    @property
    def message(self) -> str:
        return {
            0: "converged",
            1: "maximum number of Newton steps reached before the residual tolerance",
            2: "neither the Newton line search nor Levenberg–Marquardt reduced the residual",
            3: "the residual or the Newton step became non-finite",
        }[self.value]


@dataclass(frozen=True)
class Newton:
    """Configured Newton solver.

    Parameters
    ----------
    atol : float
        Convergence when ‖r‖∞ < atol (residual units N, mm), > 0.
    max_steps : int
        Newton iterations, ≥ 1.
    max_backtracks : int
        Step halvings in the Armijo line search, ≥ 1.
    armijo : float
        Sufficient-decrease constant c in (0, 0.5).
    """

    atol: float = 1e-9
    max_steps: int = 60
    max_backtracks: int = 30
    armijo: float = 1e-4

    def __post_init__(self) -> None:
        check_range("Newton.atol", self.atol, low=0.0)
        check_range("Newton.armijo", self.armijo, low=0.0, high=0.5)
        for name in ("max_steps", "max_backtracks"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or v < 1:
                raise ConfigError(f"Newton.{name}", v, "an integer ≥ 1")

    def settings(self) -> Array:
        return jnp.asarray([self.atol, self.max_steps, self.max_backtracks, self.armijo])


class LoopState(NamedTuple):
    z: Array
    it: Array
    status: Array  # -1 running, else Status value
    damping: Array
    rnorm: Array


def newton_loop(layout: TubeLayout, params: Any, z0: Array, load: Load, settings: Array) -> LoopState:
    """Pure (jit/vmap-able) Newton iteration; see module docstring."""
    k = kernels(layout)
    atol, max_steps, max_bt, c_arm = settings[0], settings[1], settings[2], settings[3]

    def res(z: Array) -> Array:
        return k.residual(params, z, load)

    def merit(z: Array) -> Array:
        r = res(z)
        f = 0.5 * r @ r
        return jnp.where(jnp.isfinite(f), f, jnp.inf)

    def body(s: LoopState) -> LoopState:
        r = res(s.z)
        rnorm = jnp.max(jnp.abs(r))
        done = rnorm < atol
        J = k.jacobian(params, s.z, load)
        f = 0.5 * r @ r
        dz = jnp.linalg.solve(J, -r)
        ok_dir = jnp.all(jnp.isfinite(dz))
        dz = jnp.where(ok_dir, dz, 0.0)
        slope = r @ (J @ dz)  # directional derivative of f, = −2f for an exact Newton step

        def bt_cond(c: tuple) -> Array:
            alpha, n, fn = c
            return (fn > f + c_arm * alpha * slope) & (n < max_bt)

        def bt_body(c: tuple) -> tuple:
            alpha, n, _ = c
            alpha = 0.5 * alpha
            return alpha, n + 1, merit(s.z + alpha * dz)

        alpha, _, f_new = jax.lax.while_loop(bt_cond, bt_body, (1.0, 0, merit(s.z + dz)))
        newton_ok = ok_dir & (f_new <= f + c_arm * alpha * slope) & (slope < 0)

        def lm(_: Any) -> tuple:
            jtj = J.T @ J
            g = J.T @ r
            scale = jnp.diag(jtj) + 1e-12
            step = jnp.linalg.solve(jtj + s.damping * jnp.diag(scale), -g)
            step = jnp.where(jnp.isfinite(step), step, 0.0)
            f_lm = merit(s.z + step)
            better = f_lm < f
            return step, better

        def newton(_: Any) -> tuple:
            return alpha * dz, jnp.asarray(True)

        step, accepted = jax.lax.cond(newton_ok, newton, lm, None)
        damping = jnp.where(
            newton_ok, jnp.maximum(s.damping * 0.3, 1e-10), jnp.where(accepted, s.damping * 0.3, s.damping * 10.0)
        )
        z_new = jnp.where(accepted & ~done, s.z + step, s.z)
        finite = jnp.isfinite(rnorm)
        status = jnp.where(
            done,
            Status.CONVERGED.value,
            jnp.where(
                ~finite,
                Status.NONFINITE.value,
                jnp.where(~accepted & (damping > 1e12), Status.LINE_SEARCH_FAILED.value, -1),
            ),
        )
        return LoopState(z_new, s.it + jnp.where(done, 0, 1), status, damping, rnorm)

    def cond(s: LoopState) -> Array:
        return (s.status < 0) & (s.it < max_steps)

    init = LoopState(z0, jnp.asarray(0), jnp.asarray(-1), jnp.asarray(1e-3), jnp.asarray(jnp.inf))
    out = jax.lax.while_loop(cond, body, init)
    # Final residual (the loop stops before re-evaluating after its last step).
    rn = jnp.max(jnp.abs(res(out.z)))
    status = jnp.where(
        out.status >= 0,
        out.status,
        jnp.where(rn < atol, Status.CONVERGED.value, Status.MAX_STEPS.value),
    )
    status = jnp.where(jnp.isfinite(rn), status, Status.NONFINITE.value)
    return LoopState(out.z, out.it, status, out.damping, rn)


@functools.lru_cache(maxsize=64)
def compiled_loop(layout: TubeLayout) -> Any:
    """The jitted Newton loop of a layout (built once)."""
    return jax.jit(functools.partial(newton_loop, layout))


@dataclass(frozen=True)
class Solution:
    """A (possibly failed) equilibrium solve.

    Attributes
    ----------
    q : ndarray
        Generalised coordinates (n_q,).
    multipliers : ndarray
        Guide multipliers λ [N] (2N,).
    contact_multipliers : ndarray
        Contact multipliers λ_∂ [N] (n_c,).
    force : float
        End force [N]: the applied F, or the reaction −μ under displacement control.
    displacement : float
        Axial displacement z_p [mm] of the load point.
    load : Load
        The load solved for.
    status : Status
    residual_norm : float
        ‖r‖∞ at the returned point.
    iterations : int
    energy : float
        Π(q) [N·mm].
    """

    q: np.ndarray
    multipliers: np.ndarray
    contact_multipliers: np.ndarray
    force: float
    displacement: float
    load: Load
    status: Status
    residual_norm: float
    iterations: int
    energy: float
    z: np.ndarray = field(repr=False)

    @property
    def converged(self) -> bool:
        return self.status is Status.CONVERGED

    @property
    def message(self) -> str:
        return (
            f"{self.status.message} after {self.iterations} iterations "
            f"(‖r‖∞ = {self.residual_norm:.3e})"
        )


def _start_vector(model: Model, start: Any) -> np.ndarray:
    if isinstance(start, Solution):
        z = np.asarray(start.z, dtype=float)
        if z.shape != (model.n_unknowns,):
            raise ConfigError("start", z.shape, f"a Solution of this model ({model.n_unknowns} unknowns)")
        return z
    arr = np.asarray(start, dtype=float)
    if arr.shape == (model.n_unknowns,):
        z = arr.copy()
    elif arr.shape == (model.n_coordinates,):
        z = model.pack(arr)
    else:
        raise ConfigError(
            "start",
            arr.shape,
            f"q of shape ({model.n_coordinates},), z of shape ({model.n_unknowns},) or a Solution",
        )
    if not np.all(np.isfinite(z)):
        raise ConfigError("start", "non-finite entries", "finite coordinates")
    return z


def make_solution(model: Model, z: np.ndarray, load: Load, status: Status, rnorm: float, it: int) -> Solution:
    """Wrap a packed solution vector into a :class:`Solution`."""
    q, lam, lam_c, mu = model.split(z)
    zp = model.load_displacement(q)
    force = -mu if load.is_displacement_controlled else float(load.force)
    return Solution(
        q=q,
        multipliers=lam,
        contact_multipliers=lam_c,
        force=float(force),
        displacement=zp,
        load=load,
        status=status,
        residual_norm=float(rnorm),
        iterations=int(it),
        energy=model.energy(q),
        z=np.asarray(z),
    )


def solve_equilibrium(
    model: Model,
    solver: Newton | None = None,
    start: Any = None,
    load: Load | None = None,
    *,
    throw: bool = False,
) -> Solution:
    """Solve the KKT equilibrium system for one load.

    Parameters
    ----------
    model : Model
    solver : Newton, optional
        Defaults to ``Newton()``.
    start : array_like or Solution, optional
        q (n_q,), a packed z, or a previous Solution (warm start with its multipliers).
        Defaults to q = 0.
    load : Load, optional
        Defaults to zero end force.
    throw : bool
        Raise :class:`~biplan.ConvergenceError` instead of returning a failed Solution.

    Returns
    -------
    Solution
        Check ``solution.status``; a non-converged solution is never marked converged.
    """
    solver = solver or Newton()
    load = load or Load.of_force(0.0)
    if not isinstance(load, Load):
        raise ConfigError("load", load, "a biplan Load (Load.of_force / Load.of_displacement)")
    z0 = _start_vector(model, model.zeros() if start is None else start)
    if load.is_displacement_controlled and not isinstance(start, Solution) and z0[-1] == 0.0:
        pass
    loop = compiled_loop(model.layout)
    jload = Load(*(jnp.asarray(float(v)) for v in load))
    out = loop(model.params, jnp.asarray(z0), jload, solver.settings())
    status = Status(int(out.status))
    sol = make_solution(model, np.asarray(out.z), load, status, float(out.rnorm), int(out.it))
    if throw and not sol.converged:
        raise ConvergenceError(f"equilibrium solve for {load}: {sol.message}")
    return sol


def relaxed_reference(model: Model, solver: Newton | None = None, *, throw: bool = True) -> Solution:
    """The relaxed reference configuration q_ref: clamped base only, no load (SI "Numerical
    solver"). Starts from q = 0, which is an equilibrium up to the contact regularisation."""
    return solve_equilibrium(model, solver, model.zeros(), Load.of_force(0.0), throw=throw)
