"""The fixed starts of the equilibrium search of the stability map
(:mod:`biplan.analysis.maps.stability_map`).

:func:`seeds` gives the packed starting vectors at a prescribed load-point displacement u [mm]:
one per subset of the circular folds (or the older fold patterns), each with the displacement
shared equally by its open folds, and a *pressed* copy (contact multipliers :data:`PRESS` on
the closed contacts) where the open folds push. :func:`pushing` evaluates the laws for that
test. :func:`reference_path_starts` is the start of last resort: the state that the
stable-branch sweep from the relaxed reference reaches.
"""

from __future__ import annotations

import enum
import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from biplan.analysis.response.quasistatic import displacement_sweep
from biplan.model.assembly import Model
from biplan.model.system import assemble
from biplan.model.tube import Tube
from biplan.solvers.newton import relaxed_reference
from biplan.solvers.observation import ACTIVE_GAP

__all__ = [
    "PRESS",
    "REFERENCE_STEP",
    "REFERENCE_STEPS",
    "Seeding",
    "pushing",
    "reference_path_starts",
    "seeds",
]

#: Contact multiplier [N/mm] of the closed contacts of a "pressed" seed (:func:`seeds`).
PRESS = 1e-3


class Seeding(enum.StrEnum):
    """The fixed seeds of :class:`StabilitySearch`
    (:func:`~biplan.analysis.maps.stability_seeds.seeds`)."""

    SUBSETS = "subsets"  #: one per subset of the circular folds (2^N_c)
    PATTERNS = "patterns"  #: the 3 N_c − 2 patterns next to the base or the free end


#: Largest ``StabilitySearch.max_subset_folds``: 2^12 = 4096 seeds per seeded point.
MAX_SUBSET_FOLDS = 12


def _line_force(coefficients: Any, w: np.ndarray) -> np.ndarray:
    """Line force F(w) [N/mm] of a fold law (k1, k2, k3, w1, w2) at openings w [mm]: the
    NumPy form of :meth:`biplan.laws.FoldLaw.force` (same arithmetic, no JAX)."""
    k1, k2, k3, w1, w2 = (float(c) for c in coefficients)
    f1 = k1 * w1
    f2 = f1 + k2 * (w2 - w1)
    return np.where(w < w1, k1 * w, np.where(w < w2, f1 + k2 * (w - w1), f2 + k3 * (w - w2)))


def pushing(tube: Tube, u: np.ndarray) -> np.ndarray:
    """(len(u), N_c, N_c) booleans: whether circular fold i pushes (law force < 0) when k + 1
    folds share the displacement u [mm] equally (opening u / (k + 1)); one law evaluation
    per distinct law."""
    u = np.asarray(u, dtype=float).reshape(-1)
    n_circ = tube.n_circular
    ws = u[:, None] / np.arange(1, n_circ + 1)[None, :]
    forces: dict[Any, np.ndarray] = {}
    for law in tube.circular_laws:
        if law not in forces:
            forces[law] = _line_force(law.coefficients, ws) < 0.0
    return np.stack([forces[law] for law in tube.circular_laws], axis=1)


