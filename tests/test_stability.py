"""Stability by the reduced Hessian (main "Equilibrium Stability"; MODEL.md §12).

* the verdict does not depend on the null-space basis (Sylvester's law of inertia);
* on the semi-bistable design the rising phase-1 branch is stable and the symmetric branch past
  the force peak is unstable under displacement control;
* the reduced-Hessian curvature is the curvature of the energy along the constraint manifold;
* uniform fold states at the law's zero-force points have closed-form curvatures H k.
"""

from __future__ import annotations

import numpy as np
import pytest

import biplan
from biplan import ConfigError, Load, Newton, Verdict
from biplan.analysis.stability import active_constraint_jacobian, null_space
from conftest import GEOMETRY, make_tube

H = biplan.Development(**GEOMETRY).circumference


@pytest.fixture(scope="module")
def symmetric_path(model6, reference6):
    """Displacement-controlled path of the semi-bistable tube, warm-started step by step along
    the symmetric branch (no branch switching): {U: Solution}."""
    out = {}
    cur = reference6
    for u_end in np.round(np.arange(0.1, 2.01, 0.1), 10):
        cur = biplan.solve_equilibrium(model6, Newton(), cur, Load.of_displacement(float(u_end)))
        assert cur.converged, (u_end, cur.message)
        out[float(u_end)] = cur
    return out


def _circular_fractions(model, q) -> np.ndarray:
    """(closed, spinodal, open) length fractions of every circular fold, (Nc, 3)."""
    frac = biplan.model.potential.phase_fractions(model.layout, model.params, q)
    return np.asarray(frac)[model.layout.n_modules :]


def _random_orthogonal(rng, n):
    q, r = np.linalg.qr(rng.normal(size=(n, n)))
    return q * np.sign(np.diag(r))


def _inertia(h, tol=1e-8):
    eig = np.linalg.eigvalsh(0.5 * (h + h.T))
    return int(np.sum(eig > tol)), int(np.sum(eig < -tol)), int(np.sum(np.abs(eig) <= tol))


# --------------------------------------------------------------------------------------------
# Semi-bistable design under displacement control
# --------------------------------------------------------------------------------------------
def test_phase_one_branch_is_stable(model6, symmetric_path):
    for u_end in (0.1, 0.5, 1.0):
        sol = symmetric_path[u_end]
        st = biplan.classify(model6, sol)
        assert st.verdict is Verdict.STABLE and st.stable
        assert st.min_eigenvalue > 0.1
        assert st.min_eigenvalue == st.eigenvalues[0]
        assert np.all(np.diff(st.eigenvalues) >= 0)
        # active set: guides and the end constraint → dof = n_q − n_g − 1 − active contacts
        assert st.dof == model6.n_coordinates - model6.n_guides - 1 - st.n_active_contacts


def test_symmetric_branch_past_the_peak_is_unstable(model6, symmetric_path):
    """Past the force peak the folds in series are all on the spinodal: the symmetric state is
    a saddle — the reaction decreases (dF/dU < 0) and the reduced Hessian has a negative
    eigenvalue."""
    forces = np.array([symmetric_path[u].force for u in sorted(symmetric_path)])
    k_peak = int(np.argmax(forces))
    assert 1.0 < sorted(symmetric_path)[k_peak] < 2.0
    sol = symmetric_path[2.0]
    assert sol.force < forces.max()
    st = biplan.classify(model6, sol)
    assert st.verdict is Verdict.UNSTABLE and not st.stable
    assert st.min_eigenvalue < -0.1
    # at least one circular fold is (partly) on the spinodal branch
    law = model6.tube.circular_laws[0]
    fractions = [law.phase_fractions(s, e) for s, e, _ in model6.circular_fields(sol.q)]
    assert max(f[..., 1].max() for f in fractions) > 0.5


def test_stability_changes_once_along_the_path(model6, symmetric_path):
    """Stable until (about) the force peak, unstable after it: the sign of λ_min changes once
    between the last rising and the first falling step."""
    us = sorted(symmetric_path)
    lam = np.array([biplan.classify(model6, symmetric_path[u]).min_eigenvalue for u in us])
    forces = np.array([symmetric_path[u].force for u in us])
    change = np.flatnonzero(np.diff(np.sign(lam)) != 0)
    assert len(change) == 1
    k = int(change[0])
    assert lam[k] > 0 > lam[k + 1]
    # the loss of stability coincides with the force peak (dF/dU = 0 ⇔ zero reduced
    # stiffness for folds in series under displacement control)
    assert int(np.argmax(forces)) in (k, k + 1)


