"""Energy barriers between stable states: constrained climbing-image NEB and saddle refinement.

``minimum_energy_path(model, z_start, z_end, NudgedElasticBand())`` finds the minimum-energy
path (MEP) between two stable equilibria at zero end load on the constraint manifold of the
tube (guides g(q) = 0, contact gaps w_∂(q) ≥ 0):

1. the band is the straight line between the two states in q (mm, rad), each interior image
   returned to the manifold (:mod:`biplan.solvers.manifold`);
2. the band is relaxed by FIRE with constraint-projected NEB forces and, once the forces are
   small, a climbing image (Henkelman, Uberuaga & Jónsson 2000): the compiled loop
   :func:`biplan.solvers.band_loop.fire_band` on the model's System at rest (Numba, compiled
   once for every tube; the JAX loop it replaced is the tests' oracle,
   ``tests/jax_oracle/neb.py``);
3. the climbing image, with its least-squares multipliers, starts a Newton solve of the full KKT
   system at zero load (:func:`biplan.solvers.iteration.newton`, contact by the smoothed
   Fischer–Burmeister function), which converges to the nearby stationary point; its reduced
   Hessian (MODEL §12) must have exactly one negative eigenvalue (a first-order saddle).

The barrier is ΔE_forward = Π(saddle) − Π(start) and ΔE_backward = Π(saddle) − Π(end) [N·mm].
:func:`departure_force` (in :mod:`biplan.analysis.states.departure`) gives the actuation instead.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from biplan._errors import ConfigError, ResultStatus, check_integer, check_range
from biplan.analysis.stability import classify
from biplan.model.assembly import Load, Model
from biplan.model.params import StateData
from biplan.model.system import System
from biplan.model.system.assemble import observe
from biplan.solvers import band_loop, iteration
from biplan.solvers.newton import Newton, Status, make_solution

__all__ = [
    "MepStatus",
    "MinimumEnergyPath",
    "NudgedElasticBand",
    "edge_barriers",
    "minimum_energy_path",
]

#: An eigenvalue of the reduced Hessian below −this counts as negative.
NEGATIVE_TOL = 1e-8


class MepStatus(ResultStatus):
    """Outcome of a minimum-energy-path search."""

    CONVERGED = "converged", "first-order saddle found", True
    BAND_NOT_CONVERGED = "band_not_converged", "the nudged elastic band did not converge"
    SADDLE_NOT_REFINED = "saddle_not_refined", "the saddle refinement did not converge"
    NOT_FIRST_ORDER = "not_first_order", "the highest point is not a first-order saddle"
    NO_BARRIER = "no_barrier", "the highest image is not above both end states"


@dataclass(frozen=True)
class NudgedElasticBand:
    """Configured constrained climbing-image nudged elastic band.

    Parameters
    ----------
    n_images : int
        Images including the two end states, ≥ 3.
    spring : float
        Spring constant k [N/mm] between neighbouring images, > 0.
    climbing : bool
        Let the highest interior image climb to the saddle.
    tolerance : float
        Convergence when every NEB force component is below this [N], > 0.
    max_iterations : int
        FIRE iterations at most, ≥ 1.
    time_step, max_time_step : float
        Initial and largest FIRE pseudo-time step (> 0).
    max_step : float
        Largest change of any coordinate of an image per iteration [mm or rad], > 0.
    contact_tolerance : float
        A contact with gap below this [mm] is closed (may carry a multiplier), > 0.
    climb_start : float
        The climbing image switches on once the largest force is below this [N], > 0.
    refine : Newton
        Newton solver of the saddle refinement on the KKT system.
    fallbacks : tuple of (float, float)
        (spring, max_step) pairs tried in turn, from the straight band again, when an attempt
        does not end CONVERGED (band and contact active set can cycle or stray; no setting was
        found that converges every edge of the four-module tube on its own).
    """

    n_images: int = 12
    spring: float = 2.0
    climbing: bool = True
    tolerance: float = 1e-5
    max_iterations: int = 20000
    time_step: float = 0.02
    max_time_step: float = 0.2
    max_step: float = 0.01
    contact_tolerance: float = 1e-6
    climb_start: float = 1e-2
    refine: Newton = field(default_factory=lambda: Newton(max_steps=200))
    fallbacks: tuple[tuple[float, float], ...] = ((0.5, 0.02), (2.0, 0.005))

    def __post_init__(self) -> None:
        for name in ("n_images", "max_iterations"):
            low = 3 if name == "n_images" else 1
            v = check_integer(f"NudgedElasticBand.{name}", getattr(self, name), low=low)
            object.__setattr__(self, name, v)
        for name in (
            "spring",
            "tolerance",
            "time_step",
            "max_time_step",
            "max_step",
            "contact_tolerance",
            "climb_start",
        ):
            check_range(f"NudgedElasticBand.{name}", getattr(self, name), low=0.0)
        check_range(
            "NudgedElasticBand.max_time_step",
            self.max_time_step,
            low=self.time_step,
            low_open=False,
        )
        if not isinstance(self.refine, Newton):
            raise ConfigError("NudgedElasticBand.refine", self.refine, "a biplan Newton")

    def loop_settings(
        self, spring: float | None = None, max_step: float | None = None
    ) -> band_loop.BandSettings:
        """These settings as the compiled band loop takes them (``spring`` and ``max_step``
        replaced when given; every field of its type)."""
        return band_loop.BandSettings(
            float(self.spring if spring is None else spring),
            float(self.tolerance),
            int(self.max_iterations),
            bool(self.climbing),
            float(self.time_step),
            float(self.max_time_step),
            float(self.max_step if max_step is None else max_step),
            float(self.contact_tolerance),
            float(self.climb_start),
        )


@dataclass(frozen=True)
class MinimumEnergyPath:
    """A minimum-energy path between two stable states and its saddle.

    Attributes
    ----------
    q : ndarray (n_images, n_q)
        Images of the relaxed band (first and last: the end states).
    energies : ndarray (n_images,)
        Π of each image [N·mm].
    arc_length : ndarray (n_images,)
        Cumulative Euclidean length along the band in q [mm, rad mixed].
    saddle_index : int
        Index of the climbing (highest) image.
    saddle_z : ndarray
        Packed state z = [q, λ, λ_∂, μ] of the refined saddle (the climbing image with its
        least-squares multipliers when the refinement failed).
    saddle_energy : float
        Π at the saddle [N·mm].
    barrier_forward, barrier_backward : float
        Π(saddle) − Π(start) and Π(saddle) − Π(end) [N·mm].
    n_negative : int
        Negative eigenvalues of the reduced Hessian at the saddle (1 for a first-order saddle).
    saddle_eigenvalues : ndarray
        Eigenvalues of the reduced Hessian at the saddle, ascending.
    status : MepStatus
    message : str
    iterations : int
        FIRE iterations of the band.
    max_force : float
        Largest NEB force component at the end [N].
    saddle_residual : float
        ‖r‖∞ of the KKT system at ``saddle_z``.
    """

    q: np.ndarray = field(repr=False)
    energies: np.ndarray = field(repr=False)
    arc_length: np.ndarray = field(repr=False)
    saddle_index: int
    saddle_z: np.ndarray = field(repr=False)
    saddle_energy: float
    barrier_forward: float
    barrier_backward: float
    n_negative: int
    saddle_eigenvalues: np.ndarray = field(repr=False)
    status: MepStatus
    message: str
    iterations: int
    max_force: float
    saddle_residual: float

    @property
    def converged(self) -> bool:
        return self.status is MepStatus.CONVERGED


def _as_state(model: Model, z: object, name: str) -> np.ndarray:
    arr = np.asarray(getattr(z, "z", z), dtype=float)
    if arr.shape == (model.n_coordinates,):
        arr = model.pack(arr)
    if arr.shape != (model.n_unknowns,) or not np.all(np.isfinite(arr)):
        raise ConfigError(
            name, arr.shape, f"finite q ({model.n_coordinates},) or z ({model.n_unknowns},)"
        )
    return arr


def _contact_start(model: Model, z: np.ndarray, lam_c: np.ndarray) -> np.ndarray:
    """Multipliers that satisfy the SFB rows for open contacts: λ_∂ ≈ ε²/(2w) [N] (w the
    contact gaps at z [mm], ε the contact smoothing)."""
    eps = float(model.params.smoothing)
    gaps = observe(model.system().data, z)[4]
    return np.where(lam_c > 0.0, lam_c, eps**2 / (2.0 * np.maximum(gaps, eps)))


def _refine(
    system: System, neb: NudgedElasticBand, z0: np.ndarray
) -> tuple[np.ndarray, int, float, StateData]:
    """(z, status, ‖r‖∞, state data at z) of the Newton refinement of the KKT system at rest
    from z0 (:func:`biplan.solvers.iteration.newton`)."""
    m = neb.refine
    settings = m.loop_settings()
    z, r, f, jac, _, status = iteration.solve_system(system, z0, settings)
    data = system.state(z, jac if np.isfinite(f) else None)
    return z, int(status), float(np.max(np.abs(r))), data


def minimum_energy_path(
    model: Model,
    z_start: object,
    z_end: object,
    neb: NudgedElasticBand | None = None,
) -> MinimumEnergyPath:
    """Minimum-energy path and first-order saddle between two stable states (zero load).

    Parameters
    ----------
    model : Model
    z_start, z_end : array_like or Solution
        The two states: packed z (n_z,), coordinates q (n_q,) or a Solution.
    neb : NudgedElasticBand, optional
        Defaults to ``NudgedElasticBand()``.

    Returns
    -------
    MinimumEnergyPath
        ``status`` is CONVERGED only when the band converged, the Newton refinement of the
        climbing image converged near it, and its reduced Hessian has exactly one negative
        eigenvalue. Barriers are reported in every case (from the best available saddle).
    """
    neb = NudgedElasticBand() if neb is None else neb
    if not isinstance(neb, NudgedElasticBand):
        raise ConfigError("neb", type(neb).__name__, "a NudgedElasticBand")
    za, zb = _as_state(model, z_start, "z_start"), _as_state(model, z_end, "z_end")
    first = _attempt(model, neb, za, zb, neb.loop_settings())
    if first.converged:
        return first
    for spring, max_step in neb.fallbacks:
        again = _attempt(model, neb, za, zb, neb.loop_settings(spring, max_step))
        if again.converged:
            return again
    return first


def _attempt(
    model: Model,
    neb: NudgedElasticBand,
    za: np.ndarray,
    zb: np.ndarray,
    settings: band_loop.BandSettings,
) -> MinimumEnergyPath:
    nq = model.n_coordinates
    t = np.linspace(0.0, 1.0, neb.n_images)[:, None]
    band0 = (1.0 - t) * za[None, :nq] + t * zb[None, :nq]
    system = model.system()
    q, energies, lams, lam_cs, fmax, climbing, its, _ = band_loop.fire_band(
        system.data, band0, settings
    )
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    top = int(np.argmax(energies[1:-1])) + 1 if climbing < 0 else int(climbing)
    band_ok = fmax < neb.tolerance and (climbing >= 0 or not neb.climbing)

    z_ci = model.pack(q[top], lams[top])
    z_ci = model.pack(q[top], lams[top], _contact_start(model, z_ci, lam_cs[top]))
    spacing = max(min(arc[top] - arc[top - 1], arc[top + 1] - arc[top]), 1e-9)
    # start from the least-squares multipliers, then (contact active sets of the band and of
    # the smoothed system can differ) from zero multipliers
    for z0 in (z_ci, model.pack(q[top])):
        z_s, code, rnorm, data = _refine(system, neb, z0)
        moved = float(np.linalg.norm(z_s[:nq] - q[top]))
        refined = code == Status.CONVERGED.value and moved <= spacing
        if refined:
            break
    if not refined:
        z_s = z_ci
        rnorm = float(np.max(np.abs(system.residual(z_ci))))
        data = system.state(z_ci)
    sol = make_solution(
        model,
        z_s,
        Load.of_force(0.0),
        Status.CONVERGED if refined else Status(code),
        rnorm,
        0,
        data,
    )
    eig = classify(model, sol).eigenvalues if refined else _eigenvalues(model, sol)
    n_neg = int(np.sum(eig < -NEGATIVE_TOL))
    e_s = sol.energy
    e_a, e_b = energies[0], energies[-1]

    if top in (0, len(q) - 1) or e_s <= max(e_a, e_b) - 1e-12:
        status, msg = MepStatus.NO_BARRIER, "the highest image is not above both end states"
    elif not band_ok:
        status = MepStatus.BAND_NOT_CONVERGED
        msg = f"band not converged after {its} iterations (max force {fmax:.2e} N)"
    elif not refined:
        status = MepStatus.SADDLE_NOT_REFINED
        msg = (
            f"Newton refinement of the climbing image ended {Status(code).name} at "
            f"{moved:.2e} from it (image spacing {spacing:.2e})"
        )
    elif n_neg != 1:
        status = MepStatus.NOT_FIRST_ORDER
        msg = f"the refined stationary point has {n_neg} negative reduced-Hessian eigenvalues"
    else:
        status, msg = MepStatus.CONVERGED, f"first-order saddle after {its} band iterations"
    return MinimumEnergyPath(
        q=q,
        energies=energies,
        arc_length=arc,
        saddle_index=top,
        saddle_z=z_s,
        saddle_energy=float(e_s),
        barrier_forward=float(e_s - e_a),
        barrier_backward=float(e_s - e_b),
        n_negative=n_neg,
        saddle_eigenvalues=eig,
        status=status,
        message=msg,
        iterations=int(its),
        max_force=float(fmax),
        saddle_residual=float(rnorm),
    )


def _eigenvalues(model: Model, sol: object) -> np.ndarray:
    """Reduced-Hessian eigenvalues of a state that need not be converged."""
    from biplan.analysis.stability import reduced_hessian

    h, n = reduced_hessian(model, sol)  # type: ignore[arg-type]
    return np.linalg.eigvalsh(h) if n.shape[1] else np.zeros(0)


def edge_barriers(
    model: Model,
    pairs: Iterable[tuple[object, object]],
    neb: NudgedElasticBand | None = None,
) -> list[MinimumEnergyPath]:
    """Minimum-energy paths of a list of (z_a, z_b) pairs (graph edges), in order.

    All pairs share the model's System (the band loop is compiled once for every tube).
    """
    neb = NudgedElasticBand() if neb is None else neb
    return [minimum_energy_path(model, za, zb, neb) for za, zb in pairs]
