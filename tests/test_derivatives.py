"""Derivatives of the assembled model against central finite differences, and the block
structure of the KKT residual and Jacobian (MODEL.md §11).

Configurations are random (module coordinates ~ N(0, 0.03), γ in 0.1–0.8 mm so that circular
fields cross the law breakpoints) but keep every field boundary 1e-3 mm away from a breakpoint,
where the Hessian is discontinuous.
"""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan.model.lagrangian import sfb
from conftest import random_configuration

LAYOUTS = ["model1", "model2", "model6", "model4"]
STEP = 1e-6


def _fd(f, x, h=STEP):
    """Central-difference Jacobian of f at x, shape f(x).shape + x.shape."""
    cols = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h
        cols.append((np.asarray(f(x + e)) - np.asarray(f(x - e))) / (2 * h))
    return np.stack(cols, axis=-1)


def _close(analytic, fd, rtol=1e-5, floor=1e-6):
    """|analytic − fd| ≤ rtol |fd| + floor · max(1, max|analytic|)."""
    analytic = np.asarray(analytic)
    atol = floor * max(1.0, float(np.max(np.abs(analytic), initial=0.0)))
    np.testing.assert_allclose(analytic, fd, rtol=rtol, atol=atol)


@pytest.fixture(params=LAYOUTS)
def model(request):
    return request.getfixturevalue(request.param)


@pytest.fixture
def configs(model, rng):
    return [random_configuration(model, rng) for _ in range(2)]


# The KKT Jacobian kernel is compiled only for these tests (~10 s per layout): the 1-module
# tube (base TPC) and the 6-module design (base TPC, S→M SPC, M→S TPC) cover every connector
# kind. The Lagrangian Hessian is compiled anyway wherever the stability tests classify.
@pytest.fixture(params=["model1", "model6"])
def kkt_model(request):
    return request.getfixturevalue(request.param)


@pytest.fixture
def kkt_configs(kkt_model, rng):
    return [random_configuration(kkt_model, rng) for _ in range(2)]


@pytest.fixture(params=["model1", "model6", "model4"])
def lag_model(request):
    return request.getfixturevalue(request.param)


def _random_z(model, q, rng):
    lam = rng.normal(0.0, 1.0, model.n_guides)
    lam_c = np.abs(rng.normal(0.0, 0.1, model.n_contacts))
    return model.pack(q, lam, lam_c, float(rng.normal()))


def test_configurations_cross_breakpoints(model6, rng):
    """The random configurations used here really exercise every branch of the circular law."""
    branches = set()
    for _ in range(4):
        q = random_configuration(model6, rng)
        for w0, w1, _ in model6.circular_fields(q):
            for w in np.concatenate([w0, w1]):
                branches.add(int(w >= 0.2) + int(w >= 1.3))
    assert branches >= {0, 1}


def test_energy_gradient(model, configs):
    for q in configs:
        _close(model.gradient(q), _fd(model.energy, q))


@pytest.mark.parametrize("name", ["model1", "model2", "model6"])
def test_gradient_hessian(name, request, rng):
    model = request.getfixturevalue(name)
    configs = [random_configuration(model, rng) for _ in range(2)]
    for q in configs:
        h = model.hessian(q)
        np.testing.assert_allclose(h, h.T, atol=1e-12 * max(1.0, np.abs(h).max()))
        _close(h, _fd(model.gradient, q))


def test_fold_energies_sum_to_energy(model, configs):
    for q in configs:
        hel, circ = model.fold_energies(q)
        assert hel.shape == (model.layout.n_modules,)
        assert circ.shape == (model.layout.n_connectors,)
        assert hel.sum() + circ.sum() == pytest.approx(model.energy(q), rel=1e-13, abs=1e-15)
        # each fold's energy is the exact field energy of its law over its fields
        kin = model.kinematics(q)
        for n, law in enumerate(model.tube.helical_laws):
            w0, wa = kin.helical[n]
            assert hel[n] == pytest.approx(law.field_energy(w0, wa, kin.helical_length), rel=1e-13)
        for c, (law, (s, e, length)) in enumerate(
            zip(model.tube.circular_laws, model.circular_fields(q), strict=True)
        ):
            assert circ[c] == pytest.approx(
                float(np.sum(law.field_energy(s, e, length))), rel=1e-13
            )


def test_constraint_jacobian(model, configs):
    for q in configs:
        _close(model.constraint_jacobian(q), _fd(model.constraints, q))


def test_contact_jacobian(model, configs):
    for q in configs:
        _close(model.contact_jacobian(q), _fd(model.contact_gaps, q))


def test_load_gradient(model, configs):
    for q in configs:
        _close(model.load_gradient(q), _fd(model.load_displacement, q))


@pytest.mark.parametrize(
    "load", [biplan.Load.of_force(0.7), biplan.Load.of_displacement(0.4)], ids=["force", "disp"]
)
def test_residual_jacobian(kkt_model, kkt_configs, load, rng):
    model = kkt_model
    for q in kkt_configs:
        z = _random_z(model, q, rng)
        _close(model.jacobian(z, load), _fd(lambda zz: model.residual(zz, load), z))


