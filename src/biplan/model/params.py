"""The traced inputs of every model kernel: :class:`ModelParams` and :class:`Load`.

Both are JAX pytrees of numbers. A kernel is compiled once per tube layout
(:class:`~biplan.geometry.TubeLayout`) and takes these as traced arguments, so sweeping the
geometry, the law coefficients or the load never recompiles. :data:`AT_REST` is the load of a
tube at rest (zero end force under force control).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from biplan._compile.setup import jnp
from biplan._errors import check_finite, check_range
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.options import ContactForm

__all__ = ["AT_REST", "Load", "ModelParams", "StateData"]

Array = Any


class ModelParams(NamedTuple):
    """Traced parameters of a model (a JAX pytree).

    Attributes
    ----------
    geometry : GeometryParams
        R [mm], l [mm] and β [rad] of the development.
    helical, circular : array (N, 5), (Nc, 5)
        Law coefficients (k1, k2, k3 [N/mm²], w1, w2 [mm]) of each helical and circular fold.
    smoothing : scalar
        ε of the smoothed Fischer–Burmeister function of the contact rows (SI Eq. sfb).
    compliance : scalar
        c [mm/N] of the contact rows φ_ε(w + c λ, λ).
    smooth_min_width : scalar
        τ [mm] of ``ContactForm.MINIMUM``.
    bias_anchor : array (n_q,)
        Anchor q_a of the optional proximal bias ½κ‖q − q_a‖² [mm or rad].
    bias_stiffness : scalar
        κ ≥ 0 of the bias (0: no bias).
    """

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

    def for_jax(self) -> Load:
        """The form every compiled kernel is called with: weakly typed JAX scalars, whatever
        the caller passed (Python or NumPy floats; arrays are passed on). One input type per
        kernel, so no kernel is traced and compiled once per scalar type."""
        return Load(*(jnp.asarray(float(v)) if np.ndim(v) == 0 else jnp.asarray(v) for v in self))


#: Zero end force under force control: the load of a tube at rest (state searches).
AT_REST = Load(0.0, 0.0, 0.0)


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


def sizes(layout: TubeLayout) -> tuple[int, int, int]:
    """(n_q, n_g, n_c): coordinates, guide and contact multipliers of a layout."""

    nq = layout.n_coordinates
    ng = 2 * layout.n_modules
    if layout.options.contact is ContactForm.MINIMUM:
        nc = 2 * layout.n_modules + layout.n_connectors
    else:
        nc = 2 * layout.n_modules + len(chain.tables(layout).contact_pt)
    return nq, ng, nc
