"""The bordered banded solve of the KKT Jacobian (:mod:`biplan.solvers.bordered`, the layout of
:mod:`biplan.model.system.ordering`): its band substitutions against LAPACK's ``dgbtrs``, and
against dense LU: random bordered banded matrices and
the real KKT Jacobians of 6 and 24 modules at rest, under an end force and under displacement
control (relative residual ≤ 1e-12), singular systems reported as NaN, the
Levenberg–Marquardt step against the normal equations, the Jacobian written in place and
within the layout's pattern, and the Newton of a long tube reaching the same equilibrium with
the structure as without it."""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan.model.params import Load
from biplan.model.system import assemble, ordering
from biplan.options import ChainOffset, ContactForm, ModelOptions
from biplan.solvers import bordered, iteration
from biplan.solvers.levenberg import lm_direction
from conftest import make_tube

LOADS = {
    "rest": Load(0.0, 0.0, 0.0),
    "force 1 N": Load(1.0, 0.0, 0.0),
    "displacement 0.2 N mm": Load(0.0, 1.0, 1.0),
}


def _relative_residual(a: np.ndarray, x: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a @ x - b) / np.linalg.norm(b))


def _backward_error(a: np.ndarray, x: np.ndarray, b: np.ndarray) -> float:
    """‖a x − b‖∞ / (‖a‖∞ ‖x‖∞ + ‖b‖∞)."""
    res = np.max(np.abs(a @ x - b))
    return float(res / (np.max(np.abs(a).sum(axis=1)) * np.max(np.abs(x)) + np.max(np.abs(b))))


def _as_good_as_dense(a: np.ndarray, x: np.ndarray, b: np.ndarray) -> None:
    """Relative residual ≤ 1e-12, or (at rest, where J is ill-conditioned, cond ≈ 4e9, and dense
    LU itself leaves ≈ 1e-10) within 4× dense LU's; backward error ≤ 1e-15."""
    dense = _relative_residual(a, np.linalg.solve(a, b), b)
    assert _relative_residual(a, x, b) <= max(1e-12, 4.0 * dense)
    assert _backward_error(a, x, b) <= 1e-15


def _bordered_matrix(
    rng: np.random.Generator, m: int, k: int, kl: int, ku: int
) -> tuple[np.ndarray, np.ndarray]:
    """A random (m + k)² matrix, banded on m inner unknowns (shuffled) with a dense border of
    k, and its layout order."""
    n = m + k
    band = np.zeros((n, n))
    for i in range(m):
        for j in range(max(0, i - kl), min(m, i + ku + 1)):
            band[i, j] = rng.normal()
        band[i, i] += 4.0
    band[m:, :] = rng.normal(size=(k, n))
    band[:, m:] = rng.normal(size=(n, k))
    perm = rng.permutation(n)  # unknown perm[p] sits at position p of the band order
    a = np.empty((n, n))
    a[np.ix_(perm, perm)] = band
    return a, perm.astype(np.int64)


def _direction(a, b, order, band, structured):
    """``bordered.direction``'s x, its second output checked to be the product a x (the
    Newton's slope takes it)."""
    x, ax = bordered.direction(a, b, order, band, structured)
    if np.all(np.isnan(x)):  # singular
        assert np.all(np.isnan(ax))
        return x
    expected = a @ x
    scale = np.max(np.abs(expected))
    assert np.allclose(ax, expected, rtol=1e-13, atol=1e-13 * scale)
    return x


@pytest.mark.parametrize(("m", "k", "kl", "ku"), [(40, 3, 2, 5), (200, 12, 6, 6), (90, 0, 4, 1)])
def test_random_bordered_banded_matrices(rng, m, k, kl, ku):
    a, order = _bordered_matrix(rng, m, k, kl, ku)
    b = rng.normal(size=m + k)
    x, ok = bordered.banded_solve(a, b, order, m, kl, ku)
    assert ok
    assert _relative_residual(a, x, b) <= 1e-12
    band = np.array([m, kl, ku])
    assert np.allclose(_direction(a, b, order, band, True), np.linalg.solve(a, b))


