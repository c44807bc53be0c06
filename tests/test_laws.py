"""Fold laws against their definitions (MODEL.md §1–2; main Eqs. stiffness,
field_constitutive_energy, field_strain_energy).

F = ∫k, Ψ = ∫F, P = ∫Ψ and the exact field energy ∫_0^L Ψ(w(x)) dx are checked by adaptive
quadrature, the characteristic points against the closed forms of MODEL.md §1.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import quad

import biplan
from biplan import ConfigError, LinearLaw, TransitionReading, TrilinearLaw

CALIB = TrilinearLaw(stiffness=(0.9, -0.2, 0.6), transitions=(0.2, 1.3))
#: A second, more asymmetric law (the fully bistable design's helical law).
STEEP = TrilinearLaw(stiffness=(2.0, -1.6, 1.0), transitions=(0.05, 0.3))
#: A monostable trilinear law (softening, F2 > 0).
SOFT = TrilinearLaw(stiffness=(1.0, 0.1, 2.0), transitions=(0.3, 0.9))
LAWS = [CALIB, STEEP, SOFT]
LAW_IDS = ["calibration", "steep", "monostable"]


def _k(law, w):
    k1, k2, k3, w1, w2 = law.coefficients
    return k1 if w < w1 else (k2 if w < w2 else k3)


def _integral(f, a, b, points):
    """∫_a^b f with the integrand's kinks as break points (signed)."""
    lo, hi = min(a, b), max(a, b)
    inner = [p for p in points if lo < p < hi]
    val, _ = quad(f, lo, hi, points=inner or None, epsabs=1e-14, epsrel=1e-13, limit=200)
    return val if b >= a else -val


_PSI: dict = {}


def _jitted_psi(law):
    """Ψ of the law as a compiled scalar function (fast pointwise calls for quadrature)."""
    if law not in _PSI:
        _PSI[law] = jax.jit(law.energy_density)
    return _PSI[law]


def _quad_field_energy(law, w0, w1, length):
    """∫_0^L Ψ((1 − x/L) w0 + (x/L) w1) dx by adaptive quadrature, split where w crosses a
    breakpoint."""
    bps = law.coefficients[3:]
    if w1 == w0:
        return length * float(law.energy_density(w0))
    xs = [length * (b - w0) / (w1 - w0) for b in bps]
    xs = [x for x in xs if 0.0 < x < length]

    psi = _jitted_psi(law)

    def integrand(x):
        return float(psi(w0 + (w1 - w0) * x / length))

    val, _ = quad(integrand, 0.0, length, points=xs or None, epsabs=1e-15, epsrel=1e-13, limit=200)
    return val


# --------------------------------------------------------------------------------------------
# F, Ψ, P against their definitions
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("law", LAWS, ids=LAW_IDS)
def test_force_energy_antiderivative_are_successive_integrals(law):
    bps = law.coefficients[3:]
    ws = np.array([-0.7, -0.1, 0.0, 0.03, 0.1, 0.2, 0.25, 0.6, 1.1, 1.3, 1.5, 2.4, 3.0])
    for w in ws:
        f_ref = _integral(lambda x: _k(law, x), 0.0, w, bps)
        psi_ref = _integral(lambda x: float(law.force(x)), 0.0, w, bps)
        p_ref = _integral(lambda x: float(law.energy_density(x)), 0.0, w, bps)
        assert law.force(w) == pytest.approx(f_ref, rel=1e-12, abs=1e-13)
        assert law.energy_density(w) == pytest.approx(psi_ref, rel=1e-11, abs=1e-13)
        assert law.antiderivative(w) == pytest.approx(p_ref, rel=1e-10, abs=1e-13)
        assert law.differential_stiffness(w) == _k(law, w)


@pytest.mark.parametrize("law", LAWS, ids=LAW_IDS)
def test_law_functions_are_continuous_at_breakpoints(law):
    """k jumps; F is C⁰, Ψ is C¹ and P is C² across each breakpoint (MODEL.md §1)."""
    for b in law.coefficients[3:]:
        lo, hi = b - 1e-9, b + 1e-9
        assert law.force(lo) == pytest.approx(law.force(hi), abs=1e-8)
        assert law.energy_density(lo) == pytest.approx(law.energy_density(hi), abs=1e-9)
        assert law.antiderivative(lo) == pytest.approx(law.antiderivative(hi), abs=1e-9)
        # one-sided derivatives of Ψ equal F (C¹), of P equal Ψ (C¹)
        h = 1e-6
        dpsi_left = (law.energy_density(b - h) - law.energy_density(b - 2 * h)) / h
        dpsi_right = (law.energy_density(b + 2 * h) - law.energy_density(b + h)) / h
        assert dpsi_left == pytest.approx(dpsi_right, abs=1e-5)
        assert dpsi_left == pytest.approx(law.force(b), abs=1e-5)