def test_transformation_starts_distributed_over_every_fold(model6, symmetric_path):
    """Before it snaps, the semi-bistable tube transforms in every circular fold at once: the
    last stable state before the force peak (U = 1.5 mm, λ_min > 0) has each of the six folds
    partly on its spinodal branch (the helical coupling tilts each fold's field, so it enters
    the spinodal from one side); the snap then localises the transformation in one fold
    (docs/fidelity.md, "Distributed onset, serrated completion")."""
    sol = symmetric_path[1.5]
    st = biplan.classify(model6, sol)
    assert st.verdict is Verdict.STABLE and st.min_eigenvalue > 0.1
    spinodal = np.sort(_circular_fractions(model6, sol.q)[:, 1])
    assert len(spinodal) == 6
    assert spinodal[0] > 0.25 and spinodal[1] > 0.6


@pytest.mark.parametrize("k2", [-0.2, -1.2])
def test_series_criterion_decides_snap_or_stable_softening(model2, k2):
    """Two circular folds in series (stiff helical folds, so the fields stay uniform) under a
    displacement-controlled stable-branch sweep, past the fold capacity k₁w₁H. With one fold on
    k₂ < 0 and the other on k₁ the chain's compliance is 1/(H k₂) + 1/(H k₁):

    * |k₂| < k₁: negative — the fold crosses its spinodal stably while the other unloads, the
      force falls with dF/dU = H/(1/k₂ + 1/k₁) and λ_min(H_r) = H (k₁ + k₂)/2 (the Hessian
      diag(H k₁, H k₂) on the plane dw₁ + dw₂ = 0): no snap;
    * |k₂| > k₁: positive — a snap-back, which displacement control passes by a snap."""
    from biplan.analysis.response.quasistatic import displacement_sweep
    from biplan.analysis.response.summary import summarize

    k1 = 0.9
    law = biplan.TrilinearLaw(stiffness=(k1, k2, 0.6), transitions=(0.2, 1.3))
    model = biplan.Model(make_tube(2, helical=biplan.LinearLaw(200.0), circular=law))
    assert model.layout == model2.layout  # shares the suite's compiled kernels
    u = np.round(np.arange(0.1, 1.01, 0.1), 10)
    path = displacement_sweep(model, u, start=biplan.relaxed_reference(model))
    assert all(s.converged for s in path.solutions) and path.stable.all()
    summary = summarize(path, initial_length=model.tube.initial_length)
    assert summary.peak_force == pytest.approx(k1 * 0.2 * H, rel=0.01)  # the capacity k1 w1 H
    spinodal = np.array([_circular_fractions(model, s.q)[:, 1] for s in path.solutions])
    if abs(k2) < k1:
        assert not path.switched.any()
        soft = (u >= 0.5) & (u <= 1.0)  # one fold wholly on its spinodal, the other closed
        assert (np.sort(spinodal[soft], axis=1) == [0.0, 1.0]).all()
        slope = np.diff(path.force[soft]) / np.diff(u[soft])
        np.testing.assert_allclose(slope, H / (1 / k2 + 1 / k1), rtol=0.01)
        np.testing.assert_allclose(path.min_eigenvalue[soft], H * (k1 + k2) / 2, rtol=0.01)
        assert summary.softening_start == pytest.approx(0.5)
    else:
        snap = int(np.flatnonzero(path.switched)[0])
        assert u[snap] == pytest.approx(0.5) and path.force[snap] < 0 < path.force[snap - 1]
        # landed with one fold on its spinodal and the other pressed flat (contact)
        assert (np.sort(spinodal[snap]) == [0.0, 1.0]).all()
        assert np.isinf(path.min_eigenvalue[snap])