@pytest.mark.parametrize(
    ("m", "kl", "ku", "nrhs"), [(40, 6, 6, 7), (97, 13, 13, 51), (30, 0, 3, 2)]
)
def test_band_factor_and_substitutions_equal_lapack(rng, m, kl, ku, nrhs):
    """``bordered._factor_solve`` (LAPACK's ``dgbtrf``, then the substitutions of
    ``_substitute`` for every right-hand side at once) against SciPy's ``dgbtrf`` +
    ``dgbtrs`` pair, which solves them one at a time, with row interchanges (a weak
    diagonal)."""
    from scipy.linalg import lapack

    dense = np.zeros((m, m))
    for i in range(m):
        for j in range(max(0, i - kl), min(m, i + ku + 1)):
            dense[i, j] = rng.normal()
    dense += 0.05 * np.diag(rng.normal(size=m))
    rhs = rng.normal(size=(nrhs, m))
    lapack_ab = np.zeros((2 * kl + ku + 1, m))  # LAPACK's AB, rows kl … for the band
    for j in range(m):
        for i in range(max(0, j - ku), min(m, j + kl + 1)):
            lapack_ab[kl + ku + i - j, j] = dense[i, j]
    lu, piv, info = lapack.dgbtrf(lapack_ab, kl, ku)
    assert info == 0
    assert kl == 0 or np.any(piv != np.arange(m))  # rows interchanged (SciPy's 0-based pivots)
    expected = np.stack([lapack.dgbtrs(lu, kl, ku, b, piv)[0] for b in rhs])
    ab, got = np.ascontiguousarray(lapack_ab.T), np.ascontiguousarray(rhs.T)
    assert bordered._factor_solve(ab, kl, ku, got)
    got = got.T
    assert np.max(np.abs(got - expected)) <= 1e-12 * np.max(np.abs(expected))
    for x, b in zip(got, rhs, strict=True):
        assert _backward_error(dense, x, b) <= 1e-14


def test_an_entry_outside_the_band_falls_back_to_dense_lu(rng):
    a, order = _bordered_matrix(rng, 60, 4, 3, 3)
    a[order[0], order[50]] = 5.0  # outside the layout's band: the check rejects the result
    b = rng.normal(size=64)
    x = _direction(a, b, order, np.array([60, 3, 3]), True)
    assert _relative_residual(a, x, b) <= 1e-12


def test_singular_systems_report_nan(rng):
    a, order = _bordered_matrix(rng, 50, 3, 2, 2)
    a[order[10], :] = 0.0  # a zero row: singular
    b = rng.normal(size=53)
    x = _direction(a, b, order, np.array([50, 2, 2]), True)
    assert np.all(np.isnan(x))
    assert np.all(np.isnan(bordered.dense_solve(a, b)))


@pytest.fixture(scope="module", params=[6, 24])
def tube_model(request) -> biplan.Model:
    return biplan.Model(make_tube(request.param))


@pytest.mark.parametrize("case", LOADS)
def test_kkt_jacobians_at_rest_and_under_load(tube_model, case):
    load = LOADS[case]
    n = tube_model.layout.n_modules
    load = Load(load.force, 0.2 * n * load.displacement, load.displacement_control)
    data = tube_model.system().data
    order, band = ordering.solve_layout(data, min_unknowns=0, min_gain=0.0)
    assert sorted(order) == list(range(tube_model.n_unknowns))
    ref = biplan.relaxed_reference(tube_model)
    sol = biplan.solve_equilibrium(tube_model, biplan.Newton(), ref, load)
    assert sol.converged
    system = tube_model.system(load)
    jac = system.jacobian(sol.z)
    b = system.residual(ref.z) + 1.0
    x, ok = bordered.banded_solve(jac, b, order, *band)
    assert ok
    _as_good_as_dense(jac, x, b)
    _as_good_as_dense(jac, _direction(jac, b, order, band, True), b)
    # a right-hand side in the range of J's large singular values
    exact = np.random.default_rng(1).normal(size=b.size)
    rhs = jac @ exact
    assert _relative_residual(jac, _direction(jac, rhs, order, band, True), rhs) <= 1e-12
    # the bordered path system: one more unknown, in the border
    border = np.concatenate([np.ones(jac.shape[0]), [2.0]])
    big = np.block([[jac, b[:, None]], [border[None, :-1], border[-1:, None]]])
    rhs = np.concatenate([b, [1.0]])
    _as_good_as_dense(big, _direction(big, rhs, order, band, True), rhs)
    # the Levenberg–Marquardt step: the augmented system against the normal equations
    for damping in (1e-3, 1.0, 1e4):
        step, ok = bordered.lm_solve(jac, b, damping, order, *band)
        assert ok
        dense = lm_direction(jac, b, damping)
        assert np.linalg.norm(step - dense) <= 1e-7 * np.linalg.norm(dense)