def test_vectorised_and_jax_inputs_agree_with_scalars():
    ws = np.linspace(-0.5, 2.5, 31)
    vec = CALIB.energy_density(ws)
    assert isinstance(vec, np.ndarray) and vec.shape == ws.shape
    scal = np.array([CALIB.energy_density(float(w)) for w in ws])
    np.testing.assert_array_equal(vec, scal)
    jx = CALIB.energy_density(jnp.asarray(ws))
    assert isinstance(jx, jax.Array)
    np.testing.assert_allclose(np.asarray(jx), vec, rtol=0, atol=0)
    # F is the JAX derivative of Ψ and k the derivative of F (off the breakpoints)
    ws_off = ws[np.min(np.abs(ws[:, None] - np.array([0.2, 1.3])[None]), axis=1) > 1e-6]
    dpsi = jax.vmap(jax.grad(lambda w: CALIB.energy_density(w)))(jnp.asarray(ws_off))
    np.testing.assert_allclose(np.asarray(dpsi), CALIB.force(ws_off), rtol=1e-14, atol=1e-15)
    dF = jax.vmap(jax.grad(lambda w: CALIB.force(w)))(jnp.asarray(ws_off))
    np.testing.assert_allclose(np.asarray(dF), CALIB.differential_stiffness(ws_off), rtol=1e-14)


# --------------------------------------------------------------------------------------------
# Exact field energy (MODEL.md §2)
# --------------------------------------------------------------------------------------------
def _field_cases(rng):
    cases = [
        (0.0, 2.0),  # crosses both breakpoints
        (2.0, 0.0),  # reversed
        (-0.4, 1.8),  # negative start, both breakpoints
        (-0.3, -0.05),  # entirely negative (branch-1 continuation)
        (0.25, 1.25),  # inside the spinodal
        (0.1, 0.7),  # crosses w1 only
        (1.0, 1.6),  # crosses w2 only
        (0.2, 1.3),  # ends exactly on the breakpoints
        (1.3, 0.2),
        (0.2, 0.2),
        (1.3, 1.3),
    ]
    for w0 in (0.05, 0.2, 0.7, 1.3, 1.45, -0.2):
        for d in (1e-3, 1e-7, 1e-10, 0.0):
            cases += [(w0, w0 + d), (w0 + d, w0), (w0 - d / 2, w0 + d / 2)]
    cases += [tuple(x) for x in rng.uniform(-0.5, 2.5, size=(40, 2))]
    return cases


@pytest.mark.parametrize("law", LAWS, ids=LAW_IDS)
def test_field_energy_matches_adaptive_quadrature(law, rng):
    cases = _field_cases(rng)
    w0 = np.array([c[0] for c in cases])
    w1 = np.array([c[1] for c in cases])
    lengths = rng.uniform(0.5, 13.0, size=len(cases))
    got = law.field_energy(w0, w1, lengths)
    assert got.shape == w0.shape
    for i in range(len(cases)):
        ref = _quad_field_energy(law, w0[i], w1[i], lengths[i])
        assert got[i] == pytest.approx(ref, rel=1e-10, abs=1e-13), (w0[i], w1[i])
        # symmetric in the orientation of the field
        assert law.field_energy(w1[i], w0[i], lengths[i]) == pytest.approx(got[i], rel=1e-13)


def test_field_energy_exact_closed_form_p_difference(rng):
    """Π_S = L [P(wL) − P(w0)] / (wL − w0) for well separated ends (MODEL.md §2)."""
    for _ in range(50):
        w0, w1 = rng.uniform(-0.5, 2.5, 2)
        if abs(w1 - w0) < 0.05:
            continue
        L = rng.uniform(1.0, 10.0)
        ref = L * (CALIB.antiderivative(w1) - CALIB.antiderivative(w0)) / (w1 - w0)
        assert CALIB.field_energy(w0, w1, L) == pytest.approx(ref, rel=1e-11, abs=1e-14)