@pytest.mark.parametrize(
    "load", [biplan.Load.of_force(-0.3), biplan.Load.of_displacement(1.1)], ids=["force", "disp"]
)
def test_lagrangian_hessian(lag_model, load, rng):
    model = lag_model
    nq = model.n_coordinates
    for q in [random_configuration(model, rng) for _ in range(2)]:
        z = _random_z(model, q, rng)
        k = model.lagrangian_hessian(z, load)
        np.testing.assert_allclose(k, k.T, atol=1e-12 * max(1.0, np.abs(k).max()))

        def grad_q(qq, z=z):
            zz = z.copy()
            zz[:nq] = qq
            return model.residual(zz, load)[:nq]

        _close(k, _fd(grad_q, q))


@pytest.mark.parametrize(
    "load", [biplan.Load.of_force(0.9), biplan.Load.of_displacement(0.25)], ids=["force", "disp"]
)
def test_residual_structure(kkt_model, kkt_configs, load, rng):
    """r = [∇Π − F∇z_p + Gᵀλ − Cᵀλ_∂ + d μ ∇z_p, g, φ_SFB(w_∂, λ_∂), d(z_p − U) + (1 − d)μ]
    and its Jacobian [[K, Gᵀ, −Cᵀ, d∇z_p], [G, 0, 0, 0], [(ŵ/ρ − 1)C, 0, diag(c(ŵ/ρ − 1) +
    λ/ρ − 1), 0], [d∇z_pᵀ, 0, 0, 1 − d]] (MODEL.md §11), ŵ = w + cλ with the contact
    compliance c."""
    model = kkt_model
    eps = model.options.contact_smoothing
    c = model.options.contact_compliance
    assert c > 0.0  # the default: the compliance terms are checked below
    d = 1.0 if load.is_displacement_controlled else 0.0
    nq, ng, nc = model.n_coordinates, model.n_guides, model.n_contacts
    for q in kkt_configs:
        z = _random_z(model, q, rng)
        _, lam, lam_c, mu = model.split(z)
        g_jac = model.constraint_jacobian(q)
        c_jac = model.contact_jacobian(q)
        dzp = model.load_gradient(q)
        w = model.contact_gaps(q)
        r = model.residual(z, load)
        r1 = model.gradient(q) - load.force * dzp + g_jac.T @ lam - c_jac.T @ lam_c + d * mu * dzp
        scale = max(1.0, np.abs(r1).max())
        np.testing.assert_allclose(r[:nq], r1, atol=1e-11 * scale)
        np.testing.assert_allclose(r[nq : nq + ng], model.constraints(q), atol=1e-14)
        np.testing.assert_allclose(
            r[nq + ng : nq + ng + nc], np.asarray(sfb(w + c * lam_c, lam_c, eps)), atol=1e-14
        )
        expected_last = d * (model.load_displacement(q) - load.displacement) + (1 - d) * mu
        assert r[-1] == pytest.approx(expected_last, abs=1e-13)

        jac = model.jacobian(z, load)
        w_hat = w + c * lam_c
        rho = np.sqrt(w_hat**2 + lam_c**2 + eps**2)
        sl = slice(nq + ng, nq + ng + nc)
        k = model.lagrangian_hessian(z, load)
        np.testing.assert_allclose(jac[:nq, :nq], k, atol=1e-10 * max(1.0, np.abs(k).max()))
        np.testing.assert_allclose(jac[:nq, nq : nq + ng], g_jac.T, atol=1e-12)
        np.testing.assert_allclose(jac[:nq, sl], -c_jac.T, atol=1e-12)
        np.testing.assert_allclose(jac[:nq, -1], d * dzp, atol=1e-12)
        np.testing.assert_allclose(jac[nq : nq + ng, :nq], g_jac, atol=1e-12)
        np.testing.assert_allclose(jac[nq : nq + ng, nq:], 0.0, atol=0)
        np.testing.assert_allclose(jac[sl, :nq], (w_hat / rho - 1)[:, None] * c_jac, atol=1e-11)
        np.testing.assert_allclose(
            jac[sl, sl], np.diag(c * (w_hat / rho - 1) + lam_c / rho - 1), atol=1e-12
        )
        np.testing.assert_allclose(jac[sl, nq : nq + ng], 0.0, atol=0)
        np.testing.assert_allclose(jac[-1, :nq], d * dzp, atol=1e-12)
        assert jac[-1, -1] == pytest.approx(1 - d, abs=0)


def test_sfb_encodes_complementarity():
    """φ(w, λ) = 0 ⇔ w, λ > 0 and wλ = ε²/2 (SI Eq. sfb)."""
    eps = 1e-6
    for w in (1e-9, 1e-6, 1e-3, 0.5):
        lam = eps**2 / (2 * w)
        assert float(sfb(w, lam, eps)) == pytest.approx(0.0, abs=1e-15 * max(1.0, lam, w) + 1e-18)
    assert float(sfb(-0.1, 0.0, eps)) > 0  # penetration is penalised
    assert float(sfb(0.1, 0.1, eps)) < 0  # open gap with force: not a solution
    assert float(sfb(0.0, -0.1, eps)) > 0  # tensile contact force: not a solution


@pytest.mark.parametrize("name", ["model1", "model6"])
def test_hessian_at_reference_state(name, request):
    """At q = 0 every field is uniform (w ≡ 0); the Hessian must still equal the finite
    difference of the gradient (the energy is smooth there: no breakpoint at w = 0)."""
    m = request.getfixturevalue(name)
    q = m.zeros()
    _close(m.hessian(q), _fd(m.gradient, q))
