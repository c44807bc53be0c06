"""Result datasets of the file contract (path, trajectory, state catalogue), built from states.

The plotting and export tests do not depend on the path-following solvers: they build the
datasets the solvers write (dims, variables, attributes of ``biplan.io.results``) from a few
configurations q and the model's own observables.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

import biplan
from biplan.io.config import dump_config

PHASES = ["closed", "spinodal", "open"]


def fold_names(model: biplan.Model) -> list[str]:
    names = [f"helical {i + 1}" for i in range(model.layout.n_modules)]
    for c in model.layout.connectors:
        names.append(f"circular {0 if c.lower is None else c.lower + 1}|{c.upper + 1}")
    return names


def _phase_fractions(model: biplan.Model, q: np.ndarray) -> np.ndarray:
    rows = [
        law.phase_fractions(w0, wa)
        for law, (w0, wa) in zip(model.tube.helical_laws, model.helical_boundary(q), strict=True)
    ]
    for law, (w0, w1, length) in zip(
        model.tube.circular_laws, model.circular_fields(q), strict=True
    ):
        frac = np.atleast_2d(law.phase_fractions(w0, w1))
        rows.append((frac * length[:, None]).sum(axis=0) / length.sum())
    return np.asarray(rows, dtype=float)


def result_dataset(
    model: biplan.Model, qs: np.ndarray, force: np.ndarray, *, times: np.ndarray | None = None
) -> xr.Dataset:
    """A path (``times`` None) or trajectory dataset of the states ``qs`` under ``force``."""
    qs, force = np.asarray(qs, dtype=float), np.asarray(force, dtype=float)
    dim = "step" if times is None else "time"
    u = np.array([model.load_displacement(q) for q in qs])
    ends = [model.endpoint(q) for q in qs]
    fold_energy = np.array([np.concatenate(model.fold_energies(q)) for q in qs])
    n_h = model.layout.n_modules
    slope = np.gradient(force, u) if len(qs) > 1 else np.ones(1)
    data = {
        "force": ((dim,), force, {"units": "N"}),
        "displacement": ((dim,), u, {"units": "mm"}),
        "u_z": ((dim,), [e.u_z for e in ends], {"units": "mm"}),
        "u_r": ((dim,), [e.u_r for e in ends], {"units": "mm"}),
        "theta": ((dim,), [e.theta for e in ends], {"units": "rad"}),
        "energy": ((dim,), fold_energy.sum(axis=1), {"units": "N mm"}),
        "helical_energy": ((dim,), fold_energy[:, :n_h].sum(axis=1), {"units": "N mm"}),
        "circular_energy": ((dim,), fold_energy[:, n_h:].sum(axis=1), {"units": "N mm"}),
        "fold_energy": ((dim, "fold"), fold_energy, {"units": "N mm"}),
        "phase_fraction": ((dim, "fold", "phase"), [_phase_fractions(model, q) for q in qs]),
        "min_eigenvalue": ((dim,), slope, {"units": "N mm"}),
        "stable": ((dim,), (slope > 0).astype(np.int8)),
        "q": ((dim, "coordinate"), qs),
    }
    coords = {
        "fold": fold_names(model),
        "phase": PHASES,
        "coordinate": np.arange(model.n_coordinates),
    }
    if times is None:
        coords["step"] = np.arange(len(qs))
        peak = np.r_[False, (force[1:-1] > force[:-2]) & (force[1:-1] > force[2:]), False]
        data["limit_point"] = ((dim,), peak.astype(np.int8))
    else:
        coords["time"] = ("time", np.asarray(times, dtype=float), {"units": "s"})
        kinetic = 0.05 * np.abs(np.gradient(u))
        data["kinetic_energy"] = ((dim,), kinetic, {"units": "N mm"})
        total = data["energy"][1] + kinetic - force * u
        data["total_energy"] = ((dim,), total, {"units": "N mm"})
    attrs = {
        "kind": "path" if times is None else "trajectory",
        "config": dump_config(model.tube),
        "control": "displacement",
        "initial_length": model.tube.initial_length,
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def states_dataset(model: biplan.Model, qs: np.ndarray, labels: list[str]) -> xr.Dataset:
    """A state catalogue of the states ``qs`` labelled by hex codes."""
    qs = np.asarray(qs, dtype=float)
    ends = [model.endpoint(q) for q in qs]
    theta = np.array([e.theta for e in ends])
    return xr.Dataset(
        {
            "q": (("state", "coordinate"), qs),
            "label": (("state",), labels),
            "u_z": (("state",), [e.u_z for e in ends], {"units": "mm"}),
            "u_r": (("state",), [e.u_r for e in ends], {"units": "mm"}),
            "Theta": (("state",), theta / max(np.abs(theta).max(), 1e-12)),
            "energy": (("state",), [model.energy(q) for q in qs], {"units": "N mm"}),
        },
        coords={"coordinate": np.arange(model.n_coordinates)},
        attrs={"kind": "states", "config": dump_config(model.tube)},
    )
