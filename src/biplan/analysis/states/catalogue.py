"""The result of a state enumeration: :class:`StateCatalogue` and its labelled forms.

``to_dataset()`` gives an ``xarray.Dataset`` (dims ``state``, ``coordinate``, ``fold``,
``seed``; ``attrs["kind"] = "states"``) that :mod:`biplan.plot.gallery` and the CLI read, and
``from_dataset(ds, model)`` the catalogue back (what ``biplan path --states`` reads);
``rows()`` gives one dict per state with the CSV columns
``name,label,bits,energy,u_z,u_r,theta,Theta,min_eigenvalue,n_open_helical,n_open_circular,seeds``.
"""

from __future__ import annotations

import enum
import functools
import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from biplan._errors import check_integer, check_range
from biplan.geometry import FoldRef
from biplan.model.assembly import Model
from biplan.solvers.newton import Newton
from biplan.solvers.observation import STABILITY_TOL

__all__ = [
    "CSV_COLUMNS",
    "STRAIGHT",
    "Enumeration",
    "Outcome",
    "SeedOutcome",
    "StableState",
    "StateCatalogue",
]

#: Columns of the CSV form, in order.
CSV_COLUMNS = (
    "name",
    "label",
    "bits",
    "energy",
    "u_z",
    "u_r",
    "theta",
    "Theta",
    "min_eigenvalue",
    "n_open_helical",
    "n_open_circular",
    "seeds",
)

#: End slopes |θ| at or below this [rad] count as straight: the contact smoothing (ε = 1e-6)
#: leaves closed folds open by O(ε) mm, which tilts the end of a tube whose open folds are all
#: circular by ~1e-7 rad. Normalising by such a max|θ| would turn rounding into Θ = ±1.
STRAIGHT = 1e-6


@dataclass(frozen=True)
class Enumeration:
    """Settings of the seeded relaxation.

    Parameters
    ----------
    penalty_stiffness : float
        k_p [N/mm] of the contact penalties of the descent (the final KKT solve is
        exact; k_p only sets how close the descent lands).
    max_iterations : int
        Most modified-Newton descent iterations per seed.
    newton : Newton
        Settings of the final KKT Newton solve (atol is the equilibrium tolerance).
    chunk : int
        Seeds per call of the compiled relaxation (a chunk is what a search streams to disk
        and what a Dask worker runs).
    threads : int
        Threads of the compiled relaxation and observation in this process (the seeds of a
        chunk run in parallel); 0 (default): one per core this process may run on. The
        states do not depend on it.
    duplicate_tolerance : float
        Two equilibria are the same state when max |Δq| is below this [mm, rad].
    stability_tolerance : float
        λ_min of the reduced Hessian above this [N·mm per unit q²] is stable.
    """

    penalty_stiffness: float = 1e4
    max_iterations: int = 300
    newton: Newton = field(default_factory=Newton)
    chunk: int = 128
    threads: int = 0
    duplicate_tolerance: float = 1e-5
    stability_tolerance: float = STABILITY_TOL

    def __post_init__(self) -> None:
        check_range("Enumeration.penalty_stiffness", self.penalty_stiffness, low=0.0)
        check_range("Enumeration.duplicate_tolerance", self.duplicate_tolerance, low=0.0)
        check_range("Enumeration.stability_tolerance", self.stability_tolerance, low=0.0)
        for name in ("max_iterations", "chunk"):
            v = check_integer(f"Enumeration.{name}", getattr(self, name), low=1)
            object.__setattr__(self, name, v)
        threads = check_integer("Enumeration.threads", self.threads, low=0)
        object.__setattr__(self, "threads", threads)


@dataclass(frozen=True)
class StableState:
    """A distinct stable equilibrium at zero end load.

    ``bits`` are the fold states (free end first,
    :func:`~biplan.analysis.states.labels.bistable_folds`),
    ``name`` is the label, made unique with a suffix (``1B.2``) when two distinct states share
    bits. Lengths in mm, θ in rad, energy in N·mm, eigenvalue in N·mm per unit q² (q in mm and rad).
    """

    name: str
    label: str
    bits: tuple[int, ...]
    q: np.ndarray
    z: np.ndarray
    energy: float
    u_z: float
    u_r: float
    theta: float
    min_eigenvalue: float
    phase_fraction: np.ndarray  # (N + Nc, 3): closed, spinodal, open
    seeds: tuple[str, ...]


class Outcome(enum.StrEnum):
    """What a seed relaxed to (the value is what files hold)."""

    STABLE = "stable"  #: a stable equilibrium; ``SeedOutcome.state`` names the state
    UNSTABLE = "unstable"  #: an equilibrium with λ_min ≤ tolerance
    FAILED = "failed"  #: no converged equilibrium; ``SeedOutcome.message`` says why


