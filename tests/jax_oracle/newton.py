"""The JAX Newton of the equilibrium solve, kept as the oracle of the compiled one
(:func:`biplan.solvers.iteration.newton`): :func:`jax_oracle.core.machine` on the model's KKT
system r(z) = 0 at a load, its residual and KKT Jacobian by autodiff
(:func:`biplan.model.assembly.autodiff_functions`), one ``jax.lax.while_loop`` per tube layout.
"""

from __future__ import annotations

from typing import Any

from biplan._compile.setup import jax
from biplan._compile.traced import traced
from biplan.geometry.layout import TubeLayout
from biplan.model.assembly import Load, autodiff_functions
from biplan.model.lagrangian import StateData, state_from_jacobian
from biplan.solvers import Newton
from jax_oracle.core import LoopState, machine
from jax_oracle.settings import Settings

__all__ = ["newton_loop", "newton_machine", "settings_of", "solve_loop"]

Array = Any


def settings_of(method: Newton) -> Settings:
    """The traced settings of the oracle's iteration for a configured :class:`Newton`."""
    return Settings.of(
        method.atol, method.max_steps, method.max_backtracks, method.armijo, method.free_steps
    )


def newton_machine(
    layout: TubeLayout,
    params: Any,
    load: Load,
    settings: Settings,
    line_search_loop: bool = False,
    free_steps: int | None = 0,
    axis_name: str | None = None,
) -> tuple:
    """:func:`jax_oracle.core.machine` on the model's KKT system r(z) = 0 at ``load``."""
    k = autodiff_functions(layout)
    return machine(
        lambda z: k.residual(params, z, load),
        lambda z: k.jacobian(params, z, load),
        settings,
        line_search_loop=line_search_loop,
        free_steps=free_steps,
        axis_name=axis_name,
    )


def newton_loop(
    layout: TubeLayout,
    params: Any,
    z0: Array,
    load: Load,
    settings: Settings,
    line_search_loop: bool = False,
    free_steps: int | None = 0,
    axis_name: str | None = None,
) -> LoopState:
    """Pure (jit/vmap-able) globalised Newton iteration (:func:`newton_machine`): Newton steps
    with an Armijo line search on ½‖r‖² that falls back to Levenberg–Marquardt steps with
    growing damping."""
    init, body, cond, finish = newton_machine(
        layout, params, load, settings, line_search_loop, free_steps, axis_name
    )
    return finish(jax.lax.while_loop(cond, body, init(z0)))


@traced("newton_loop", runs_often=True)
def solve_loop(
    layout: TubeLayout, params: Any, z0: Array, load: Load, settings: Settings
) -> tuple[LoopState, StateData]:
    """:func:`newton_loop` (watchdog length traced) and the :class:`StateData` of its last
    iterate, taken from the Jacobian the loop evaluated there."""
    out = newton_loop(layout, params, z0, load, settings, free_steps=None)
    return out, state_from_jacobian(layout, params, out.z, load, out.jac)