@pytest.mark.parametrize("u_end", [0.5, 2.0])
def test_verdict_is_independent_of_the_null_space_basis(model6, symmetric_path, u_end, rng):
    sol = symmetric_path[u_end]
    h, n = biplan.reduced_hessian(model6, sol)
    a = active_constraint_jacobian(model6, sol)
    np.testing.assert_allclose(a @ n, 0.0, atol=1e-10)
    np.testing.assert_allclose(n.T @ n, np.eye(n.shape[1]), atol=1e-12)
    eig = np.linalg.eigvalsh(h)
    # orthonormal change of basis: same eigenvalues
    q = _random_orthogonal(rng, n.shape[1])
    h_q, n_q = biplan.reduced_hessian(model6, sol, basis=n @ q)
    np.testing.assert_array_equal(n_q, n @ q)
    np.testing.assert_allclose(np.linalg.eigvalsh(h_q), eig, rtol=1e-10, atol=1e-10)
    # any invertible change of basis: same inertia (Sylvester)
    for _ in range(3):
        s = rng.normal(size=(n.shape[1], n.shape[1])) + 2 * np.eye(n.shape[1])
        assert abs(np.linalg.det(s)) > 1e-6
        h_s, _ = biplan.reduced_hessian(model6, sol, basis=n @ s)
        assert _inertia(h_s) == _inertia(h)
        np.testing.assert_allclose(h_s, s.T @ h @ s, rtol=1e-9, atol=1e-9)
    # a basis computed from another factorisation of the same space
    other = null_space(np.vstack([a, a[::-1] * 2.0]))
    h_o, _ = biplan.reduced_hessian(model6, sol, basis=other)
    np.testing.assert_allclose(np.linalg.eigvalsh(h_o), eig, rtol=1e-9, atol=1e-9)


def _project(model, q, u_end, iters=30):
    """Return q moved back onto {g(q) = 0, z_p(q) = U} by minimum-norm Gauss–Newton steps."""
    q = q.copy()
    for _ in range(iters):
        c = np.concatenate([model.constraints(q), [model.load_displacement(q) - u_end]])
        if np.max(np.abs(c)) < 1e-14:
            break
        a = np.vstack([model.constraint_jacobian(q), model.load_gradient(q)[None]])
        q -= np.linalg.lstsq(a, c, rcond=None)[0]
    return q