@dataclass(frozen=True)
class SeedOutcome:
    """What one seed relaxed to (:class:`Outcome`)."""

    seed: str
    seed_bits: tuple[int, ...]
    reached_bits: tuple[int, ...]
    outcome: Outcome
    state: str | None
    min_eigenvalue: float
    residual: float
    message: str

    def __post_init__(self) -> None:
        if not isinstance(self.outcome, Outcome):
            object.__setattr__(self, "outcome", Outcome(self.outcome))

    @property
    def matches_seed(self) -> bool:
        """Whether the equilibrium has the seed's own fold states."""
        return self.reached_bits == self.seed_bits


@dataclass(frozen=True)
class StateCatalogue:
    """Distinct stable states of a tube, every seed's outcome, and the rejected equilibria.

    Attributes
    ----------
    folds : tuple of FoldRef
        The bistable folds, free end first (the order of every ``bits``).
    states : tuple of StableState
    seeds : tuple of SeedOutcome
        One per seed, in seed order (seed bits counting up from 0…0).
    unstable_z : ndarray (k, n_z)
        Distinct converged equilibria rejected as not stable.
    unstable_eigenvalues : ndarray (k,)
        Their smallest reduced-Hessian eigenvalues [N·mm per unit q²] (≤ the stability tolerance).
    elapsed : float
        Wall time [s] of the enumeration.
    """

    model: Model
    folds: tuple[FoldRef, ...]
    states: tuple[StableState, ...]
    seeds: tuple[SeedOutcome, ...]
    unstable_z: np.ndarray
    unstable_eigenvalues: np.ndarray
    settings: Enumeration
    elapsed: float

    def __len__(self) -> int:
        return len(self.states)

    @property
    def names(self) -> tuple[str, ...]:
        """Unique state names (the label, suffixed ``.2``… for repeated bits)."""
        return tuple(s.name for s in self.states)

    def state(self, name: str) -> StableState:
        """The state of a name (or label)."""
        for s in self.states:
            if name in (s.name, s.label):
                return s
        from biplan._errors import ConfigError

        raise ConfigError("state", name, f"one of {', '.join(self.names)}")

    @functools.cached_property
    def max_abs_theta(self) -> float:
        """max |θ| [rad] over the stable states: the normaliser of Θ."""
        theta = np.abs([s.theta for s in self.states])
        return float(theta.max()) if theta.size else 0.0

    def slope(self, state: StableState) -> float:
        """Θ = θ / max|θ| (0 when every state is straight: max|θ| ≤ :data:`STRAIGHT`)."""
        m = self.max_abs_theta
        return state.theta / m if m > STRAIGHT else 0.0

    def open_counts(self, state: StableState) -> tuple[int, int]:
        """(open helical, open circular) folds of a state."""
        hel = sum(b for b, f in zip(state.bits, self.folds, strict=True) if f.set == "helical")
        return hel, sum(state.bits) - hel

    @property
    def mismatched_seeds(self) -> tuple[SeedOutcome, ...]:
        """Seeds that relaxed to a stable state other than their own bits."""
        return tuple(s for s in self.seeds if s.outcome is Outcome.STABLE and not s.matches_seed)

    def rows(self) -> list[dict[str, Any]]:
        """One dict per state with the :data:`CSV_COLUMNS` (new dicts at every call; built
        once per catalogue)."""
        return [dict(r) for r in self._rows]

    @functools.cached_property
    def _rows(self) -> tuple[dict[str, Any], ...]:
        out = []
        for s in self.states:
            hel, circ = self.open_counts(s)
            out.append(
                {
                    "name": s.name,
                    "label": s.label,
                    "bits": "".join(map(str, s.bits)),
                    "energy": s.energy,
                    "u_z": s.u_z,
                    "u_r": s.u_r,
                    "theta": s.theta,
                    "Theta": self.slope(s),
                    "min_eigenvalue": s.min_eigenvalue,
                    "n_open_helical": hel,
                    "n_open_circular": circ,
                    "seeds": " ".join(s.seeds),
                }
            )
        return tuple(out)

    def to_dataset(self, seeds: bool = True) -> Any:
        """The catalogue as an ``xarray.Dataset`` (``attrs["kind"] = "states"``); without
        ``seeds``, only the states (no ``seed`` dimension and no ``seed_*`` variables)."""
        import xarray as xr

        n_q = self.model.layout.n_coordinates
        n_z = self.unstable_z.shape[1] if self.unstable_z.ndim == 2 else n_q
        rows = self.rows()
        names = [r["name"] for r in rows]
        data: dict[str, Any] = {
            key: (("state",), np.asarray([r[key] for r in rows]))
            for key in CSV_COLUMNS
            if key != "name"
        }
        data["q"] = (
            ("state", "coordinate"),
            np.asarray([s.q for s in self.states]).reshape(-1, n_q),
        )
        data["z"] = (("state", "packed"), np.asarray([s.z for s in self.states]).reshape(-1, n_z))
        data["phase_fraction"] = (  # every fold, named as in the result files
            ("state", "fold", "phase"),
            np.asarray([s.phase_fraction for s in self.states]).reshape(len(rows), -1, 3),
        )
        coords: dict[str, Any] = {"state": names}
        if seeds:
            data["seed_outcome"] = (("seed",), np.asarray([s.outcome.value for s in self.seeds]))
            data["seed_state"] = (("seed",), np.asarray([s.state or "" for s in self.seeds]))
            data["seed_reached"] = (
                ("seed",),
                np.asarray(["".join(map(str, s.reached_bits)) for s in self.seeds]),
            )
            data["seed_min_eigenvalue"] = (
                ("seed",),
                np.asarray([s.min_eigenvalue for s in self.seeds]),
            )
            coords["seed"] = [s.seed for s in self.seeds]
        coords["fold"] = list(self.model.layout.fold_names)
        coords["phase"] = ["closed", "spinodal", "open"]
        ds = xr.Dataset(data, coords=coords)
        units = {
            "energy": "N mm",
            "u_z": "mm",
            "u_r": "mm",
            "theta": "rad",
            "min_eigenvalue": "N mm",
        }
        for key, unit in units.items():
            ds[key].attrs["units"] = unit
        ds.attrs.update(
            kind="states",
            folds=json.dumps([[f.set, f.index] for f in self.folds]),
            bit_folds=", ".join(self.model.layout.fold_name(f) for f in self.folds),
            initial_length=self.model.tube.initial_length,
            n_seeds=len(self.seeds),
            n_stable=len(self.states),
            n_unstable_equilibria=len(self.unstable_eigenvalues),
            n_failed_seeds=sum(s.outcome is Outcome.FAILED for s in self.seeds),
            n_mismatched_seeds=len(self.mismatched_seeds),
            elapsed_s=self.elapsed,
        )
        return ds

    @classmethod
    def from_dataset(cls, ds: Any, model: Model) -> StateCatalogue:
        """The catalogue of a dataset written by :meth:`to_dataset` (a ``states.nc`` file),
        for the model of its tube.

        The states (coordinates, energies, endpoints, eigenvalues, phase fractions, seeds) and
        every seed's outcome come back; what the file does not hold stays empty: the rejected
        unstable equilibria, and each seed's residual (NaN) and failure message. The caller
        checks that ``model`` is the catalogue's tube (:mod:`biplan.io.catalogue`).
        """
        from biplan.analysis.states.labels import label_to_bits

        folds = tuple(FoldRef(str(s), int(i)) for s, i in json.loads(ds.attrs["folds"]))
        n_bits = len(folds)

        def bits(text: Any) -> tuple[int, ...]:
            return tuple(int(c) for c in str(text))

        def column(name: str) -> np.ndarray:
            return np.asarray(ds[name].values)

        states = tuple(
            StableState(
                name=str(name),
                label=str(column("label")[k]),
                bits=bits(column("bits")[k]),
                q=np.asarray(column("q")[k], dtype=float),
                z=np.asarray(column("z")[k], dtype=float),
                energy=float(column("energy")[k]),
                u_z=float(column("u_z")[k]),
                u_r=float(column("u_r")[k]),
                theta=float(column("theta")[k]),
                min_eigenvalue=float(column("min_eigenvalue")[k]),
                phase_fraction=np.asarray(column("phase_fraction")[k], dtype=float),
                seeds=tuple(str(column("seeds")[k]).split()),
            )
            for k, name in enumerate(column("state"))
        )
        seeds = tuple(
            SeedOutcome(
                seed=str(seed),
                seed_bits=label_to_bits(str(seed), n_bits),
                reached_bits=bits(column("seed_reached")[k]),
                outcome=Outcome(str(column("seed_outcome")[k])),
                state=str(column("seed_state")[k]) or None,
                min_eigenvalue=float(column("seed_min_eigenvalue")[k]),
                residual=float("nan"),
                message="",
            )
            for k, seed in enumerate(column("seed"))
        )
        n_z = states[0].z.size if states else model.layout.n_coordinates
        return cls(
            model=model,
            folds=folds,
            states=states,
            seeds=seeds,
            unstable_z=np.zeros((0, n_z)),
            unstable_eigenvalues=np.zeros(0),
            settings=Enumeration(),
            elapsed=float(ds.attrs.get("elapsed_s", 0.0)),
        )
