"""The model of a tube: :class:`Model` (its compiled :class:`~biplan.model.system.System` and
its JAX autodiff functions, :class:`AutodiffFunctions`) and :class:`Load`.

:func:`autodiff_functions` ``jit``-compiles the pure functions of :mod:`biplan.model.potential`
(energy, guides, gaps, load point) and :mod:`biplan.model.lagrangian` (the KKT residual, its
Jacobian, the Hessians and the state data) once per tube *layout*
(:class:`~biplan.geometry.TubeLayout`), with geometry and law numbers passed as traced
parameters (:class:`~biplan.model.params.ModelParams`), so sweeping R, l, β or law
coefficients never recompiles them. :class:`Model` binds a tube to its parameters, hands out
its :class:`~biplan.model.system.System` (:meth:`Model.system`: what every solver iterates on)
and evaluates the autodiff functions on NumPy arrays (the reference the compiled system is
tested against); the loads it takes are :class:`Load` (defined in :mod:`biplan.model.params`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from biplan._compile.setup import jax, jnp
from biplan._errors import ConfigError, check_finite
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.model.params import Load, ModelParams, StateData, sizes
from biplan.model.system import System
from biplan.model.system.kinematics import kinematics as system_kinematics
from biplan.model.tube import Tube
from biplan.options import ModelOptions

if TYPE_CHECKING:
    from biplan.model.autodiff import AutodiffFunctions

__all__ = ["AutodiffFunctions", "Load", "Model", "autodiff_functions", "sizes"]

Array = Any


def _law_rows(laws: tuple) -> np.ndarray:  # type: ignore[type-arg]
    if not laws:
        return np.zeros((0, 5))
    return np.asarray([law.coefficients for law in laws], dtype=np.float64)


def autodiff_functions(layout: TubeLayout) -> AutodiffFunctions:
    """The JAX autodiff functions of a layout (:func:`biplan.model.autodiff.functions`;
    imports JAX)."""
    from biplan.model import autodiff

    return autodiff.functions(layout)


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
            np.asarray(dev.radius, dtype=float),
            np.asarray(dev.pitch, dtype=float),
            np.asarray(dev.beta, dtype=float),
        )
        self.params = ModelParams(
            geom,
            _law_rows(tube.helical_laws),
            _law_rows(tube.circular_laws),
            np.asarray(tube.options.contact_smoothing, dtype=float),
            np.asarray(tube.options.contact_compliance, dtype=float),
            np.asarray(tube.options.smooth_min_width, dtype=float),
            np.zeros(self.layout.n_coordinates),
            np.asarray(0.0),
        )
        self.n_coordinates, self.n_guides, self.n_contacts = sizes(self.layout)
        self.n_unknowns = self.n_coordinates + self.n_guides + self.n_contacts + 1

    @property
    def autodiff(self) -> AutodiffFunctions:
        """The JAX autodiff functions of this model's layout (:mod:`biplan.model.autodiff`; the
        first use imports JAX)."""
        return autodiff_functions(self.layout)

    @property
    def options(self) -> ModelOptions:
        return self.tube.options

    def system(self, load: Load | None = None) -> System:
        """The compiled :class:`~biplan.model.system.System` of this model's parameters
        (``self.params``: geometry, laws, contact numbers, bias) at ``load`` (default: at
        rest)."""
        return self._compiled_system(load)

    def _compiled_system(self, load: Load | None) -> System:
        cached = self.__dict__.get("_system")
        if cached is None or cached[0] is not self.params:  # a copy with other parameters
            p = self.params
            base = System.of_numbers(
                self.layout,
                float(p.geometry.radius),
                float(p.geometry.pitch),
                float(p.geometry.beta),
                np.asarray(p.helical, dtype=float),
                np.asarray(p.circular, dtype=float),
            )
            base = base.with_contact(
                float(p.smoothing), float(p.compliance), float(p.smooth_min_width)
            )
            kappa = float(p.bias_stiffness)
            if kappa:
                base = base.with_bias(np.asarray(p.bias_anchor), kappa)
            cached = (p, base)
            self.__dict__["_system"] = cached
        base = cached[1]
        if load is None:
            return base
        return base.at(
            float(load.force), float(load.displacement), float(load.displacement_control)
        )

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
        out.params = self.params._replace(bias_anchor=anchor, bias_stiffness=np.asarray(kappa))
        cached = self.__dict__.get("_system")
        if cached is not None and cached[0] is self.params:  # the same tables, another bias
            system = cached[1].with_bias(anchor if kappa else np.zeros_like(anchor), kappa)
            out.__dict__["_system"] = (out.params, system)
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
        z = np.asarray(z)
        nq, ng, nc = self.n_coordinates, self.n_guides, self.n_contacts
        return z[:nq], z[nq : nq + ng], z[nq + ng : nq + ng + nc], float(z[nq + ng + nc])

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
        return float(self.autodiff.energy(self.params, self._q(q)))

    def fold_energies(self, q: Array) -> tuple[np.ndarray, np.ndarray]:
        """Energy [N·mm] of each helical (N,) and circular (Nc,) fold."""
        h, c = self.autodiff.fold_energies(self.params, self._q(q))
        return np.asarray(h), np.asarray(c)

    def gradient(self, q: Array) -> np.ndarray:
        """∇Π(q) [N or N·mm per coordinate]."""
        return np.asarray(self.autodiff.gradient(self.params, self._q(q)))

    def hessian(self, q: Array) -> np.ndarray:
        """∇²Π(q)."""
        return np.asarray(self.autodiff.hessian(self.params, self._q(q)))

    def constraints(self, q: Array) -> np.ndarray:
        """Guide values g(q) [mm], (2N,)."""
        return np.asarray(self.autodiff.guides(self.params, self._q(q)))

    def constraint_jacobian(self, q: Array) -> np.ndarray:
        """∂g/∂q, (2N, n_q)."""
        return np.asarray(self.autodiff.guide_jacobian(self.params, self._q(q)))

    def contact_gaps(self, q: Array) -> np.ndarray:
        """Contact gaps w_∂(q) [mm], (n_c,)."""
        return np.asarray(self.autodiff.contact_gaps(self.params, self._q(q)))

    def contact_jacobian(self, q: Array) -> np.ndarray:
        """∂w_∂/∂q, (n_c, n_q)."""
        return np.asarray(self.autodiff.contact_jacobian(self.params, self._q(q)))

    def residual(self, z: Array, load: Load) -> np.ndarray:
        """KKT residual r(z) for the given load."""
        return np.asarray(self.autodiff.residual(self.params, jnp.asarray(z), load.for_jax()))

    def jacobian(self, z: Array, load: Load) -> np.ndarray:
        """∂r/∂z, (n_z, n_z)."""
        return np.asarray(self.autodiff.jacobian(self.params, jnp.asarray(z), load.for_jax()))

    def jacobian_autodiff(self, z: Array, load: Load) -> np.ndarray:
        """∂r/∂z by forward-mode autodiff of the whole residual (reference for tests)."""
        return np.asarray(
            self.autodiff.jacobian_autodiff(self.params, jnp.asarray(z), load.for_jax())
        )

    def state(self, z: Array, load: Load) -> StateData:
        """Energies, endpoint, Lagrangian Hessian and constraint Jacobians at z (one JAX
        function)."""
        out = self.autodiff.state(self.params, jnp.asarray(z), load.for_jax())
        return jax.tree_util.tree_map(np.asarray, out)

    def lagrangian_hessian(self, z: Array, load: Load) -> np.ndarray:
        """∇²_q L at z: energy, load and multiplier curvature (MODEL CHOICE S2)."""
        return np.asarray(
            self.autodiff.lagrangian_hessian(self.params, jnp.asarray(z), load.for_jax())
        )

    def endpoint(self, q: Array) -> chain.Endpoint:
        """(u_z [mm], u_r [mm], θ [rad]) of the free end relative to q = 0 (MODEL R2)."""
        e = self.autodiff.endpoint(self.params, self._q(q))
        return chain.Endpoint(float(e.u_z), float(e.u_r), float(e.theta))

    def load_displacement(self, q: Array) -> float:
        """Axial displacement z_p [mm] of the load point (work conjugate of F)."""
        return float(self.autodiff.load_height(self.params, self._q(q)))

    def load_gradient(self, q: Array) -> np.ndarray:
        """∂z_p/∂q."""
        return np.asarray(self.autodiff.load_gradient(self.params, self._q(q)))

    def kinematics(self, q: Array) -> chain.Kinematics:
        """All kinematic quantities at q (NumPy arrays): nodes, guides, elongations, frames;
        evaluated on the compiled system (:func:`biplan.model.system.kinematics.kinematics`,
        no JAX; equal to the JAX :func:`biplan.geometry.chain.kinematics` to 1e-12)."""
        return system_kinematics(self.system().data, np.asarray(q, dtype=float))

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
        return np.asarray(chain.global_nodes(self.kinematics(q)))

    def cylinder_nodes(self, q: Array) -> np.ndarray:
        """Deformed nodes wrapped onto the cylinder of radius R, (N, 7, 3) [mm] (x, y, z)."""
        nodes = self.global_nodes(q)
        return np.asarray(chain.wrap_to_cylinder(nodes, self.tube.development.radius))