def test_the_jacobian_is_written_in_place_and_within_the_pattern(tube_model):
    """``assemble.evaluate_into`` writes ∂r/∂z into the leading block of a larger array of
    zeros (as the bordered path system and the Newton's reused arrays do) and nothing else;
    at an equilibrium under each load, every entry outside the layout's symmetric pattern is
    rounding (the bordered solve ignores it; its backward-error check sees it)."""
    n = tube_model.layout.n_modules
    pattern = ordering.jacobian_pattern(tube_model.system().data)
    assert (pattern != pattern.T).nnz == 0
    ref = biplan.relaxed_reference(tube_model)
    for load in LOADS.values():
        load = Load(load.force, 0.2 * n * load.displacement, load.displacement_control)
        sol = biplan.solve_equilibrium(tube_model, biplan.Newton(), ref, load)
        system = tube_model.system(load)
        jac = system.jacobian(sol.z)
        n_z = jac.shape[0]
        big = np.zeros((n_z + 2, n_z + 2))
        out = assemble.evaluate_into(system.data, sol.z, system.load, True, big)
        assert out[1] is big
        assert np.array_equal(big[:n_z, :n_z], jac)
        assert not big[n_z:].any() and not big[:, n_z:].any()
        assert np.array_equal(out[0], system.residual(sol.z))
        rows, cols = np.nonzero(jac)
        outside = ~np.asarray(pattern[rows, cols]).ravel()
        # only rounding is outside: terms of the chain that cancel (≈ 1e-18 … 2e-16)
        assert np.max(np.abs(jac[rows[outside], cols[outside]]), initial=0.0) <= 1e-14 * np.max(
            np.abs(jac)
        )


@pytest.mark.parametrize(
    "tube",
    [
        lambda: make_tube(6),
        lambda: biplan.designs.fully_bistable(n_modules=5),
        lambda: biplan.designs.semi_bistable(ModelOptions(contact=ContactForm.MINIMUM)),
        lambda: make_tube(4).with_options(chain_offset=ChainOffset.PAPER),
    ],
    ids=["uniform", "fully bistable, edge fit", "minimum contact", "paper chain offset"],
)
def test_the_pattern_of_one_load_is_the_union_of_the_force_and_displacement_patterns(tube):
    """ordering.PATTERN_LOAD (an end force with the control half-way) carries every entry of
    the Jacobians under a force alone and under displacement control alone, at the random
    states jacobian_pattern draws, and no other but rounding: terms of the chain that cancel
    (at most 1e-14 of the largest entry) come and go with the load."""
    data = biplan.Model(tube()).system().data
    n_q, n_g, n_c = (int(v) for v in data.sizes)
    n_z = n_q + n_g + n_c + 1
    rng = np.random.default_rng(0)  # the states of jacobian_pattern(data, seed=0)
    union = np.zeros((n_z, n_z), dtype=bool)
    structural = np.zeros((n_z, n_z), dtype=bool)  # the union without rounding
    mixed = np.zeros((n_z, n_z))  # |J| under PATTERN_LOAD, the larger of the two states
    for _ in range(2):
        z = np.concatenate([rng.uniform(-0.1, 0.1, n_q), rng.uniform(0.5, 1.0, n_g + n_c + 1)])
        for load in ((1.0, 0.0, 0.0), (0.0, 0.5, 1.0), ordering.PATTERN_LOAD):
            out = assemble.evaluate_into(data, z, np.array(load), True, np.zeros((n_z, n_z)))
            jac = np.abs(out[1])
            if load == ordering.PATTERN_LOAD:
                mixed = np.maximum(mixed, jac / jac.max())
            else:
                union |= jac != 0.0
                structural |= jac > 1e-14 * jac.max()
    pattern = ordering.jacobian_pattern(data).toarray()
    assert structural[n_z - 1, :n_q].any() and structural[:n_q, n_z - 1].any()  # u control
    assert not (structural & ~(pattern | pattern.T)).any()
    extra = pattern & ~(union | union.T)
    assert np.all(np.maximum(mixed, mixed.T)[extra] <= 1e-14)


def test_layout_by_size():
    """Dense LU below ordering.MIN_UNKNOWNS; from 12 modules the frame angles and μ form the
    border and the rest has bandwidth 6."""
    small = biplan.Model(make_tube(6)).system().data
    assert small.solve_order.size == 0 and small.solve_band.size == 0
    data = biplan.Model(make_tube(24)).system().data
    n_z = data.solve_order.size
    n_inner, kl, ku = data.solve_band
    assert n_z == 253 and n_z - n_inner == 13 and kl <= 8 and ku <= 8


def test_newton_reaches_the_same_equilibrium_with_and_without_the_structure():
    model = biplan.Model(make_tube(24))
    ref = biplan.relaxed_reference(model)
    load = Load(0.0, 6.0, 1.0)
    system = model.system(load)
    dense = system.data._replace(
        solve_order=np.zeros(0, dtype=np.int64), solve_band=np.zeros(0, dtype=np.int64)
    )
    settings = iteration.newton_settings(1e-9, 60, 8, 1e-4, 0)
    outs = [
        iteration.solve(
            d,
            system.load,
            ref.z,
            settings,
            iteration.NO_BORDER,
            0.0,
            iteration.NO_STEP,
            iteration.NO_DEFLATION,
        )
        for d in (system.data, dense)
    ]
    assert outs[0][5] == outs[1][5] == 0  # converged
    assert np.max(np.abs(outs[0][0] - outs[1][0])) < 1e-8
