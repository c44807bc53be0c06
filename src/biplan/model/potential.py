"""The terms of the BiPlan Lagrangian as functions of the coordinates q (main Eq.
mft_energy_assembly; MODEL §4–7).

Pure functions of (layout, params, q), traceable by JAX:

* :func:`energy` Π(q) and :func:`fold_energies`, the exact field energy of every helical
  field and every connector field;
* :func:`guide_values` g(q), the guides (2 per module);
* :func:`contact_gaps` w_∂(q), the contact gaps (helical ends, connector field ends; MODEL C1);
* :func:`load_height` z_p(q), the axial displacement of the load point (MODEL W1);
* :func:`phase_fractions` and :func:`fold_openings`, per-fold readings of the same kinematics.

The Lagrangian, the KKT residual and the Jacobian built from them are in
:mod:`biplan.model.lagrangian`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from biplan._compile.setup import jax, jnp, lazy_jit
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.laws import _jax as law_jax
from biplan.model import elements
from biplan.model.params import ModelParams
from biplan.options import ContactForm

__all__ = [
    "contact_gaps",
    "energy",
    "fold_energies",
    "fold_openings",
    "guide_values",
    "load_height",
    "phase_fractions",
]

Array = Any


def _coeffs(row: Array) -> law_jax.Coefficients:
    return (row[0], row[1], row[2], row[3], row[4])


@lazy_jit(static_argnums=0)
def _kin(layout: TubeLayout, p: ModelParams, q: Array) -> chain.Kinematics:
    """The chain kinematics (MODEL §4–7), a nested ``jit``: a kernel calls it many times
    (energy, guides, gaps, load point, each under grad/Hessian/jacfwd/vmap), and JAX traces a
    nested ``jit`` once per argument shape and reuses its jaxpr, where a plain function is
    traced again at every call (with :func:`_energies` and :func:`_gaps` also nested, the
    batched relaxation kernel traces in 2.7–3.2 s instead of 12.8–16.8 s; XLA inlines the
    calls, so the compiled kernels do the same arithmetic)."""
    return chain.kinematics(layout, p.geometry, q)


@lazy_jit(static_argnums=0)
def _energies(layout: TubeLayout, p: ModelParams, kin: chain.Kinematics) -> tuple[Array, Array]:
    """Helical and circular fold energies of given kinematics (a nested ``jit``, as
    :func:`_kin`)."""
    w = kin.helical
    helical = law_jax.field_energy(w[:, 0], w[:, 1], kin.helical_length, _coeffs(p.helical.T))
    if layout.n_connectors == 0:
        return helical, jnp.zeros((0,))
    t = chain.tables(layout)
    per_field = law_jax.field_energy(
        kin.field_start, kin.field_end, kin.field_length, _coeffs(p.circular[t.field_conn].T)
    )
    circ = jax.ops.segment_sum(per_field, t.field_conn, num_segments=layout.n_connectors)
    return helical, circ


def fold_energies(layout: TubeLayout, p: ModelParams, q: Array) -> tuple[Array, Array]:
    """Strain energy [N·mm] of every helical fold (N,) and every circular fold (Nc,)."""
    return _energies(layout, p, _kin(layout, p, q))


def phase_fractions(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    """Fraction of each fold's length on the closed, spinodal and open branch of its law,
    (N + Nc, 3), helical folds then circular (length-weighted over a connector's fields)."""
    kin = _kin(layout, p, q)
    w = kin.helical
    hel = law_jax.phase_fractions(w[:, 0], w[:, 1], _coeffs(p.helical.T))
    if layout.n_connectors == 0:
        return hel
    t = chain.tables(layout)
    per = law_jax.phase_fractions(
        kin.field_start, kin.field_end, _coeffs(p.circular[t.field_conn].T)
    )
    length = kin.field_length
    num = jax.ops.segment_sum(per * length[:, None], t.field_conn, layout.n_connectors)
    den = jax.ops.segment_sum(length, t.field_conn, layout.n_connectors)
    return jnp.concatenate([hel, num / den[:, None]], axis=0)


def fold_openings(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    """Length-mean elongation w̄ [mm] of every fold, (N + Nc,), helical folds then circular
    (length-weighted over a connector's fields). Used to seed fold states (MODEL §15)."""
    kin = _kin(layout, p, q)
    hel = 0.5 * (kin.helical[:, 0] + kin.helical[:, 1])
    if layout.n_connectors == 0:
        return hel
    t = chain.tables(layout)
    length = kin.field_length
    mean = 0.5 * (kin.field_start + kin.field_end) * length
    num = jax.ops.segment_sum(mean, t.field_conn, layout.n_connectors)
    den = jax.ops.segment_sum(length, t.field_conn, layout.n_connectors)
    return jnp.concatenate([hel, num / den])


def energy(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    """Total strain energy Π(q) [N·mm] (main Eq. mft_energy_assembly)."""
    helical, circ = fold_energies(layout, p, q)
    return helical.sum() + circ.sum()


def guide_values(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    """Guide constraints g(q) [mm], (2N,) (SI Eq. 11)."""
    return _kin(layout, p, q).guides


@lazy_jit(static_argnums=0)
def _gaps(layout: TubeLayout, p: ModelParams, kin: chain.Kinematics) -> Array:
    """Contact gaps of given kinematics (a nested ``jit``, as :func:`_kin`)."""
    gaps = [kin.helical.reshape(-1)]
    if layout.n_connectors:
        t = chain.tables(layout)
        pts = kin.point_w[t.contact_pt]
        if layout.options.contact is ContactForm.MINIMUM:
            tau = p.smooth_min_width
            for c in range(layout.n_connectors):
                sel = pts[np.flatnonzero(t.contact_conn == c)]
                gaps.append((-tau * jax.nn.logsumexp(-sel / tau))[None])
        else:
            gaps.append(pts)
    return jnp.concatenate(gaps)


def contact_gaps(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    """Contact gaps w_∂(q) [mm]: helical (w0, wa) per module, then connector points (MODEL C1)."""
    return _gaps(layout, p, _kin(layout, p, q))


def load_height(layout: TubeLayout, p: ModelParams, q: Array) -> Array:
    """Axial displacement z_p(q) [mm] of the load point (MODEL CHOICE W1), as the assembly
    computes it (:func:`biplan.model.elements.load_point_height`)."""
    return elements.load_point_height(layout, p.geometry, q)