def seeds(
    model: Model,
    u: float,
    kind: Seeding = Seeding.SUBSETS,
    pressed_only: bool = False,
    pushes: np.ndarray | None = None,
) -> np.ndarray:
    """Packed starting vectors (n_seeds, n_z) for prescribed displacement ``u`` [mm].

    ``kind`` "subsets": one start per subset of the circular folds (2^N_c, all folds closed
    first), the displacement shared equally by the open folds of the subset — the fold states
    of the tube's phase-1/phase-2 combinations, every one of which can be a stable
    equilibrium (the circular folds are in series and nearly equivalent; docs/maps.md).
    "patterns": the 3 N_c − 2 patterns of earlier versions (all closed, shared by all, one
    per fold, the k lowest and the k highest folds), which miss most combinations of two or
    more open folds.

    A start whose open folds all *push* (law force < 0 at their opening: between a
    bistable law's unloaded open opening and its second zero) is added a second time,
    *pressed*: with multiplier :data:`PRESS` on every closed contact. Such a state can be an
    equilibrium held by the contacts alone — the tube in compression, every other fold pressed
    shut, no free direction left (a contact-locked state, stable by MODEL.md §12). Newton from
    zero multipliers treats a closed gap and its multiplier alike and opens the gaps, so it
    leaves such states; from the pressed start it keeps the gaps shut and finds the
    multipliers (docs/maps.md, "contact-locked states"). ``pressed_only``: only these
    (possibly none: shape (0, n_z)). ``pushes``: :func:`pushing` of this ``u`` (computed
    when not given). The contact gaps come from the model's compiled System
    (:meth:`Model.system`).
    """
    nq = model.n_coordinates
    n_circ = model.tube.n_circular
    first = nq - n_circ
    patterns: list[np.ndarray]
    if kind == Seeding.SUBSETS:
        patterns = [
            np.isin(np.arange(n_circ), c).astype(float)
            for k in range(n_circ + 1)
            for c in itertools.combinations(range(n_circ), k)
        ]
    else:
        patterns = [np.zeros(n_circ), np.ones(n_circ)]
        patterns += [np.eye(n_circ)[i] for i in range(n_circ)]
        for k in range(2, n_circ):
            patterns += [np.r_[np.ones(k), np.zeros(n_circ - k)]]
            patterns += [np.r_[np.zeros(n_circ - k), np.ones(k)]]
    if pushes is None:
        pushes = pushing(model.tube, np.array([u]))[0]
    lam_c = slice(nq + model.n_guides, nq + model.n_guides + model.n_contacts)
    n_z = lam_c.stop + 1
    plain, pressed = [], []
    for pat in patterns:
        k = int(pat.sum())
        push = k > 0 and bool(pushes[pat > 0, k - 1].all())
        if pressed_only and not push:
            continue
        z = np.zeros(n_z)
        if k > 0:
            z[first:nq] = pat * u / k
        plain.append(z)
        if push:
            zp = z.copy()
            gaps = assemble.observe(model.system().data, z)[4]
            zp[lam_c] = np.where(gaps < ACTIVE_GAP, PRESS, 0.0)
            pressed.append(zp)
    out = pressed if pressed_only else plain + pressed
    return np.asarray(out).reshape(-1, n_z)


#: Largest step [mm] of :func:`reference_path_starts`'s sweep (that of ``biplan respond
#: --control displacement``), and most steps (longer steps beyond 2 mm): a sweep whose steps
#: all fail (a tube that cannot be pulled) costs up to a few seconds a point, not minutes.
REFERENCE_STEP = 0.05
REFERENCE_STEPS = 40


def reference_path_starts(model: Model, us: Sequence[float]) -> list[np.ndarray]:
    """The packed state (n_z,) that the stable-branch sweep from the relaxed reference reaches
    at each displacement of ``us`` [mm]: one
    :func:`~biplan.analysis.response.quasistatic.displacement_sweep` per sign of u, through
    every u asked for, in steps of at most :data:`REFERENCE_STEP` and at most
    :data:`REFERENCE_STEPS` of them besides; at each u the last state it converged to (the
    reference at u = 0, or before any step converged). A start for the points where no fixed
    seed's Newton bridges the jump from the unloaded tube to u: that sweep leaves the
    symmetric state of identical folds in series for the stable branch past their peak,
    which neither a fixed seed nor the arclength path reaches."""
    ref = relaxed_reference(model)
    reached: dict[float, np.ndarray] = {}
    for sign in (1.0, -1.0):
        wanted = sorted({abs(float(u)) for u in us if u * sign > 0})
        if not wanted:
            continue
        top = wanted[-1]
        n = min(max(1, int(np.ceil(top / REFERENCE_STEP))), REFERENCE_STEPS)
        targets = np.union1d(np.linspace(top / n, top, n), wanted) * sign
        sweep = displacement_sweep(model, targets, start=ref)
        last = ref.z
        for target, sol in zip(targets, sweep.solutions, strict=True):
            last = sol.z if sol.converged else last
            reached[float(target)] = last
    return [np.asarray(reached.get(float(u), ref.z), dtype=float) for u in us]