def test_field_energy_is_smooth_as_the_field_becomes_uniform():
    """E(w0, w0 + d) = L[Ψ(w0) + F(w0) d/2 + k d²/6] for small d without a breakpoint, and
    it varies continuously through the small-|d| switch, also straddling a breakpoint."""
    L = 6.3
    for w0 in (0.1, 0.7, 1.45, -0.2):
        for d in (1e-2, 1e-3, 1e-5, 1e-7, 1e-10, 0.0, -1e-7, -1e-3):
            k = CALIB.differential_stiffness(w0)
            ref = L * (CALIB.energy_density(w0) + CALIB.force(w0) * d / 2 + k * d * d / 6)
            assert CALIB.field_energy(w0, w0 + d, L) == pytest.approx(ref, rel=1e-13, abs=1e-16)
    # straddling a breakpoint: below the split tolerance the one-piece form has an error
    # O(d² Δk) per unit length (MODEL.md §2); above it the split is exact
    dk = abs(CALIB.stiffness[0] - CALIB.stiffness[1]) + abs(CALIB.stiffness[1] - CALIB.stiffness[2])
    for b in (0.2, 1.3):
        ds = np.array([3e-6, 1.01e-6, 1e-6, 0.99e-6, 5e-7, 1e-8, 1e-12, 0.0])
        for shift in (0.0, 0.3, -0.45):
            w0 = b - (0.5 + shift) * ds
            e = CALIB.field_energy(w0, w0 + ds, L)
            ref = np.array(
                [_quad_field_energy(CALIB, a, a + d, L) for a, d in zip(w0, ds, strict=True)]
            )
            assert np.all(np.abs(e - ref) <= L * dk * ds**2 / 8 + 1e-14 * np.abs(ref))


def test_field_energy_gradient_and_hessian_by_autodiff():
    """The solver differentiates the field energy with JAX: gradient = closed form of
    d/dwL {L[P(wL) − P(w0)]/(wL − w0)}, finite and equal to L F/2 at w0 = wL, and the
    Hessian of a linear law is L k/6 [[2, 1], [1, 2]] everywhere (incl. w0 = wL)."""
    L = 7.2
    grad = jax.jit(jax.grad(lambda a, b: CALIB.field_energy(a, b, L), argnums=(0, 1)))
    for w0, w1 in [(0.0, 2.0), (0.5, 0.9), (1.4, 0.1), (-0.2, 0.15), (0.1, 1.2)]:
        g0, g1 = (float(v) for v in grad(jnp.float64(w0), jnp.float64(w1)))
        dp = CALIB.antiderivative(w1) - CALIB.antiderivative(w0)
        ref1 = L * (CALIB.energy_density(w1) * (w1 - w0) - dp) / (w1 - w0) ** 2
        ref0 = L * (dp - CALIB.energy_density(w0) * (w1 - w0)) / (w1 - w0) ** 2
        assert g1 == pytest.approx(ref1, rel=1e-10, abs=1e-13)
        assert g0 == pytest.approx(ref0, rel=1e-10, abs=1e-13)
    for w in (0.0, 0.1, 0.2, 0.7, 1.3, 1.9):
        g0, g1 = (float(v) for v in grad(jnp.float64(w), jnp.float64(w)))
        assert np.isfinite(g0) and np.isfinite(g1)
        assert g0 == pytest.approx(L * CALIB.force(w) / 2, rel=1e-12, abs=1e-15)
        assert g1 == pytest.approx(L * CALIB.force(w) / 2, rel=1e-12, abs=1e-15)
    lin = LinearLaw(1.3)
    hess = jax.jit(jax.hessian(lambda v: lin.field_energy(v[0], v[1], L)))
    for v in ([0.0, 1.0], [-0.2, 0.5], [2.0, 2.0 + 1e-9], [0.3, 0.3 - 1e-12]):
        h = np.asarray(hess(jnp.asarray(v, dtype=float)))
        np.testing.assert_allclose(h, L * 1.3 / 6 * np.array([[2, 1], [1, 2]]), rtol=1e-12)


