"""Kinematics of modules, connectors and the chain (MODEL.md §3–7, §9, §16).

Numbers of MODEL.md §4 (Table geometry R = 2, l = 3.6, β = 60°), an independent NumPy
re-implementation of the module layout, the connector-field formulas of §7 and the rigidity of
the chain reconstruction.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

import biplan
from biplan.geometry.chain import _edge_fit
from biplan.options import ChainAttachment
from conftest import GEOMETRY, make_tube, random_configuration

DEV = biplan.Development(**GEOMETRY)
H, H1, H2, A_LEN = DEV.circumference, DEV.element1_span, DEV.helical_span, DEV.helical_length
L, BETA = DEV.pitch, DEV.beta
K_WEDGE = H * math.sin(BETA) / H1 + L * math.cos(BETA) * (1 / H1 + 1 / H2)


# --------------------------------------------------------------------------------------------
# Independent implementation of one module (MODEL.md §4, §5 CHOICE K1, K2, K3)
# --------------------------------------------------------------------------------------------
def _rot(phi):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


def _module_reference(kind):
    std = np.array([[0, 0], [L, 0], [L, H], [0, H1], [0, H1], [L, H], [0, H]], dtype=float)
    n_c = np.array([math.cos(BETA), math.sin(BETA)])
    n_sp = np.array([-math.sin(BETA), math.cos(BETA)])
    if kind == "S":
        return std, n_c, n_sp
    mirror = np.array([-1.0, 1.0])  # z -> l - z
    return std * mirror + np.array([L, 0.0]), n_c * mirror, n_sp * mirror


def _module_kinematics(kind, u, phi1, phi2):
    """Nodes, guides (g_C, g_F) and helical (w0, wa) of a module, from MODEL.md §4."""
    ref, n_c, n_sp = _module_reference(kind)
    out = np.empty_like(ref)
    for i in range(7):
        el = 0 if i < 4 else 1
        pivot = ref[0] if el == 0 else ref[6]
        phi = phi1 if el == 0 else phi2
        out[i] = _rot(phi) @ (ref[i] - pivot) + pivot + np.array([u, 0.0])
    g = np.array([(out[2] - ref[2]) @ n_c, (out[5] - ref[5]) @ n_c])
    w = np.array([(out[4] - out[3]) @ n_sp, (out[5] - out[2]) @ n_sp])
    return out, g, w


def _reduced_angles_standard(u):
    """MODEL.md §16: closed-form solution of the two guides of a standard module."""
    phi2 = BETA - math.acos(math.cos(BETA) * (1 - u / L))
    rho = math.hypot(L, H)
    delta = math.atan2(H, L)
    c = (L - u) * math.cos(BETA) + H * math.sin(BETA)
    phi1 = BETA - delta + math.copysign(1.0, delta - BETA) * math.acos(c / rho)
    return phi1, phi2


def _solve_guides(model, module, u, q=None):
    """q with module ``module`` at axial translation u and (φ1, φ2) solving its two guides
    g = 0 (Newton on the model's guides and guide Jacobian, small-angle initial guess)."""
    q = model.zeros() if q is None else q.copy()
    standard = model.tube.module_kinds[module] is biplan.options.ModuleKind.STANDARD
    sign = 1.0 if standard else -1.0
    i, r = 3 * module, slice(2 * module, 2 * module + 2)
    q[i : i + 3] = [u, sign * u / H1, -sign * u / H2]
    for _ in range(50):
        g = model.constraints(q)[r]
        if np.max(np.abs(g)) < 1e-14:
            break
        jac = model.constraint_jacobian(q)[r, i + 1 : i + 3]
        q[i + 1 : i + 3] -= np.linalg.solve(jac, g)
    assert np.max(np.abs(model.constraints(q)[r])) < 1e-13
    return q


# --------------------------------------------------------------------------------------------
# Development and counts (MODEL.md §3, §6)
# --------------------------------------------------------------------------------------------
def test_development_numbers():
    assert abs(H - 12.566) < 1e-3
    assert abs(H2 - 6.235) < 1e-3
    assert abs(H1 - 6.331) < 1e-3
    assert abs(A_LEN - 7.2) < 1e-12
    tube = biplan.designs.semi_bistable()
    assert abs(tube.b - 0.573) < 0.01
    assert tube.b == pytest.approx(A_LEN / H, rel=1e-14)
    assert pytest.approx(1.3 / 0.9, rel=1e-14) == tube.C
    assert abs(K_WEDGE - 2.29) < 0.01
    # kinematic lock of MODEL.md §16
    assert DEV.lock_displacement == pytest.approx(0.778, abs=1e-3)
    # β for a prescribed b inverts b(β)
    beta = biplan.Development.helical_angle_for_b(0.58, 2.0, 3.6)
    assert biplan.Development(2.0, 3.6, beta).b == pytest.approx(0.58, rel=1e-12)


def test_counts(model6, model4, model1, model2):
    assert (model6.n_coordinates, model6.n_guides, model6.n_contacts) == (24, 12, 27)
    assert model6.n_unknowns == 24 + 12 + 27 + 1
    assert (model4.n_coordinates, model4.n_guides, model4.n_contacts) == (15, 8, 15)
    assert model4.n_unknowns == 15 + 8 + 15 + 1
    kinds6 = [c.kind for c in model6.layout.connectors]
    assert kinds6 == ["TPC", "SPC"] * 3
    assert [c.kind for c in model4.layout.connectors] == ["SPC", "TPC", "SPC"]
    assert (model1.n_coordinates, model1.n_guides, model1.n_contacts) == (4, 2, 5)
    assert (model2.n_coordinates, model2.n_guides, model2.n_contacts) == (8, 4, 9)
    # DOF before contact = N + Nc (guide Jacobian has full row rank)
    for m in (model6, model4, model2):
        g = m.constraint_jacobian(m.zeros())
        assert np.linalg.matrix_rank(g) == m.n_guides


# --------------------------------------------------------------------------------------------
# One module (MODEL.md §4)
# --------------------------------------------------------------------------------------------
def test_module_matches_independent_implementation(model2, rng):
    """Guides and helical boundary elongations of S and M modules equal those computed from
    the node layout, rigid maps and directions of MODEL.md §4–5."""
    for _ in range(10):
        q = rng.normal(0.0, 0.1, model2.n_coordinates)
        kin = model2.kinematics(q)
        for n, kind in enumerate(("S", "M")):
            nodes, g, w = _module_kinematics(kind, *q[3 * n : 3 * n + 3])
            np.testing.assert_allclose(kin.local_nodes[n], nodes, atol=1e-12)
            np.testing.assert_allclose(kin.guides[2 * n : 2 * n + 2], g, atol=1e-12)
            np.testing.assert_allclose(kin.helical[n], w, atol=1e-12)
        ref, _, _ = _module_reference("S")
        np.testing.assert_allclose(kin.reference[0], ref, atol=1e-12)
        assert float(kin.helical_length) == pytest.approx(A_LEN, rel=1e-14)


def test_exact_open_module_numbers(model1):
    """MODEL.md §4: u = −0.6 mm → φ1 = −0.128, φ2 = 0.099, w0 = 0.205 mm, wa = 1.836 mm."""
    q = _solve_guides(model1, 0, -0.6)
    assert q[1] == pytest.approx(-0.128, abs=1e-3)
    assert q[2] == pytest.approx(0.099, abs=1e-3)
    w0, wa = model1.helical_boundary(q)[0]
    assert w0 == pytest.approx(0.205, abs=1e-3)
    assert wa == pytest.approx(1.836, abs=1e-3)
    np.testing.assert_allclose(model1.constraints(q), 0.0, atol=1e-12)


@pytest.mark.parametrize("u", [-0.77, -0.6, -0.3, -0.05, 0.05, 0.3, 0.6])
def test_guides_agree_with_reduced_coordinates(model1, u):
    """MODEL.md §16 closed forms of g_F = 0 and g_C = 0 for the standard module."""
    phi1, phi2 = _reduced_angles_standard(u)
    q = np.array([u, phi1, phi2, 0.0])
    np.testing.assert_allclose(model1.constraints(q), 0.0, atol=1e-12)
    q2 = _solve_guides(model1, 0, u)
    np.testing.assert_allclose(q2[1:3], [phi1, phi2], atol=1e-10)


def test_mirrored_module_is_the_mirror_image(model2):
    """φ_i^M(u) = −φ_i^S(−u) and the M helical fold opens for u > 0 exactly as S does for −u
    (MODEL.md §5, §16)."""
    for u in (-0.4, -0.1, 0.2, 0.5):
        qs = _solve_guides(model2, 0, -u)
        qm = _solve_guides(model2, 1, u)
        np.testing.assert_allclose(qm[4:6], -qs[1:3], atol=1e-10)
        ws = model2.helical_boundary(qs)[0]
        wm = model2.helical_boundary(qm)[1]
        np.testing.assert_allclose(wm, ws, atol=1e-10)


def test_small_angle_kinematics(model1):
    """φ1 ≈ u/H1, φ2 ≈ −u/H2, wa ≈ −K u, w0 = O(u²) ≥ 0 (MODEL.md §4)."""
    for u in (-1e-4, 1e-4):
        q = _solve_guides(model1, 0, u)
        assert q[1] == pytest.approx(u / H1, rel=1e-3)
        assert q[2] == pytest.approx(-u / H2, rel=1e-3)
        w0, wa = model1.helical_boundary(q)[0]
        assert wa == pytest.approx(-K_WEDGE * u, rel=1e-3)
    # w0 is quadratic and never negative
    c = []
    for u in (-2e-3, -1e-3, 1e-3, 2e-3, -0.3, 0.3, -0.7):
        w0 = model1.helical_boundary(_solve_guides(model1, 0, u))[0, 0]
        assert w0 >= 0.0
        if abs(u) < 0.01:
            c.append(w0 / u**2)
    np.testing.assert_allclose(c, np.mean(c), rtol=5e-3)
    assert np.mean(c) > 0


def test_wedge_opens_for_negative_u_in_standard_module(model1):
    """The standard module's helical fold opens (wa > 0) for u < 0 and would penetrate
    (wa < 0) for u > 0 (MODEL.md §4 CHOICE K2)."""
    assert model1.helical_boundary(_solve_guides(model1, 0, -0.2))[0, 1] > 0.4
    assert model1.helical_boundary(_solve_guides(model1, 0, 0.2))[0, 1] < -0.4


def test_kinematic_lock(model1):
    """g_C = 0 has a solution only for |u| ≤ u_lim on the opening side (MODEL.md §16)."""
    u_lim = DEV.lock_displacement

    def min_gc(u):
        res = minimize_scalar(
            lambda p: model1.constraints(np.array([u, p, 0.0, 0.0]))[0] ** 2,
            bounds=(-1.0, 1.0),
            method="bounded",
            options={"xatol": 1e-12},
        )
        return math.sqrt(res.fun)

    assert min_gc(-(u_lim - 0.01)) < 1e-6
    assert min_gc(-(u_lim + 0.02)) > 1e-4
    # the boundary is where the reduced formula's arccos argument reaches 1
    c_of_u = lambda u: (L - u) * math.cos(BETA) + H * math.sin(BETA) - math.hypot(L, H)  # noqa: E731
    assert brentq(c_of_u, -2.0, 0.0) == pytest.approx(-u_lim, abs=1e-12)


# --------------------------------------------------------------------------------------------
# Reference state
# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["model1", "model2", "model6", "model4"])
def test_reference_state_is_stress_free(name, request):
    m = request.getfixturevalue(name)
    q = m.zeros()
    np.testing.assert_allclose(m.constraints(q), 0.0, atol=1e-14)
    np.testing.assert_allclose(m.contact_gaps(q), 0.0, atol=1e-14)
    assert m.energy(q) == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(m.gradient(q), 0.0, atol=1e-14)
    e = m.endpoint(q)
    assert (e.u_z, e.u_r, e.theta) == pytest.approx((0.0, 0.0, 0.0), abs=1e-14)
    assert m.load_displacement(q) == pytest.approx(0.0, abs=1e-14)
    # modules stacked at pitch l along the axis
    nodes = m.global_nodes(q)
    kin = m.kinematics(q)
    for n in range(m.layout.n_modules):
        np.testing.assert_allclose(nodes[n], kin.reference[n] + [n * L, 0.0], atol=1e-12)


# --------------------------------------------------------------------------------------------
# Chain reconstruction (MODEL.md §9)
# --------------------------------------------------------------------------------------------
ELEMENTS = (range(0, 4), range(4, 7))


@pytest.mark.parametrize("name", ["model2", "model6", "model4"])
def test_elements_are_rigid(name, request, rng):
    """Distances between nodes of one element are those of the reference for any q."""
    m = request.getfixturevalue(name)
    ref = m.global_nodes(m.zeros())
    for _ in range(5):
        q = rng.normal(0.0, 0.1, m.n_coordinates)
        nodes = m.global_nodes(q)
        for n in range(m.layout.n_modules):
            for el in ELEMENTS:
                idx = list(el)
                d = np.linalg.norm(nodes[n, idx][:, None] - nodes[n, idx][None], axis=-1)
                d0 = np.linalg.norm(ref[n, idx][:, None] - ref[n, idx][None], axis=-1)
                np.testing.assert_allclose(d, d0, atol=1e-11)


def test_base_gamma_translates_the_whole_tube(model6, rng):
    """Adding c to the base connector's γ translates every module axially by c: guides,
    helical fields and the other folds are unchanged, the base fold opens uniformly by c."""
    n = model6.layout.n_modules
    ig = 3 * n  # index of the base connector's γ
    q = random_configuration(model6, rng, amplitude=0.02, gamma=(0.2, 0.6))
    c = 0.137
    q2 = q.copy()
    q2[ig] += c
    np.testing.assert_allclose(
        model6.global_nodes(q2), model6.global_nodes(q) + np.array([c, 0.0]), atol=1e-12
    )
    np.testing.assert_allclose(model6.constraints(q2), model6.constraints(q), atol=1e-14)
    np.testing.assert_allclose(model6.helical_boundary(q2), model6.helical_boundary(q), atol=1e-14)
    f1, f2 = model6.circular_fields(q), model6.circular_fields(q2)
    np.testing.assert_allclose(f2[0][0], f1[0][0] + c, atol=1e-14)
    np.testing.assert_allclose(f2[0][1], f1[0][1] + c, atol=1e-14)
    for a, b in zip(f1[1:], f2[1:], strict=True):
        for x, y in zip(a, b, strict=True):
            np.testing.assert_allclose(x, y, atol=1e-14)
    h1, c1 = model6.fold_energies(q)
    h2, c2 = model6.fold_energies(q2)
    np.testing.assert_allclose(h2, h1, atol=1e-14)
    np.testing.assert_allclose(c2[1:], c1[1:], atol=1e-14)
    assert c2[0] != pytest.approx(c1[0])
    e1, e2 = model6.endpoint(q), model6.endpoint(q2)
    assert e2.u_z == pytest.approx(e1.u_z + c, abs=1e-12)
    assert e2.u_r == pytest.approx(e1.u_r, abs=1e-12)
    assert e2.theta == pytest.approx(e1.theta, abs=1e-12)
    assert model6.load_displacement(q2) == pytest.approx(model6.load_displacement(q) + c, abs=1e-12)
    np.testing.assert_allclose(model6.load_gradient(q2), model6.load_gradient(q), atol=1e-12)


@pytest.mark.parametrize("name", ["model6", "model4_element", "model4"])
def test_gamma_translates_the_upper_tube_along_the_attachment_axis(name, request, rng):
    """Opening connector j by c moves every module above it rigidly by c along the axis of the
    attachment frame (SPC: the lower S element-1 frame; TPC: the lower module frame; R3
    edge_fit: the frame of the lower module's fitted top edge) and leaves the modules below in
    place (MODEL.md §9, CHOICE R1 exact)."""
    m = request.getfixturevalue(name)
    n = m.layout.n_modules
    q = random_configuration(m, rng, amplitude=0.03, gamma=(0.2, 0.6))
    frames = m.kinematics(q).frames
    c = 0.0731
    for j, spec in enumerate(m.layout.connectors):
        q2 = q.copy()
        q2[3 * n + j] += c
        before, after = m.global_nodes(q), m.global_nodes(q2)
        if spec.lower is None:
            axis = np.array([1.0, 0.0])
        elif m.layout.options.chain_attachment is ChainAttachment.EDGE_FIT:
            local = m.kinematics(q)
            fit = _edge_fit(
                local.local_nodes[spec.lower], local.reference[spec.lower], spec.lower_edge.segments
            )
            axis = (frames[spec.lower] @ np.asarray(fit))[:2, :2] @ np.array([1.0, 0.0])
        else:
            rot = frames[spec.lower][:2, :2]
            if spec.kind == "SPC":
                rot = rot @ _rot(q[3 * spec.lower + 1])
            axis = rot @ np.array([1.0, 0.0])
        up = spec.upper
        np.testing.assert_allclose(after[:up], before[:up], atol=1e-13)
        np.testing.assert_allclose(after[up:], before[up:] + c * axis, atol=1e-12)


def _line_value(p0, p1, s):
    """z on the straight line through p0, p1 (points (z, s)) at circumferential s."""
    return p0[0] + (p1[0] - p0[0]) * (s - p0[1]) / (p1[1] - p0[1])


@pytest.mark.parametrize("name", ["model2", "model6", "model4_element"])
def test_connector_fields_match_the_global_geometry(name, request, rng):
    """Each connector field endpoint equals the axial gap, in the attachment frame, between
    the lower module's top edge and the upper module's bottom edge taken from the global
    nodes (MODEL.md §7 'geometric definition'); the seam gap is exactly γ (CHOICE R1)."""
    m = request.getfixturevalue(name)
    n = m.layout.n_modules
    q = random_configuration(m, rng, amplitude=0.03, gamma=(0.2, 0.6))
    nodes = m.global_nodes(q)
    frames = m.kinematics(q).frames
    fields = m.circular_fields(q)
    s_of = {"0": 0.0, "H1": H1, "H2": H2, "H": H}
    for j, spec in enumerate(m.layout.connectors):
        up = spec.upper
        if spec.lower is None:
            attach = np.eye(3)
        else:
            attach = frames[spec.lower]
            if spec.kind == "SPC":
                e = _hom_element(q[3 * spec.lower : 3 * spec.lower + 3], m, spec.lower)
                attach = attach @ e
        inv = np.linalg.inv(attach)

        def local(pts, inv=inv):
            return (inv[:2, :2] @ pts.T).T + inv[:2, 2]

        up_nodes = local(nodes[up])
        lo_nodes = None if spec.lower is None else local(nodes[spec.lower])
        starts, ends, lengths = fields[j]
        for f, (a, b) in enumerate(spec.field_ends()):
            for end, value in ((a, starts[f]), (b, ends[f])):
                s = s_of[end.s]
                seg_up = _segment(m.layout.shapes[up].bottom, end.upper_element)
                z_up = _line_value(up_nodes[seg_up[0]], up_nodes[seg_up[1]], s)
                if lo_nodes is None:
                    z_lo = 0.0
                else:
                    el = end.lower_element
                    if el is None:
                        el = spec.lower_full_element
                    seg_lo = _segment(m.layout.shapes[spec.lower].top, el)
                    z_lo = _line_value(lo_nodes[seg_lo[0]], lo_nodes[seg_lo[1]], s)
                assert value == pytest.approx(z_up - z_lo, abs=1e-11), (j, f, end)
            assert lengths[f] == pytest.approx(s_of[b.s] - s_of[a.s], abs=1e-12)
        assert starts[0] == pytest.approx(q[3 * n + j], abs=1e-13)  # seam gap = γ


def _segment(edge, element):
    for el, i0, i1 in edge.segments:
        if el == element:
            return i0, i1
    raise AssertionError("element not on edge")


def _hom_element(qm, m, module):
    kind = "S" if m.tube.module_kinds[module] is biplan.options.ModuleKind.STANDARD else "M"
    ref, _, _ = _module_reference(kind)
    rot = _rot(qm[1])
    t = ref[0] - rot @ ref[0] + np.array([qm[0], 0.0])
    out = np.eye(3)
    out[:2, :2] = rot
    out[:2, 2] = t
    return out


def test_connector_field_formulas(model6, rng):
    """MODEL.md §7: SPC w(x) = γ − x tan φ1^(M); TPC w_1(x) = γ − x[tan φ1^(S) − tan φ1^(M)],
    w_2(x) = γ + x[tan φ2^(S) − tan φ2^(M)] with x from the seam; the base TPC faces the flat
    clamp (φ = 0)."""
    n = 6
    for _ in range(3):
        q = random_configuration(model6, rng, amplitude=0.05, gamma=(0.2, 0.6))
        fields = model6.circular_fields(q)
        for j, spec in enumerate(model6.layout.connectors):
            gam = q[3 * n + j]
            up = spec.upper
            t1u, t2u = math.tan(q[3 * up + 1]), math.tan(q[3 * up + 2])
            if spec.lower is None:
                t1l = t2l = 0.0
            else:
                t1l, t2l = math.tan(q[3 * spec.lower + 1]), math.tan(q[3 * spec.lower + 2])
            starts, ends, lengths = fields[j]
            if spec.kind == "SPC":
                assert model6.tube.module_kinds[up].value == "mirrored"
                np.testing.assert_allclose(starts, [gam], atol=1e-13)
                np.testing.assert_allclose(ends, [gam - H * t1u], atol=1e-12)
                np.testing.assert_allclose(lengths, [H], atol=1e-12)
            else:
                assert model6.tube.module_kinds[up].value == "standard"
                w1_end = gam - H1 * (t1u - t1l)
                w2_end = gam + H2 * (t2u - t2l)
                np.testing.assert_allclose(starts, [gam, w2_end], atol=1e-12)
                np.testing.assert_allclose(ends, [w1_end, gam], atol=1e-12)
                np.testing.assert_allclose(lengths, [H1, H2], atol=1e-12)


def test_contact_gaps_are_field_boundaries(model6, rng):
    """Contact gaps = helical (w0, wa) per module, then per connector the seam and both sides
    of the split (TPC: 3) or both ends (SPC: 2) (MODEL.md §6, §8 CHOICE C1)."""
    q = random_configuration(model6, rng)
    gaps = model6.contact_gaps(q)
    expected = [model6.helical_boundary(q).reshape(-1)]
    for spec, (s, e, _) in zip(model6.layout.connectors, model6.circular_fields(q), strict=True):
        if spec.kind == "TPC":
            expected.append([s[0], e[0], s[1]])
        else:
            expected.append([s[0], e[0]])
    np.testing.assert_allclose(gaps, np.concatenate(expected), atol=1e-14)


def test_open_standard_helical_fold_wedges_the_tpc_below(model1):
    """MODEL.md §16: opening the helical fold of an S module (u < 0) with γ = 0 wedges the
    TPC below it open by ≈ |u| at the split point and keeps the seam at γ."""
    for u in (-0.01, -0.05, -0.3):
        q = _solve_guides(model1, 0, u)
        s, e, _ = model1.circular_fields(q)[0]
        assert s[0] == 0.0
        assert e[1] == pytest.approx(0.0, abs=1e-14)
        # element 1 side: −H1 tan φ1; element 2 side: H2 tan φ2; both ≈ |u| (first order)
        assert e[0] == pytest.approx(-H1 * math.tan(q[1]), rel=1e-12)
        assert s[1] == pytest.approx(H2 * math.tan(q[2]), rel=1e-12)
        assert e[0] == pytest.approx(-u, rel=0.6 * abs(u))
        assert s[1] == pytest.approx(-u, rel=0.6 * abs(u))


def test_one_module_tube_layout():
    tube = make_tube(1)
    assert tube.module_kinds == (biplan.options.ModuleKind.STANDARD,)
    assert tube.layout.connectors[0].lower is None
    assert tube.layout.connectors[0].kind == "TPC"


def test_numpy_geometry_equals_jax(model6, rng):
    """The drawing helpers evaluate NumPy input in NumPy (no XLA kernel per operation) and
    JAX input in JAX; both give the same nodes, wrapped points and spans."""
    from biplan._compile.setup import jnp
    from biplan.geometry import chain
    from biplan.geometry.development import spans

    kin = model6.kinematics(random_configuration(model6, rng))
    kin_jax = chain.Kinematics(*(jnp.asarray(v) for v in kin))
    nodes = chain.global_nodes(kin)
    assert type(nodes) is np.ndarray
    np.testing.assert_allclose(nodes, np.asarray(chain.global_nodes(kin_jax)), rtol=0, atol=1e-13)
    wrapped = chain.wrap_to_cylinder(nodes, 2.0)
    assert type(wrapped) is np.ndarray
    np.testing.assert_allclose(
        wrapped, np.asarray(chain.wrap_to_cylinder(jnp.asarray(nodes), 2.0)), rtol=0, atol=1e-13
    )
    got, ref = spans(2.0, 3.6, BETA), spans(jnp.asarray(2.0), 3.6, BETA)
    assert all(isinstance(v, float | np.floating) for v in got)
    np.testing.assert_allclose(got, [float(v) for v in ref], rtol=1e-15)
    assert got[0] == pytest.approx(H) and got[1] == pytest.approx(H1)
