"""The local assembly (element blocks + chain term) equals the whole-tube autodiff oracle.

:mod:`biplan.assembly` builds the KKT residual and Jacobian from per-element autodiff
(:mod:`biplan.elements`); :mod:`biplan._oracle` differentiates one Lagrangian of the whole
chain. They must agree to round-off on every layout and reading: force and displacement
control, non-zero guide and contact multipliers, active contacts at a solved state, the
proximal bias, the MINIMUM contact form, the paper's chain offset and the edge-fit chain of the
fully bistable design (no base fold).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import biplan
from biplan import _oracle
from biplan import assembly as asm
from biplan._jax import jax, jnp
from biplan.options import ChainOffset, ContactForm, ModelOptions
from conftest import make_tube, random_configuration

TOL = 1e-10

LAYOUTS = {
    "one module": lambda: make_tube(1),
    "semi-bistable": lambda: biplan.designs.semi_bistable(),
    "fully bistable, edge fit": lambda: biplan.designs.fully_bistable(),
    "minimum contact": lambda: biplan.designs.semi_bistable(
        ModelOptions(contact=ContactForm.MINIMUM)
    ),
    "paper chain offset": lambda: make_tube(3).with_options(chain_offset=ChainOffset.PAPER),
}

LOADS = {
    "force": asm.Load(1.3, 0.0, 0.0),
    "displacement": asm.Load(0.0, 0.7, 1.0),
}


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(1.0, np.max(np.abs(b))))


@functools.cache
def _both(layout: asm.TubeLayout):
    """One compiled kernel per layout: (local, oracle) residual, Jacobian and state data."""

    def pair(fn_local, fn_oracle, p, z, load):
        return fn_local(layout, p, z, load), fn_oracle(layout, p, z, load)

    def all_three(p, z, load):
        return (
            pair(asm.residual, _oracle.residual, p, z, load),
            pair(asm.kkt_jacobian, _oracle.kkt_jacobian, p, z, load),
            pair(asm.state_data, _oracle.state_data, p, z, load),
        )

    return jax.jit(all_three)


def _compare(model: biplan.Model, z: np.ndarray, load: asm.Load) -> None:
    (r, r_ref), (j, j_ref), (s, s_ref) = _both(model.layout)(
        model.params, jnp.asarray(z), load.for_kernel()
    )
    assert _relative(r, r_ref) < TOL
    assert _relative(j, j_ref) < TOL
    for name in ("energy", "lagrangian_hessian", "constraint_jacobian", "gaps"):
        assert _relative(getattr(s, name), getattr(s_ref, name)) < TOL, name


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_local_assembly_equals_global_autodiff(name, rng):
    """Random states with non-zero multipliers, under force and displacement control."""
    model = biplan.Model(LAYOUTS[name]())
    q = random_configuration(model, rng)
    for load in LOADS.values():
        z = model.pack(
            q,
            rng.normal(0.0, 1.0, model.n_guides),
            rng.uniform(0.0, 1.0, model.n_contacts),
            0.3,
        )
        _compare(model, z, load)


def test_local_assembly_at_solved_states_with_active_contacts(model6, reference6):
    """At converged equilibria (closed contacts carry multipliers) and with the proximal bias."""
    load = biplan.Load.of_force(-0.5)  # compression presses the closed folds' contacts
    sol = biplan.solve_equilibrium(model6, biplan.Newton(), reference6, load)
    lam_c = model6.split(sol.z)[2]
    assert np.count_nonzero(lam_c > 1e-3) > 0  # some contacts are active and pressed
    _compare(model6, sol.z, load)
    biased = model6.with_bias(model6.split(sol.z)[0] + 0.01, 0.5)
    _compare(biased, sol.z, asm.Load(0.0, 0.3, 1.0))


def test_model_hessian_and_jacobians_equal_global_autodiff(model6, rng):
    """The Model's energy Hessian and constraint Jacobians (local) equal global autodiff."""
    layout, p = model6.layout, model6.params
    q = random_configuration(model6, rng)
    h = jax.hessian(lambda x: asm.energy(layout, p, x))(jnp.asarray(q))
    g = jax.jacfwd(lambda x: asm.guide_values(layout, p, x))(jnp.asarray(q))
    c = jax.jacfwd(lambda x: asm.contact_gaps(layout, p, x))(jnp.asarray(q))
    assert _relative(model6.hessian(q), h) < TOL
    assert _relative(model6.constraint_jacobian(q), g) < TOL
    assert _relative(model6.contact_jacobian(q), c) < TOL