@pytest.mark.parametrize("w", [0.0, 0.3, 1.7])
def test_field_energy_hessian_of_a_uniform_field(w):
    """Hessian of E(w0, wL) at w0 = wL: for a linear law it is L k/6 [[2, 1], [1, 2]] (the
    value just off the diagonal; E is a quadratic polynomial)."""
    L, k = 7.2, 1.3
    lin = LinearLaw(k)
    hess = jax.jit(jax.hessian(lambda v: lin.field_energy(v[0], v[1], L)))
    h = np.asarray(hess(jnp.asarray([w, w])))
    np.testing.assert_allclose(h, L * k / 6 * np.array([[2, 1], [1, 2]]), rtol=1e-12)


# --------------------------------------------------------------------------------------------
# Characteristic points (MODEL.md §1)
# --------------------------------------------------------------------------------------------
def test_calibration_law_characteristic_points():
    law = CALIB
    assert law.peak_force == pytest.approx(0.18, abs=1e-14)
    assert law.valley_force == pytest.approx(-0.04, abs=1e-14)
    assert law.is_bistable
    assert law.wells() == pytest.approx((0.0, 1.3 + 0.04 / 0.6), abs=1e-14)
    assert law.wells()[1] == pytest.approx(1.3667, abs=1e-4)
    assert law.hilltop() == pytest.approx(1.10, abs=1e-14)
    assert law.spinodal() == (0.2, 1.3)
    psi_b, dpsi = law.barrier()
    assert dpsi == pytest.approx(0.0053, abs=1e-4)
    assert psi_b == pytest.approx(0.099, abs=1e-12)
    assert law.energy_density(law.wells()[1]) == pytest.approx(0.0937, abs=1e-4)
    # the wells and the hilltop are zeros of F; Ψ has minima at the wells
    for w in (*law.wells(), law.hilltop()):
        assert law.force(w) == pytest.approx(0.0, abs=1e-14)
    ws = law.wells()[1]
    assert law.energy_density(ws + 1e-3) > law.energy_density(ws)
    assert law.energy_density(ws - 1e-3) > law.energy_density(ws)
    wb = law.hilltop()
    assert law.energy_density(wb + 1e-3) < law.energy_density(wb)
    assert law.energy_density(wb - 1e-3) < law.energy_density(wb)


@pytest.mark.parametrize("law", [CALIB, STEEP], ids=["calibration", "steep"])
def test_closed_forms_of_wells_for_general_bistable_law(law):
    k1, k2, k3, w1, w2 = law.coefficients
    f1 = k1 * w1
    f2 = f1 + k2 * (w2 - w1)
    assert law.peak_force == pytest.approx(f1, rel=1e-14)
    assert law.valley_force == pytest.approx(f2, rel=1e-14)
    assert law.hilltop() == pytest.approx(w1 + f1 / abs(k2), rel=1e-14)
    assert law.wells()[1] == pytest.approx(w2 + abs(f2) / k3, rel=1e-14)
    # the peak and valley are the extreme forces on [0, w_s]
    grid = np.union1d(np.linspace(0.0, law.wells()[1], 20001), law.spinodal())
    assert np.max(law.force(grid)) == pytest.approx(f1, rel=1e-12)
    assert np.min(law.force(grid)) == pytest.approx(f2, rel=1e-12)


def test_monostable_law_has_one_well_and_no_hilltop():
    assert not SOFT.is_bistable
    assert SOFT.wells() == (0.0,)
    with pytest.raises(ConfigError):
        SOFT.hilltop()
    with pytest.raises(ConfigError):
        SOFT.require_bistable("laws.circular")
    # k2 < 0 but F2 > 0: negative stiffness without a second well
    shallow = TrilinearLaw(stiffness=(0.9, -0.1, 0.6), transitions=(0.2, 1.3))
    assert shallow.valley_force > 0 and not shallow.is_bistable
    assert shallow.wells() == (0.0,)
    assert np.all(shallow.force(np.linspace(1e-6, 5.0, 1000)) > 0)


