"""The JAX autodiff functions of a tube layout: the autodiff model behind
:class:`~biplan.model.Model`'s evaluation methods, and the sensitivities (the compiled
system, :mod:`biplan.model.system`, is tested against them).

:func:`functions` ``jit``-compiles the pure functions of :mod:`biplan.model.potential` (energy,
guides, gaps, load point) and :mod:`biplan.model.lagrangian` (the KKT residual, its Jacobian,
the Hessians and the state data) once per tube *layout*, with geometry and law numbers passed
as traced parameters (:class:`~biplan.model.params.ModelParams`), so sweeping R, l, β or law
coefficients never recompiles. Importing this module imports JAX; the model imports it only
when one of these functions is asked for (:attr:`biplan.model.Model.autodiff`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from biplan._compile.setup import jax
from biplan._compile.traced import Traced
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.model.lagrangian import (
    kkt_jacobian,
    lagrangian_hessian,
    residual,
    state_data,
    unloaded_terms,
)
from biplan.model.potential import (
    _kin,
    contact_gaps,
    energy,
    fold_energies,
    guide_values,
    load_height,
)

__all__ = ["AutodiffFunctions", "functions"]


@dataclass(frozen=True)
class AutodiffFunctions:
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


#: The model's per-point functions (:func:`functions`): of (layout, params, …). LLVM's
#: cheap pipeline only with BIPLAN_FAST_COMPILE=on (the test suite): each of these compiles in
#: 2–9 s and runs in under a millisecond.
_POINT_FUNCTIONS: dict[str, Callable[..., Any]] = {
    "energy": energy,
    "fold_energies": fold_energies,
    "gradient": jax.grad(energy, argnums=2),
    "hessian": lambda L, p, q: unloaded_terms(L, p, q).hessian,
    "guides": guide_values,
    "guide_jacobian": lambda L, p, q: unloaded_terms(L, p, q).guide_jacobian,
    "contact_gaps": contact_gaps,
    "contact_jacobian": lambda L, p, q: unloaded_terms(L, p, q).gap_jacobian,
    "residual": residual,
    "jacobian": kkt_jacobian,
    "jacobian_autodiff": jax.jacfwd(residual, argnums=2),
    "state": state_data,
    "lagrangian_hessian": lagrangian_hessian,
    "endpoint": lambda L, p, q: chain.endpoint(L, p.geometry, q),
    "load_height": load_height,
    "load_gradient": jax.grad(load_height, argnums=2),
    "kinematics": _kin,
}
_POINT_KERNELS = {name: Traced(fun, name) for name, fun in _POINT_FUNCTIONS.items()}


@functools.lru_cache(maxsize=64)
def functions(layout: TubeLayout) -> AutodiffFunctions:
    """The compiled per-point autodiff functions of a tube layout (each built on first use)."""
    return AutodiffFunctions(**{name: k.compiled(layout) for name, k in _POINT_KERNELS.items()})
