"""The solves of the force-ramp design map (:mod:`biplan.analysis.maps.design_map`): the
quasi-static ramp of a batch of designs, and the pieces of its scalar reference.

Each design's ramp is one call of :func:`biplan.solvers.batch.ramp` on its compiled
:class:`~biplan.model.system.System` (compiled once per install; it releases the GIL, so the
chunks of a map run in parallel on threads): per load step up to :data:`CHORD_ITERATIONS`
chord iterations at the new force with the previous equilibrium's Jacobian
(:func:`biplan.solvers.batch.chord`), then the globalised Newton, and the stability read from
the Jacobian the Newton ends with. The scalar reference (:func:`point_solvers`) runs the same
chord start and Newton one load step at a time and observes each state afresh.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from biplan.model.assembly import Load, Model
from biplan.solvers import batch
from biplan.solvers.newton import Newton
from biplan.solvers.observation import Observation, observe

__all__ = ["CHORD_ITERATIONS", "point_solvers", "ramp_compiled"]

#: Most chord iterations (the previous equilibrium's Jacobian, residuals only) per load step.
CHORD_ITERATIONS = 8


def ramp_compiled(
    models: Sequence[Model], forces: np.ndarray, newton: Newton
) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """The ramp through ``forces`` [N] of every model, from q = 0:
    :func:`biplan.solvers.batch.ramp` on its compiled System, one call per design.

    Returns
    -------
    records : tuple of ndarray, each (len(models), len(forces))
        Per design and load step: converged, the failing status (−1 none), u_z, u_r [mm],
        the load-point displacement [mm] and λ_min of the reduced Hessian [N/mm] (NaN past
        a failed step).
    z_last : ndarray (len(models), n_z)
        The last converged packed state of each design.
    """
    s = newton.loop_settings()
    f = np.ascontiguousarray(forces, dtype=float)
    outs = []
    for m in models:
        z0 = np.asarray(m.pack(m.zeros()), dtype=float)
        weak = bool(m.options.weak_contacts_active)
        outs.append(batch.ramp(m.system().data, z0, f, s, CHORD_ITERATIONS, weak))
    z_last = np.stack([o[0] for o in outs])
    records = tuple(np.stack([o[k] for o in outs]) for k in range(1, 7))
    return records, z_last


def point_solvers(
    model: Model, atol: float
) -> tuple[
    Callable[[np.ndarray, Load], np.ndarray],
    Callable[[np.ndarray, np.ndarray, Load], np.ndarray],
    Callable[[np.ndarray, Load], Observation],
]:
    """The pieces of the design map's scalar reference for one design, on its compiled
    System: the KKT Jacobian ``jacobian(z, load)``, the chord start ``start(z, jac, load)``
    (:func:`biplan.solvers.batch.chord`, :data:`CHORD_ITERATIONS`, tolerance ``atol``) and the
    observation of the states ``observe(zs, loads)`` (a Load of (k,) arrays), which evaluates
    each Hessian afresh."""
    data = model.system().data

    def jacobian(z: np.ndarray, load: Load) -> np.ndarray:
        return np.asarray(model.system(load).jacobian(z))

    def start(z: np.ndarray, jac: np.ndarray, load: Load) -> np.ndarray:
        f = np.array([load.force, load.displacement, load.displacement_control], dtype=float)
        z = np.asarray(z, dtype=float)
        return np.asarray(batch.chord(data, z, np.asarray(jac, float), f, atol, CHORD_ITERATIONS))

    def observe_states(zs: np.ndarray, loads: Load) -> Observation:
        return observe(model, zs, loads)

    return jacobian, start, observe_states