@pytest.mark.parametrize("law", [CALIB, STEEP], ids=["calibration", "steep"])
def test_uniformly_elongated_field_energy_derivatives(law):
    """A single field under uniform elongation w0 = w1 = w: d(E)/dw / L = F(w), its zeros are
    the wells and the hilltop, minima exactly at the wells, and d²E/dw² < 0 exactly on the
    spinodal (w1, w2)."""
    L = 12.566
    e = jax.jit(lambda w: law.field_energy(w, w, L))
    de = jax.jit(jax.vmap(jax.grad(lambda w: law.field_energy(w, w, L))))
    d2e = jax.jit(jax.vmap(jax.grad(jax.grad(lambda w: law.field_energy(w, w, L)))))
    ws = np.linspace(-0.3, 2.5, 281)
    bps = np.array(law.coefficients[3:])
    ws = ws[np.min(np.abs(ws[:, None] - bps[None]), axis=1) > 1e-5]
    np.testing.assert_allclose(np.asarray(de(ws)) / L, law.force(ws), rtol=1e-12, atol=1e-15)
    # finite differences of the public (non-JAX) evaluation agree as well
    h = 1e-6
    fd = (law.field_energy(ws + h, ws + h, L) - law.field_energy(ws - h, ws - h, L)) / (2 * h)
    np.testing.assert_allclose(fd / L, law.force(ws), rtol=1e-6, atol=1e-9)
    curv = np.asarray(d2e(ws))
    in_spinodal = (bps[0] < ws) & (ws < bps[1])
    np.testing.assert_array_equal(curv < 0, in_spinodal)
    np.testing.assert_allclose(curv / L, law.differential_stiffness(ws), rtol=1e-12)
    # the zeros of dE/dw
    np.testing.assert_allclose(de(np.array([*law.wells(), law.hilltop()])), 0.0, atol=1e-13)
    # sign change pattern: + between 0 and w_b, − between w_b and w_s, + beyond w_s
    wb, ws_ = law.hilltop(), law.wells()[1]
    signs = np.sign(np.asarray(de(np.array([-0.1, 0.5 * wb, 0.5 * (wb + ws_), ws_ + 0.1]))))
    np.testing.assert_array_equal(signs, [-1, 1, -1, 1])
    # minima at the wells, maximum at the hilltop
    for w, kind in ((0.0, "min"), (ws_, "min"), (wb, "max")):
        sgn = 1.0 if kind == "min" else -1.0
        for dw in (1e-3, -1e-3):
            assert sgn * (float(e(w + dw)) - float(e(w))) > 0


