"""Assembly of the constrained BiPlan potential of a tube (main Eqs. aug, mft_energy_assembly).

One JAX Lagrangian, written once::

    L(q, λ, λ_∂, μ) = Π(q) − F z_p(q) + λᵀ g(q) − λ_∂ᵀ w_∂(q) + μ d (z_p(q) − U)
                      [+ ½κ‖q − q_a‖², an optional proximal bias, κ = 0 by default]

Π sums the exact field energies of every helical field and every connector field; g are the
guides (2 per module); w_∂ the contact gaps (helical ends, connector field ends; MODEL C1);
z_p the axial displacement of the load point (MODEL W1); d ∈ {0, 1} switches displacement
control on. The equilibrium residual (MODEL §11) is::

    r = [∇_q L,  g(q),  φ_SFB(w_∂(q), λ_∂),  d (z_p − U) + (1 − d) μ]

with φ_SFB(w, λ) = √(w² + λ² + ε²) − (w + λ) (SI Eq. sfb). The residual, the KKT Jacobian and
the Hessians are assembled from per-element autodiff (:mod:`biplan.model.elements`; the whole-tube
autodiff of L is the test oracle, :mod:`biplan.model.oracle`); each kernel is ``jit``-compiled once
per tube *layout*
(:class:`~biplan.geometry.TubeLayout`), with geometry and law numbers passed as traced
parameters, so sweeping R, l, β or law coefficients never recompiles.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from biplan._compile.kernel import Kernel
from biplan._compile.setup import jax, jnp
from biplan._errors import ConfigError, check_finite, check_range
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.laws import _kernels as law_kernels
from biplan.model import elements
from biplan.model.tube import Tube
from biplan.options import ContactForm, ModelOptions

__all__ = [
    "AT_REST",
    "Load",
    "Model",
    "ModelParams",
    "StateData",
    "TubeLayout",
    "curvature",
    "fold_openings",
    "guide_values",
    "kernels",
    "kkt_jacobian",
    "kkt_jacobian_at_rest",
    "kkt_matrix",
    "phase_fractions",
    "residual",
    "residual_at_rest",
    "sizes",
    "state_data",
    "state_from_jacobian",
]

Array = Any


class ModelParams(NamedTuple):
    """Traced parameters of a model (a JAX pytree)."""

    geometry: chain.GeometryParams
    helical: Array  # (N, 5) law coefficients (k1, k2, k3, w1, w2)
    circular: Array  # (Nc, 5)
    smoothing: Array  # ε of the SFB function
    compliance: Array  # c [mm/N] of the contact rows φ_ε(w + c λ, λ)
    smooth_min_width: Array  # τ of ContactForm.MINIMUM
    bias_anchor: Array  # (n_q,) anchor q_a of the optional proximal bias ½κ‖q − q_a‖²
    bias_stiffness: Array  # κ ≥ 0 (0: no bias)


class Load(NamedTuple):
    """External loading: end force F [N], or prescribed load-point displacement U [mm].

    Use :meth:`force` or :meth:`displacement` to build one.
    """

    force: Array
    displacement: Array
    displacement_control: Array  # 0.0 or 1.0

    @staticmethod
    def of_force(force: float) -> Load:
        """Dead axial end force F [N] (force control)."""
        return Load(check_finite("force", force), 0.0, 0.0)

    @staticmethod
    def of_displacement(displacement: float) -> Load:
        """Prescribed axial displacement U [mm] of the load point (displacement control)."""
        return Load(0.0, check_finite("displacement", displacement), 1.0)

    @staticmethod
    def of_pressure(pressure: float, radius: float) -> Load:
        """Internal pressure p [MPa = N/mm²] on a closed tube: end force p π R² [N].

        Raises :class:`~biplan.ConfigError` unless p is finite and the radius R [mm] > 0.
        """
        p = check_finite("pressure", pressure)
        r = check_range("radius", radius, low=0.0, unit="mm")
        return Load(p * np.pi * r**2, 0.0, 0.0)

    @property
    def is_displacement_controlled(self) -> bool:
        return bool(float(self.displacement_control) > 0.5)

    def for_kernel(self) -> Load:
        """The form every compiled kernel is called with: weakly typed JAX scalars, whatever
        the caller passed (Python or NumPy floats; arrays are passed on). One input type per
        kernel, so no kernel is traced and compiled once per scalar type."""
        return Load(*(jnp.asarray(float(v)) if np.ndim(v) == 0 else jnp.asarray(v) for v in self))


def _law_rows(laws: tuple) -> Array:  # type: ignore[type-arg]
    if not laws:
        return jnp.zeros((0, 5))
    return jnp.asarray([law.coefficients for law in laws], dtype=jnp.float64)


def _coeffs(row: Array) -> law_kernels.Coefficients:
    return (row[0], row[1], row[2], row[3], row[4])


def sfb(w: Array, lam: Array, eps: Array) -> Array:
    """Smoothed Fischer–Burmeister function (SI Eq. sfb)."""
    return jnp.sqrt(w**2 + lam**2 + eps**2) - (w + lam)


# --- pure functions of (layout, params, q) -------------------------------------------------
@functools.partial(jax.jit, static_argnums=0)
def _kin(layout: TubeLayout, p: ModelParams, q: Array) -> chain.Kinematics:
    """The chain kinematics (MODEL §4–7), a nested ``jit``: a kernel calls it many times
    (energy, guides, gaps, load point, each under grad/Hessian/jacfwd/vmap), and JAX traces a
    nested ``jit`` once per argument shape and reuses its jaxpr, where a plain function is
    traced again at every call (with :func:`_energies` and :func:`_gaps` also nested, the
    batched relaxation kernel traces in 2.7–3.2 s instead of 12.8–16.8 s; XLA inlines the
    calls, so the compiled kernels do the same arithmetic)."""
    return chain.kinematics(layout, p.geometry, q)


@functools.partial(jax.jit, static_argnums=0)
def _energies(layout: TubeLayout, p: ModelParams, kin: chain.Kinematics) -> tuple[Array, Array]:
    """Helical and circular fold energies of given kinematics (a nested ``jit``, as
    :func:`_kin`)."""
    w = kin.helical
    helical = law_kernels.field_energy(w[:, 0], w[:, 1], kin.helical_length, _coeffs(p.helical.T))
    if layout.n_connectors == 0:
        return helical, jnp.zeros((0,))
    t = chain.tables(layout)
    per_field = law_kernels.field_energy(
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
    hel = law_kernels.phase_fractions(w[:, 0], w[:, 1], _coeffs(p.helical.T))
    if layout.n_connectors == 0:
        return hel
    t = chain.tables(layout)
    per = law_kernels.phase_fractions(
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


@functools.partial(jax.jit, static_argnums=0)
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


def _terms(
    layout: TubeLayout,
    p: ModelParams,
    z: Array,
    load: Load,
    second_order: bool,
    loaded: bool = True,
) -> tuple[elements.LocalTerms, elements.ChainTerms, Array, Array]:
    """Local and chain terms at z, the ∇z_p coefficient μd − F, and the bias-free q
    (``loaded=False``: the load is :data:`AT_REST`, whose chain terms are zeros)."""
    q, lam, lam_c, mu = _split(layout, z)
    local = elements.local_terms(layout, p, q, lam, lam_c, second_order)
    if loaded:
        chain_part = elements.chain_terms(layout, p.geometry, q, second_order)
    else:
        nq = q.shape[0]
        zero_h = jnp.zeros((nq, nq)) if second_order else None
        chain_part = elements.ChainTerms(jnp.zeros(()), jnp.zeros(nq), zero_h)
    return local, chain_part, mu * load.displacement_control - load.force, q


def _lagrangian_gradient(
    p: ModelParams,
    local: elements.LocalTerms,
    chain_part: elements.ChainTerms,
    coef: Array,
    q: Array,
) -> Array:
    return local.gradient + coef * chain_part.gradient + p.bias_stiffness * (q - p.bias_anchor)


def _lagrangian_hessian(
    p: ModelParams, local: elements.LocalTerms, chain_part: elements.ChainTerms, coef: Array
) -> Array:
    nq = local.gradient.shape[0]
    return local.hessian + coef * chain_part.hessian + p.bias_stiffness * jnp.eye(nq)


def residual(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Array:
    """KKT residual r(z) (MODEL §11) for z = [q, λ, λ_∂, μ], assembled over the elements."""
    return _residual(layout, p, z, load, loaded=True)


#: Zero end force under force control: the load of a tube at rest (state searches).
AT_REST = Load(0.0, 0.0, 0.0)


def residual_at_rest(layout: TubeLayout, p: ModelParams, z: Array) -> Array:
    """:func:`residual` at :data:`AT_REST`. There the load point's terms vanish
    ((μd − F) ∇z_p = 0 and the last row is μ), so they are not evaluated."""
    return _residual(layout, p, z, AT_REST.for_kernel(), loaded=False)


def kkt_jacobian_at_rest(layout: TubeLayout, p: ModelParams, z: Array) -> Array:
    """:func:`kkt_jacobian` at :data:`AT_REST`, without the load point's terms (as
    :func:`residual_at_rest`)."""
    return _kkt_jacobian(layout, p, z, AT_REST.for_kernel(), loaded=False)


def _residual(layout: TubeLayout, p: ModelParams, z: Array, load: Load, loaded: bool) -> Array:
    local, chain_part, coef, q = _terms(layout, p, z, load, False, loaded)
    _, _, lam_c, mu = _split(layout, z)
    d = load.displacement_control
    return jnp.concatenate(
        [
            _lagrangian_gradient(p, local, chain_part, coef, q),
            local.guides,
            sfb(local.gaps + p.compliance * lam_c, lam_c, p.smoothing),
            (d * (chain_part.value - load.displacement) + (1.0 - d) * mu)[None],
        ]
    )


def kkt_jacobian(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Array:
    """∂r/∂z assembled from its blocks (MODEL §11)::

        [[K,        Gᵀ, −Cᵀ,          d a],
         [G,        0,   0,            0 ],
         [D_w C,    0,   D_λ,          0 ],
         [d aᵀ,     0,   0,        1 − d ]]

    K = ∇²_q L, the sum of the elements' local Hessians (:func:`biplan.model.elements.local_terms`)
    and (μd − F) ∇²z_p of the chain; G, C the elements' constraint Jacobians, a = ∇z_p;
    D_w = diag(ŵ/ρ − 1), D_λ = diag(c (ŵ/ρ − 1) + λ/ρ − 1), ρ = √(ŵ² + λ² + ε²), ŵ = w + c λ
    (c: ``ModelOptions.contact_compliance``).
    """
    return _kkt_jacobian(layout, p, z, load, loaded=True)


def _kkt_jacobian(layout: TubeLayout, p: ModelParams, z: Array, load: Load, loaded: bool) -> Array:
    local, chain_part, coef, _ = _terms(layout, p, z, load, True, loaded)
    _, _, lam_c, _ = _split(layout, z)
    k = _lagrangian_hessian(p, local, chain_part, coef)
    return kkt_matrix(
        p, load, k, local.guide_jacobian, local.gap_jacobian, chain_part.gradient, local.gaps, lam_c
    )


def kkt_matrix(
    p: ModelParams,
    load: Load,
    k: Array,
    g_mat: Array,
    c_mat: Array,
    a: Array,
    gaps: Array,
    lam_c: Array,
) -> Array:
    """The KKT Jacobian of :func:`kkt_jacobian` from its blocks: K (n_q, n_q), G (n_g, n_q),
    C (n_c, n_q), a = ∇z_p (n_q,), the gaps w_∂ (n_c,) and the contact multipliers λ_∂."""
    ng, nc = g_mat.shape[0], c_mat.shape[0]
    w = gaps + p.compliance * lam_c
    rho = jnp.sqrt(w**2 + lam_c**2 + p.smoothing**2)
    d = load.displacement_control
    zeros = jnp.zeros
    top = jnp.concatenate([k, g_mat.T, -c_mat.T, (d * a)[:, None]], axis=1)
    mid = jnp.concatenate([g_mat, zeros((ng, ng + nc + 1))], axis=1)
    sfb_rows = jnp.concatenate(
        [
            (w / rho - 1.0)[:, None] * c_mat,
            zeros((nc, ng)),
            jnp.diag(p.compliance * (w / rho - 1.0) + lam_c / rho - 1.0),
            zeros((nc, 1)),
        ],
        axis=1,
    )
    last = jnp.concatenate([d * a, zeros(ng + nc), (1.0 - d)[None]])[None, :]
    return jnp.concatenate([top, mid, sfb_rows, last], axis=0)


class StateData(NamedTuple):
    """Post-processing quantities of one state, computed by a single kernel."""

    energy: Array
    helical_energy: Array
    circular_energy: Array
    load_displacement: Array
    endpoint: chain.Endpoint
    lagrangian_hessian: Array
    constraint_jacobian: Array  # rows [g; w_∂; z_p]
    gaps: Array


def _state(
    layout: TubeLayout,
    p: ModelParams,
    z: Array,
    load: Load,
    second_order: bool,
    blocks: Any,
) -> StateData:
    """StateData at z; ``blocks(local, chain_part, coef)`` gives (K, G, C)."""
    local, chain_part, coef, q = _terms(layout, p, z, load, second_order)
    k, g_mat, c_mat = blocks(local, chain_part, coef)
    return StateData(
        energy=local.helical_energy.sum() + local.circular_energy.sum(),
        helical_energy=local.helical_energy,
        circular_energy=local.circular_energy,
        load_displacement=chain_part.value,
        endpoint=chain.endpoint(layout, p.geometry, q),
        lagrangian_hessian=k,
        constraint_jacobian=jnp.concatenate([g_mat, c_mat, chain_part.gradient[None]]),
        gaps=local.gaps,
    )


def state_data(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> StateData:
    """Energy split, endpoint, Lagrangian Hessian and constraint Jacobians at z."""

    def blocks(local: Any, chain_part: Any, coef: Array) -> tuple[Array, Array, Array]:
        k = _lagrangian_hessian(p, local, chain_part, coef)
        return k, local.guide_jacobian, local.gap_jacobian

    return _state(layout, p, z, load, True, blocks)


def state_from_jacobian(
    layout: TubeLayout, p: ModelParams, z: Array, load: Load, jac: Array
) -> StateData:
    """:func:`state_data` at z from the KKT Jacobian at z (:func:`kkt_jacobian`): K, G and C
    are its blocks, so only first-order terms are evaluated (what a solver returns with its
    solution, whose last Newton pass has the Jacobian at hand)."""
    nq, ng, nc = _sizes(layout)

    def blocks(*_: Any) -> tuple[Array, Array, Array]:
        return jac[:nq, :nq], jac[nq : nq + ng, :nq], -jac[:nq, nq + ng : nq + ng + nc].T

    return _state(layout, p, z, load, False, blocks)


def curvature(
    layout: TubeLayout, p: ModelParams, z: Array, load: Load, x: Array, eta: Array
) -> Array:
    """xᵀ K x − 2 ηᵀ A x at z, K = ∇²_q L and A = ∂[g; w_∂; z_p]/∂q (the rows of
    :attr:`StateData.constraint_jacobian`), for x (n_q,) and η (n_g + n_c + 1,).

    Computed as one directional derivative of the first-order terms along x (K x and A x by
    ``jax.jvp`` of ∇_q L and of the rows), so no matrix is formed: its derivatives with respect
    to z and the design (the sensitivity of λ_min) stay the size of a gradient.
    """
    nq = layout.n_coordinates

    def first(q: Array) -> tuple[Array, Array]:
        local, chain_part, coef, _ = _terms(
            layout, p, jnp.concatenate([q, z[nq:]]), load, second_order=False
        )
        gradient = _lagrangian_gradient(p, local, chain_part, coef, q)
        return gradient, jnp.concatenate([local.guides, local.gaps, chain_part.value[None]])

    _, (kx, ax) = jax.jvp(first, (z[:nq],), (x,))
    return x @ kx - 2.0 * eta @ ax


def sizes(layout: TubeLayout) -> tuple[int, int, int]:
    """(n_q, n_g, n_c): coordinates, guide and contact multipliers of a layout."""
    return _sizes(layout)


def _sizes(layout: TubeLayout) -> tuple[int, int, int]:
    nq = layout.n_coordinates
    ng = 2 * layout.n_modules
    if layout.options.contact is ContactForm.MINIMUM:
        nc = 2 * layout.n_modules + layout.n_connectors
    else:
        nc = 2 * layout.n_modules + len(chain.tables(layout).contact_pt)
    return nq, ng, nc


def _split(layout: TubeLayout, z: Array) -> tuple[Array, Array, Array, Array]:
    nq, ng, nc = _sizes(layout)
    return z[:nq], z[nq : nq + ng], z[nq + ng : nq + ng + nc], z[nq + ng + nc]


@dataclass(frozen=True)
class Kernels:
    """The jitted functions of one layout (all take ``params`` first)."""

    energy: Any
    fold_energies: Any
    gradient: Any
    hessian: Any
    guides: Any
    guide_jacobian: Any
    contact_gaps: Any
    contact_jacobian: Any
    residual: Any
    jacobian: Any
    jacobian_autodiff: Any
    state: Any
    lagrangian_hessian: Any
    endpoint: Any
    load_height: Any
    load_gradient: Any
    kinematics: Any


def _unloaded(layout: TubeLayout, p: ModelParams, q: Array) -> elements.LocalTerms:
    """Local terms with zero multipliers: energy Hessian and constraint Jacobians."""
    _, ng, nc = _sizes(layout)
    return elements.local_terms(layout, p, q, jnp.zeros(ng), jnp.zeros(nc))


def _lagrangian_hessian_at(layout: TubeLayout, p: ModelParams, z: Array, load: Load) -> Array:
    local, chain_part, coef, _ = _terms(layout, p, z, load, second_order=True)
    return _lagrangian_hessian(p, local, chain_part, coef)


#: The model's per-point kernels (:func:`kernels`): functions of (layout, params, …). LLVM's
#: cheap pipeline only with BIPLAN_FAST_COMPILE=on (the test suite): each of these compiles in
#: 2–9 s and runs in under a millisecond.
_POINT_FUNCTIONS: dict[str, Callable[..., Any]] = {
    "energy": energy,
    "fold_energies": fold_energies,
    "gradient": jax.grad(energy, argnums=2),
    "hessian": lambda L, p, q: _unloaded(L, p, q).hessian,
    "guides": guide_values,
    "guide_jacobian": lambda L, p, q: _unloaded(L, p, q).guide_jacobian,
    "contact_gaps": contact_gaps,
    "contact_jacobian": lambda L, p, q: _unloaded(L, p, q).gap_jacobian,
    "residual": residual,
    "jacobian": kkt_jacobian,
    "jacobian_autodiff": jax.jacfwd(residual, argnums=2),
    "state": state_data,
    "lagrangian_hessian": _lagrangian_hessian_at,
    "endpoint": lambda L, p, q: chain.endpoint(L, p.geometry, q),
    "load_height": load_height,
    "load_gradient": jax.grad(load_height, argnums=2),
    "kinematics": _kin,
}
_POINT_KERNELS = {name: Kernel(fun, name) for name, fun in _POINT_FUNCTIONS.items()}


@functools.lru_cache(maxsize=64)
def kernels(layout: TubeLayout) -> Kernels:
    """The compiled per-point kernels of a tube layout (each built on first use)."""
    return Kernels(**{name: k.compiled(layout) for name, k in _POINT_KERNELS.items()})


class Model:
    """A tube with its model readings, ready to evaluate: energy, constraints, residual.

    Parameters
    ----------
    tube : Tube
        Geometry, topology and laws.
    options : ModelOptions, optional
        Readings to use instead of ``tube.options``.

    Notes
    -----
    The model is immutable; use :meth:`with_options` for another reading. Unknowns of the
    equilibrium system are packed as ``z = [q, λ, λ_∂, μ]`` (see :meth:`split`).
    """

    def __init__(self, tube: Tube, options: ModelOptions | None = None) -> None:
        if not isinstance(tube, Tube):
            raise ConfigError("tube", tube, "a biplan Tube")
        if options is not None:
            from dataclasses import replace

            tube = replace(tube, options=options)
        self.tube = tube
        self.layout = tube.layout
        dev = tube.development
        geom = chain.GeometryParams(
            jnp.asarray(dev.radius), jnp.asarray(dev.pitch), jnp.asarray(dev.beta)
        )
        self.params = ModelParams(
            geom,
            _law_rows(tube.helical_laws),
            _law_rows(tube.circular_laws),
            jnp.asarray(tube.options.contact_smoothing),
            jnp.asarray(tube.options.contact_compliance),
            jnp.asarray(tube.options.smooth_min_width),
            jnp.zeros(self.layout.n_coordinates),
            jnp.asarray(0.0),
        )
        self.kernels = kernels(self.layout)
        self.n_coordinates, self.n_guides, self.n_contacts = _sizes(self.layout)
        self.n_unknowns = self.n_coordinates + self.n_guides + self.n_contacts + 1

    @property
    def options(self) -> ModelOptions:
        return self.tube.options

    def with_bias(self, anchor: Array, stiffness: float) -> Model:
        """A copy whose Lagrangian carries the proximal bias ½κ‖q − q_a‖² [N·mm].

        Used for proximal-point descent (branch selection, seeded relaxations); the bias is a
        traced parameter, so biased and unbiased models share their compiled kernels.
        """
        import copy

        anchor = np.asarray(anchor, dtype=float)
        if anchor.shape != (self.n_coordinates,) or not np.all(np.isfinite(anchor)):
            raise ConfigError("anchor", anchor.shape, f"finite q of shape ({self.n_coordinates},)")
        kappa = check_finite("stiffness", stiffness)
        if kappa < 0:
            raise ConfigError("stiffness", kappa, ">= 0")
        out = copy.copy(self)
        out.params = self.params._replace(
            bias_anchor=jnp.asarray(anchor), bias_stiffness=jnp.asarray(kappa)
        )
        return out

    def with_options(self, **changes: Any) -> Model:
        """A model of the same tube under other readings."""
        return Model(self.tube.with_options(**changes))

    def __repr__(self) -> str:
        return (
            f"Model(N={self.layout.n_modules}, connectors="
            f"{[c.kind for c in self.layout.connectors]}, n_q={self.n_coordinates}, "
            f"n_g={self.n_guides}, n_c={self.n_contacts})"
        )

    # --- packing --------------------------------------------------------------------------
    def split(self, z: Array) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """(q, λ, λ_∂, μ) from a packed unknown vector."""
        q, lam, lam_c, mu = _split(self.layout, np.asarray(z))
        return np.asarray(q), np.asarray(lam), np.asarray(lam_c), float(mu)

    def pack(
        self, q: Array, lam: Array | None = None, lam_c: Array | None = None, mu: float = 0.0
    ) -> np.ndarray:
        """Packed z = [q, λ, λ_∂, μ] (missing multipliers are zero)."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_coordinates,):
            raise ConfigError("q", q.shape, f"shape ({self.n_coordinates},)")
        lam = np.zeros(self.n_guides) if lam is None else np.asarray(lam, dtype=float)
        lam_c = np.zeros(self.n_contacts) if lam_c is None else np.asarray(lam_c, dtype=float)
        return np.concatenate([q, lam, lam_c, [mu]])

    def zeros(self) -> np.ndarray:
        """The reference coordinates q = 0."""
        return np.zeros(self.n_coordinates)

    # --- evaluation (all NumPy out) -------------------------------------------------------
    def _q(self, q: Array) -> Array:
        return jnp.asarray(q, dtype=jnp.float64)

    def energy(self, q: Array) -> float:
        """Π(q) [N·mm]."""
        return float(self.kernels.energy(self.params, self._q(q)))

    def fold_energies(self, q: Array) -> tuple[np.ndarray, np.ndarray]:
        """Energy [N·mm] of each helical (N,) and circular (Nc,) fold."""
        h, c = self.kernels.fold_energies(self.params, self._q(q))
        return np.asarray(h), np.asarray(c)

    def gradient(self, q: Array) -> np.ndarray:
        """∇Π(q) [N or N·mm per coordinate]."""
        return np.asarray(self.kernels.gradient(self.params, self._q(q)))

    def hessian(self, q: Array) -> np.ndarray:
        """∇²Π(q)."""
        return np.asarray(self.kernels.hessian(self.params, self._q(q)))

    def constraints(self, q: Array) -> np.ndarray:
        """Guide values g(q) [mm], (2N,)."""
        return np.asarray(self.kernels.guides(self.params, self._q(q)))

    def constraint_jacobian(self, q: Array) -> np.ndarray:
        """∂g/∂q, (2N, n_q)."""
        return np.asarray(self.kernels.guide_jacobian(self.params, self._q(q)))

    def contact_gaps(self, q: Array) -> np.ndarray:
        """Contact gaps w_∂(q) [mm], (n_c,)."""
        return np.asarray(self.kernels.contact_gaps(self.params, self._q(q)))

    def contact_jacobian(self, q: Array) -> np.ndarray:
        """∂w_∂/∂q, (n_c, n_q)."""
        return np.asarray(self.kernels.contact_jacobian(self.params, self._q(q)))

    def residual(self, z: Array, load: Load) -> np.ndarray:
        """KKT residual r(z) for the given load."""
        return np.asarray(self.kernels.residual(self.params, jnp.asarray(z), load.for_kernel()))

    def jacobian(self, z: Array, load: Load) -> np.ndarray:
        """∂r/∂z, (n_z, n_z)."""
        return np.asarray(self.kernels.jacobian(self.params, jnp.asarray(z), load.for_kernel()))

    def jacobian_autodiff(self, z: Array, load: Load) -> np.ndarray:
        """∂r/∂z by forward-mode autodiff of the whole residual (reference for tests)."""
        return np.asarray(
            self.kernels.jacobian_autodiff(self.params, jnp.asarray(z), load.for_kernel())
        )

    def state(self, z: Array, load: Load) -> StateData:
        """Energies, endpoint, Lagrangian Hessian and constraint Jacobians at z (one kernel)."""
        out = self.kernels.state(self.params, jnp.asarray(z), load.for_kernel())
        return jax.tree_util.tree_map(np.asarray, out)

    def lagrangian_hessian(self, z: Array, load: Load) -> np.ndarray:
        """∇²_q L at z: energy, load and multiplier curvature (MODEL CHOICE S2)."""
        return np.asarray(
            self.kernels.lagrangian_hessian(self.params, jnp.asarray(z), load.for_kernel())
        )

    def endpoint(self, q: Array) -> chain.Endpoint:
        """(u_z [mm], u_r [mm], θ [rad]) of the free end relative to q = 0 (MODEL R2)."""
        e = self.kernels.endpoint(self.params, self._q(q))
        return chain.Endpoint(float(e.u_z), float(e.u_r), float(e.theta))

    def load_displacement(self, q: Array) -> float:
        """Axial displacement z_p [mm] of the load point (work conjugate of F)."""
        return float(self.kernels.load_height(self.params, self._q(q)))

    def load_gradient(self, q: Array) -> np.ndarray:
        """∂z_p/∂q."""
        return np.asarray(self.kernels.load_gradient(self.params, self._q(q)))

    def kinematics(self, q: Array) -> chain.Kinematics:
        """All kinematic quantities at q (NumPy arrays): nodes, guides, elongations, frames."""
        kin = self.kernels.kinematics(self.params, self._q(q))
        return chain.Kinematics(*(np.asarray(v) for v in kin))

    def helical_boundary(self, q: Array) -> np.ndarray:
        """(w0, wa) [mm] of each helical fold, (N, 2)."""
        return self.kinematics(q).helical

    def circular_fields(self, q: Array) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
        """Per circular fold: (w_start, w_end, length) of its fields [mm]."""
        kin = self.kinematics(q)
        conn = chain.tables(self.layout).field_conn
        return [
            (kin.field_start[conn == c], kin.field_end[conn == c], kin.field_length[conn == c])
            for c in range(self.layout.n_connectors)
        ]

    def global_nodes(self, q: Array) -> np.ndarray:
        """Deformed nodes in the global development plane, (N, 7, 2) [mm] (z, s)."""
        return np.asarray(chain.global_nodes(self.kernels.kinematics(self.params, self._q(q))))

    def cylinder_nodes(self, q: Array) -> np.ndarray:
        """Deformed nodes wrapped onto the cylinder of radius R, (N, 7, 3) [mm] (x, y, z)."""
        nodes = self.global_nodes(q)
        return np.asarray(chain.wrap_to_cylinder(nodes, self.tube.development.radius))
