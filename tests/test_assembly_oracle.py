"""The local assembly (element blocks + chain term) equals the whole-tube autodiff oracle.

:mod:`biplan.model.lagrangian` builds the KKT residual and Jacobian from per-element autodiff
(:mod:`biplan.model.elements`); :mod:`biplan.model.oracle` differentiates one Lagrangian of the
whole
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
from biplan._compile.setup import jax, jnp, xla_options
from biplan.geometry import chain
from biplan.geometry.layout import TubeLayout
from biplan.model import lagrangian, potential
from biplan.model import oracle as _oracle
from biplan.model.params import Load
from biplan.options import ChainOffset, ContactForm, ModelOptions, TpcSign
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
    "printed TPC sign": lambda: make_tube(3).with_options(tpc_sign=TpcSign.AS_PRINTED),
}

LOADS = {
    "force": Load(1.3, 0.0, 0.0),
    "displacement": Load(0.0, 0.7, 1.0),
}


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / max(1.0, np.max(np.abs(b))))


@functools.cache
def _both(layout: TubeLayout):
    """One compiled kernel per layout: (local, oracle) residual, Jacobian and state data."""

    def pair(fn_local, fn_oracle, p, z, load):
        return fn_local(layout, p, z, load), fn_oracle(layout, p, z, load)

    def all_three(p, z, load):
        return (
            pair(lagrangian.residual, _oracle.residual, p, z, load),
            pair(lagrangian.kkt_jacobian, _oracle.kkt_jacobian, p, z, load),
            pair(lagrangian.state_data, _oracle.state_data, p, z, load),
        )

    return jax.jit(all_three, compiler_options=xla_options())


def _compare(model: biplan.Model, z: np.ndarray, load: Load) -> None:
    (r, r_ref), (j, j_ref), (s, s_ref) = _both(model.layout)(
        model.params, jnp.asarray(z), load.for_jax()
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
    _compare(biased, sol.z, Load(0.0, 0.3, 1.0))


def test_model_hessian_and_jacobians_equal_global_autodiff(model6, rng):
    """The Model's energy Hessian and constraint Jacobians (local) equal global autodiff."""
    layout, p = model6.layout, model6.params
    q = random_configuration(model6, rng)

    def oracle(x):
        return (
            jax.hessian(lambda y: potential.energy(layout, p, y))(x),
            jax.jacfwd(lambda y: potential.guide_values(layout, p, y))(x),
            jax.jacfwd(lambda y: potential.contact_gaps(layout, p, y))(x),
        )

    h, g, c = jax.jit(oracle, compiler_options=xla_options())(jnp.asarray(q))
    assert _relative(model6.hessian(q), h) < TOL
    assert _relative(model6.constraint_jacobian(q), g) < TOL
    assert _relative(model6.contact_jacobian(q), c) < TOL


def test_printed_tpc_sign_mirrors_the_first_field_of_each_tpc():
    """TpcSign.AS_PRINTED (SI Eq. VC_w as printed): at the split end of a TPC's first field
    w = 2γ − w_geometric; every other field-end point is unchanged. Three modules S, M, S:
    TPCs at the base and at 1|2, an SPC at 0|1."""
    geometric = biplan.Model(make_tube(3))
    printed = biplan.Model(make_tube(3).with_options(tpc_sign=TpcSign.AS_PRINTED))
    q = random_configuration(geometric, np.random.default_rng(3))
    w_g = np.asarray(geometric.kinematics(q).point_w)
    w_p = np.asarray(printed.kinematics(q).point_w)
    t = chain.tables(printed.layout)
    kinds = [c.kind for c in printed.layout.connectors]
    assert kinds == ["TPC", "SPC", "TPC"] and t.pt_flip.sum() == 2
    assert not chain.tables(geometric.layout).pt_flip.any()
    gamma = np.asarray(q)[3 * 3 + t.pt_conn]
    np.testing.assert_allclose(w_p[t.pt_flip], 2 * gamma[t.pt_flip] - w_g[t.pt_flip], atol=1e-13)
    np.testing.assert_array_equal(w_p[~t.pt_flip], w_g[~t.pt_flip])
    assert np.all(np.abs(w_g[t.pt_flip] - gamma[t.pt_flip]) > 1e-6)  # the sign matters here


def test_curvature_is_the_quadratic_form_of_the_assembled_matrices(model2, rng):
    """lagrangian.curvature (directional derivatives, no matrix) = xᵀ K x − 2 ηᵀ A x with K and
    A of state_data, under force and displacement control."""
    layout, p = model2.layout, model2.params
    q = random_configuration(model2, rng)
    n_rows = model2.n_guides + model2.n_contacts + 1

    @functools.partial(jax.jit, compiler_options=xla_options())
    def both(z, load, x, eta):
        data = lagrangian.state_data(layout, p, z, load)
        quad = x @ data.lagrangian_hessian @ x - 2.0 * eta @ (data.constraint_jacobian @ x)
        return lagrangian.curvature(layout, p, z, load, x, eta), quad

    for load in LOADS.values():
        z = model2.pack(
            q, rng.normal(0.0, 1.0, model2.n_guides), rng.uniform(0.0, 1.0, model2.n_contacts), 0.3
        )
        x, eta = rng.normal(size=model2.n_coordinates), rng.normal(size=n_rows)
        got, want = both(jnp.asarray(z), load.for_jax(), jnp.asarray(x), jnp.asarray(eta))
        assert abs(float(got) - float(want)) < TOL * max(1.0, abs(float(want)))