# --------------------------------------------------------------------------------------------
# Phase fractions
# --------------------------------------------------------------------------------------------
def test_phase_fractions_geometry(rng):
    law = CALIB
    np.testing.assert_allclose(law.phase_fractions(0.0, 2.0), [0.1, 0.55, 0.35], atol=1e-15)
    np.testing.assert_allclose(law.phase_fractions(2.0, 0.0), [0.1, 0.55, 0.35], atol=1e-15)
    np.testing.assert_allclose(law.phase_fractions(0.0, 0.1), [1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(law.phase_fractions(0.5, 0.5), [0, 1, 0], atol=0)
    np.testing.assert_allclose(law.phase_fractions(1.5, 1.5), [0, 0, 1], atol=0)
    np.testing.assert_allclose(law.phase_fractions(-1.0, 0.6), [0.75, 0.25, 0.0], atol=1e-15)
    w0 = rng.uniform(-0.5, 2.5, 200)
    w1 = rng.uniform(-0.5, 2.5, 200)
    fr = law.phase_fractions(w0, w1)
    assert fr.shape == (200, 3)
    np.testing.assert_allclose(fr.sum(axis=1), 1.0, atol=1e-14)
    assert np.all(fr >= 0)
    # compare with sampling the field
    x = np.linspace(0.0, 1.0, 200001)[:, None]
    w = (1 - x) * w0[None, :40] + x * w1[None, :40]
    sampled = np.stack([(w < 0.2).mean(0), ((w >= 0.2) & (w < 1.3)).mean(0), (w >= 1.3).mean(0)])
    np.testing.assert_allclose(fr[:40], sampled.T, atol=2e-5)


# --------------------------------------------------------------------------------------------
# Linear law
# --------------------------------------------------------------------------------------------
def test_linear_law_closed_forms(rng):
    k = 1.3
    law = LinearLaw(k)
    w = rng.uniform(-2.0, 5.0, 50)
    np.testing.assert_allclose(law.force(w), k * w, rtol=1e-14)
    np.testing.assert_allclose(law.energy_density(w), k * w**2 / 2, rtol=1e-13)
    np.testing.assert_allclose(law.antiderivative(w), k * w**3 / 6, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(law.differential_stiffness(w), k)
    w0, w1 = rng.uniform(-1, 3, 50), rng.uniform(-1, 3, 50)
    L = rng.uniform(1, 10, 50)
    np.testing.assert_allclose(
        law.field_energy(w0, w1, L), L * k * (w0**2 + w0 * w1 + w1**2) / 6, rtol=1e-12
    )
    np.testing.assert_allclose(law.phase_fractions(0.0, 3.0), [1, 0, 0])
    assert law.wells() == (0.0,)
    assert not law.is_bistable
    with pytest.raises(ConfigError):
        law.require_bistable()


# --------------------------------------------------------------------------------------------
# Construction and validation
# --------------------------------------------------------------------------------------------
def test_transition_readings():
    a = TrilinearLaw.from_table((0.9, -0.2, 0.6), (0.2, 1.3), TransitionReading.ABSOLUTE)
    assert a.transitions == (0.2, 1.3)
    b = TrilinearLaw.from_table((0.9, -0.2, 0.6), (0.2, 1.3), TransitionReading.BRANCH_LENGTHS)
    assert b.transitions == pytest.approx((0.2, 1.5))
    # MODEL.md §1 alternative numbers: F2 = −0.08 N/mm, w_s = 1.633 mm
    assert b.valley_force == pytest.approx(-0.08, abs=1e-14)
    assert b.wells()[1] == pytest.approx(1.5 + 0.08 / 0.6, abs=1e-14)
    assert b.wells()[1] == pytest.approx(1.633, abs=1e-3)
    c = TrilinearLaw.from_table((0.9, -0.2, 0.6), (0.2, 1.3), "branch_lengths")
    assert c == b
    # under the branch-length reading l2 may be smaller than l1
    d = TrilinearLaw.from_table((0.9, -0.2, 0.6), (0.5, 0.2), "branch_lengths")
    assert d.transitions == pytest.approx((0.5, 0.7))
    with pytest.raises(ConfigError):
        TrilinearLaw.from_table((0.9, -0.2, 0.6), (0.2, 1.3), "sideways")
    with pytest.raises(ConfigError):
        TrilinearLaw.from_table((0.9, -0.2, 0.6), (0.2, 0.0), "branch_lengths")


@pytest.mark.parametrize(
    ("stiffness", "transitions"),
    [
        ((0.0, -0.2, 0.6), (0.2, 1.3)),  # k1 = 0
        ((-0.9, -0.2, 0.6), (0.2, 1.3)),  # k1 < 0
        ((0.9, -0.2, 0.0), (0.2, 1.3)),  # k3 = 0
        ((0.9, -0.2, -0.6), (0.2, 1.3)),  # k3 < 0
        ((0.9, -0.2, 0.6), (1.3, 1.3)),  # w1 = w2
        ((0.9, -0.2, 0.6), (1.3, 0.2)),  # w1 > w2
        ((0.9, -0.2, 0.6), (0.0, 1.3)),  # w1 = 0
        ((0.9, -0.2, 0.6), (-0.2, 1.3)),  # w1 < 0
        ((math.nan, -0.2, 0.6), (0.2, 1.3)),
        ((0.9, math.nan, 0.6), (0.2, 1.3)),
        ((0.9, -0.2, math.inf), (0.2, 1.3)),
        ((0.9, -0.2, 0.6), (0.2, math.nan)),
        ((0.9, -0.2, 0.6), (math.inf, 1.3)),
        ((0.9, -0.2), (0.2, 1.3)),
        ((0.9, -0.2, 0.6), (0.2, 1.3, 2.0)),
        (("a", -0.2, 0.6), (0.2, 1.3)),
    ],
)
def test_trilinear_validation(stiffness, transitions):
    with pytest.raises(ConfigError) as info:
        TrilinearLaw(stiffness=stiffness, transitions=transitions)
    assert isinstance(info.value, ValueError)
    assert isinstance(info.value, biplan.BiplanError)


@pytest.mark.parametrize("k", [0.0, -1.0, math.nan, math.inf, -math.inf, "x", None])
def test_linear_validation(k):
    with pytest.raises(ConfigError):
        LinearLaw(k)