@pytest.mark.parametrize("u_end", [0.5, 2.0])
def test_reduced_curvature_is_the_energy_curvature_on_the_manifold(model6, symmetric_path, u_end):
    """Along q(t) = P(q* + t N v) (P: projection on the guides and the end constraint) the
    energy changes as ½ t² vᵀ H_r v: it decreases along the unstable eigenvector at U = 2.0 and
    increases along every eigenvector at U = 0.5."""
    sol = symmetric_path[u_end]
    st = biplan.classify(model6, sol)
    assert st.n_active_contacts == 0  # only guides and the end constraint are active
    h, n = biplan.reduced_hessian(model6, sol)
    eig, vec = np.linalg.eigh(h)
    lam_c = sol.contact_multipliers
    w_ref = model6.contact_gaps(sol.q)
    picks = [0, len(eig) // 2, len(eig) - 1]
    for i in picks:
        direction = n @ vec[:, i]
        ratios = []
        for t in (2e-3, 1e-3):
            q_t = _project(model6, sol.q + t * direction, u_end)
            d_energy = model6.energy(q_t) - sol.energy
            # the (regularised, inactive) contact terms of the Lagrangian are negligible but
            # included for an exact second-order statement
            d_lag = d_energy - lam_c @ (model6.contact_gaps(q_t) - w_ref)
            ratios.append(2 * d_lag / t**2)
            assert np.sign(d_energy) == np.sign(eig[i])
        # second-order: the ratio converges to the eigenvalue like O(t)
        assert ratios[1] == pytest.approx(eig[i], rel=0.02, abs=2e-3)
    if u_end == 2.0:
        assert eig[0] < 0
    else:
        assert eig[0] > 0


def test_classify_rejects_non_converged(model6):
    sol = biplan.solve_equilibrium(model6, Newton(max_steps=1), None, Load.of_displacement(1.5))
    assert not sol.converged
    with pytest.raises(ConfigError):
        biplan.classify(model6, sol)
    with pytest.raises(ConfigError):
        biplan.classify(model6, "not a solution")


def test_classify_rejects_a_solution_of_another_model(model1, symmetric_path):
    with pytest.raises(ConfigError):
        biplan.classify(model1, symmetric_path[0.5])


# --------------------------------------------------------------------------------------------
# Closed-form curvatures of uniform fold states
# --------------------------------------------------------------------------------------------
def _uniform_state(model, values):
    nm = model.layout.n_modules
    q0 = np.concatenate([np.zeros(3 * nm), values])
    sol = biplan.solve_equilibrium(model, Newton(), q0, Load.of_force(0.0))
    assert sol.converged
    return sol


@pytest.mark.parametrize("name", ["model1", "model6", "model4"])
def test_open_and_hilltop_states(name, request):
    """All circular folds uniformly at w_s (open well): stable; at w_b (hilltop): unstable with
    one negative direction per fold. Closed helical folds are contact-locked, so the free
    directions are the connector openings γ_j with curvature ∂²Π/∂γ_j² = H k(w)."""
    m = request.getfixturevalue(name)
    law = m.tube.circular_laws[0]
    nc = m.layout.n_connectors
    _, k2, k3 = law.stiffness
    open_ = biplan.classify(m, _uniform_state(m, [law.wells()[1]] * nc))
    assert open_.verdict is Verdict.STABLE
    assert open_.min_eigenvalue > 0
    # the γ_j are free (open circular folds carry no contact) with Rayleigh quotient H k3
    assert open_.min_eigenvalue <= H * k3 * (1 + 1e-9)
    hill = biplan.classify(m, _uniform_state(m, [law.hilltop()] * nc))
    assert hill.verdict is Verdict.UNSTABLE
    # γ directions do not enter the guides and do not couple in Π: an nc-dimensional subspace
    # of negative curvature H k2 ⇒ at least nc negative eigenvalues
    assert np.sum(hill.eigenvalues < 0) >= nc
    assert hill.min_eigenvalue <= H * k2 * (1 - 1e-9)
    # with the helical folds pressed shut (active contacts) exactly the γ's remain free
    if open_.dof == nc:
        np.testing.assert_allclose(open_.eigenvalues, H * k3, rtol=1e-6)
    if hill.dof == nc:
        np.testing.assert_allclose(hill.eigenvalues, H * k2, rtol=1e-6)


def test_reduced_hessian_closed_form_in_gamma_u(model1):
    """One module, circular fold uniform at w (zero force), closed helical fold: on the tangent
    basis (e_γ, t_u) of the guide manifold, H_r = [[H k, −H k/2], [−H k/2, H k/3 + k_h a K²/3]]
    (fields w1 = γ − x u/H1, w2 = γ − x u/H2, helical wedge wa = −K u)."""
    dev = model1.tube.development
    h1, h2, a = dev.element1_span, dev.helical_span, dev.helical_length
    beta = dev.beta
    kw = H * np.sin(beta) / h1 + dev.pitch * np.cos(beta) * (1 / h1 + 1 / h2)
    k_h = model1.tube.helical_laws[0].stiffness
    law = model1.tube.circular_laws[0]
    for w in (law.wells()[1], law.hilltop()):
        sol = _uniform_state(model1, [w])
        k = law.differential_stiffness(w)
        g = model1.constraint_jacobian(sol.q)
        # tangent of the guide manifold with unit u component
        t = null_space(g[:, :3])[:, 0]
        t = np.concatenate([t / t[0], [0.0]])
        basis = np.stack([np.array([0.0, 0.0, 0.0, 1.0]), t], axis=1)
        h_r, _ = biplan.reduced_hessian(model1, sol, basis=basis)
        expected = np.array([[H * k, -H * k / 2], [-H * k / 2, H * k / 3 + k_h * a * kw**2 / 3]])
        np.testing.assert_allclose(h_r, expected, rtol=1e-4, atol=5e-3)
        np.testing.assert_allclose(t[1:3], [1 / h1, -1 / h2], rtol=1e-4)


def test_mixed_state_and_reference_are_stable(model6, reference6):
    law = model6.tube.circular_laws[0]
    k3 = law.stiffness[2]
    mixed = _uniform_state(model6, [law.wells()[1] if j % 2 == 0 else 0.0 for j in range(6)])
    st = biplan.classify(model6, mixed)
    assert st.verdict is Verdict.STABLE
    # the softest direction is an open fold's γ (H k3 < H k1)
    assert st.min_eigenvalue == pytest.approx(H * k3, rel=1e-6)
    ref = biplan.classify(model6, reference6)
    assert ref.verdict is Verdict.STABLE


def test_stiff_helical_tube_in_the_spinodal_is_unstable_under_force_control():
    """A single circular fold held uniformly inside the spinodal by a dead load F = H F(w)
    is unstable under force control (negative tangent stiffness H k2) and stable under
    displacement control of the same state (the end constraint removes γ)."""
    m = biplan.Model(make_tube(1, helical=biplan.LinearLaw(1e3)))
    law = m.tube.circular_laws[0]
    w = 0.5
    f_end = H * law.force(w)
    q0 = np.array([0.0, 0.0, 0.0, w])
    fsol = biplan.solve_equilibrium(m, Newton(), q0, Load.of_force(f_end))
    assert fsol.converged
    assert fsol.q[3] == pytest.approx(w, abs=1e-3)
    assert biplan.classify(m, fsol).verdict is Verdict.UNSTABLE
    dsol = biplan.solve_equilibrium(m, Newton(), fsol, Load.of_displacement(fsol.displacement))
    assert dsol.converged
    assert dsol.force == pytest.approx(f_end, rel=1e-6)
    assert biplan.classify(m, dsol).verdict is Verdict.STABLE


# --------------------------------------------------------------------------------------------
# Leaving a saddle under displacement control (analysis.quasistatic.proximal_descent)
# --------------------------------------------------------------------------------------------
def test_relax_from_the_symmetric_saddle_opens_one_fold(model6, symmetric_path):
    """From the symmetric saddle at U = 2 mm (every fold on the spinodal), the descent along its
    softest unstable mode — in the sense that opens a fold — ends in a stable equilibrium at the
    same U with lower energy, in which one circular fold has snapped to its open branch. The
    inexact sub-problems (the default) and exact ones (every sub-problem to ``atol``) end in the
    same equilibrium, and both give up in the other sense."""
    from biplan.analysis.response.quasistatic import proximal_descent
    from biplan.analysis.stability import reduced_hessian

    saddle = symmetric_path[2.0]
    h, basis = reduced_hessian(model6, saddle)
    eig, vec = np.linalg.eigh(h)
    assert eig[0] < 0
    mode = basis @ vec[:, 0]
    runs = {
        (sign, exact): proximal_descent(
            model6,
            saddle,
            saddle.load,
            Newton(),
            direction=sign * mode,
            **({"sub_steps": 60, "sub_tolerance": 0.0} if exact else {}),
        )
        for sign in (1.0, -1.0)
        for exact in (False, True)
    }
    found = [sign for sign in (1.0, -1.0) if runs[sign, False] is not None]
    assert len(found) == 1
    sign = found[0]
    assert runs[-sign, True] is None
    sol, st = runs[sign, False]
    sol_exact, _ = runs[sign, True]
    assert sol.converged and sol.residual_norm < Newton().atol
    assert st.verdict is Verdict.STABLE
    assert sol.displacement == pytest.approx(2.0, abs=1e-9)
    assert sol.energy < saddle.energy - 1.0
    law = model6.tube.circular_laws[0]
    open_share = [
        float(np.mean(law.phase_fractions(s, e)[..., 2]))
        for s, e, _ in model6.circular_fields(sol.q)
    ]
    assert sum(x > 0.5 for x in open_share) == 1, open_share
    assert sol_exact.energy == pytest.approx(sol.energy, abs=1e-9)
    assert np.max(np.abs(sol_exact.q - sol.q)) < 1e-6


@pytest.mark.parametrize(("name", "value"), [("sub_steps", 0), ("sub_tolerance", -1.0)])
def test_relax_rejects_bad_settings(model1, name, value):
    from biplan.analysis.response.quasistatic import proximal_descent

    start = biplan.solve_equilibrium(model1, Newton(), model1.zeros())
    with pytest.raises(ConfigError, match=name):
        proximal_descent(model1, start, start.load, Newton(), **{name: value})
