"""The 3D reconstruction is geometrically right (MODEL.md §9–10).

Reference tube = cylinder of radius R and length N·l; rigid elements keep their shape; the seam
s = 0 ≡ s = H closes where the planar model is compatible; the endpoint read back from the 3D
surface equals the model's; fold lines carry the kinematic elongations.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from biplan.geometry import chain
from biplan.geometry.foldlines import branch_index, fold_lines, fold_mesh
from biplan.geometry.surface import ELEMENT_POLYGONS, surface
from conftest import random_configuration

MODELS = ["model1", "model2", "model6", "model4"]


@pytest.fixture(params=MODELS)
def model(request):
    return request.getfixturevalue(request.param)


def _surfaces(model, q):
    radius = model.tube.development.radius
    ref = surface(model.global_nodes(model.zeros()), radius)
    srf = surface(model.global_nodes(q), radius, reference=model.global_nodes(model.zeros()))
    return ref, srf


def _polyline_length(p: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def _area3d(points: np.ndarray, triangles: np.ndarray) -> float:
    a, b, c = (points[triangles[:, i]] for i in range(3))
    return 0.5 * float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


def test_reference_tube_is_the_cylinder(model) -> None:
    dev, n = model.tube.development, model.layout.n_modules
    srf, _ = _surfaces(model, model.zeros())
    np.testing.assert_allclose(np.hypot(srf.points[:, 0], srf.points[:, 1]), dev.radius)
    assert srf.points[:, 2].min() == pytest.approx(0.0, abs=1e-12)
    assert srf.points[:, 2].max() == pytest.approx(n * dev.pitch, rel=1e-12)
    assert srf.points[:, 2].max() == pytest.approx(model.tube.initial_length, rel=1e-12)
    # The facets tile the development exactly, and the wrapped facets the cylinder (up to the
    # chord error of 48 facets per turn, 1 − sin(π/48)/(π/48) ≈ 7e-4).
    tri, owner = srf.triangles()
    plane3 = np.column_stack([srf.plane, np.zeros(len(srf.plane))])
    assert _area3d(plane3, tri) == pytest.approx(n * dev.pitch * dev.circumference, rel=1e-12)
    assert _area3d(srf.points, tri) == pytest.approx(
        2 * np.pi * dev.radius * n * dev.pitch, rel=1e-3
    )
    assert set(owner) == set(range(srf.n_facets))
    assert set(srf.module) == set(range(n)) and set(srf.element) == {0, 1}


def test_facets_are_convex_strips(model6) -> None:
    srf, _ = _surfaces(model6, model6.zeros())
    width = model6.tube.development.circumference / 48
    counts = (srf.facets >= 0).sum(axis=1)
    assert counts.min() >= 3 and counts.max() <= 6
    for f in srf.facets:
        s = srf.plane[f[f >= 0], 1]
        assert np.ptp(s) <= width * (1 + 1e-9)


def test_rigid_elements_keep_their_shape(model, rng) -> None:
    q = random_configuration(model, rng, amplitude=0.06)
    ref, srf = _surfaces(model, q)
    assert srf.facets.shape == ref.facets.shape  # same topology in every configuration
    np.testing.assert_array_equal(srf.facets, ref.facets)
    # Every point pair of one element keeps its distance in the development.
    owner = np.full(len(srf.plane), -1)
    for f, m, e in zip(srf.facets, srf.module, srf.element, strict=True):
        owner[f[f >= 0]] = 2 * m + e
    for k in np.unique(owner):
        p0, p1 = ref.plane[owner == k], srf.plane[owner == k]
        d0 = np.linalg.norm(p0[:, None] - p0[None], axis=-1)
        d1 = np.linalg.norm(p1[:, None] - p1[None], axis=-1)
        np.testing.assert_allclose(d1, d0, atol=1e-11)
    # Every element edge keeps its length; on the cylinder (an isometric wrap) up to the chord
    # error of the subdivision.
    nodes0 = model.global_nodes(model.zeros())
    for (m, a, b), e0, e1, w1 in zip(
        ref.edge_nodes, ref.edges, srf.edges, srf.wrapped_edges(), strict=True
    ):
        exact = float(np.linalg.norm(nodes0[m, b] - nodes0[m, a]))
        assert _polyline_length(e0) == pytest.approx(exact, rel=1e-12)
        assert _polyline_length(e1) == pytest.approx(exact, rel=1e-12)
        assert _polyline_length(w1) == pytest.approx(exact, rel=2e-3)
    n_sides = sum(len(p) for p in ELEMENT_POLYGONS)
    assert len(srf.edges) == n_sides * model.layout.n_modules


def test_reference_seam_closes(model) -> None:
    """In the reference, s = 0 (edge AB) and s = H (edge GF) are the same 3D points."""
    srf, _ = _surfaces(model, model.zeros())
    wrapped = dict(zip(map(tuple, srf.edge_nodes), srf.wrapped_edges(), strict=True))
    dev = model.tube.development
    for m in range(model.layout.n_modules):
        ab, fg = wrapped[(m, 0, 1)], wrapped[(m, 5, 6)]
        np.testing.assert_allclose(ab, fg[::-1], atol=1e-12)
        plane = dict(zip(map(tuple, srf.edge_nodes), srf.edges, strict=True))
        s_ab, s_fg = plane[(m, 0, 1)][:, 1], plane[(m, 5, 6)][:, 1]
        assert np.allclose(s_ab, 0.0) and np.allclose(s_fg, dev.circumference)
    # Every vertex at s = H coincides with one at s = 0.
    at_h = srf.points[np.isclose(srf.plane[:, 1], dev.circumference)]
    at_0 = srf.points[np.isclose(srf.plane[:, 1], 0.0)]
    dist = np.linalg.norm(at_h[:, None] - at_0[None], axis=-1).min(axis=1)
    assert len(at_h) >= 2 * model.layout.n_modules and dist.max() < 1e-12


def test_deformed_seam_is_compatible_where_the_model_is(model1, model2, rng) -> None:
    """A ≡ G in every module frame; seam edges coincide when φ1 = φ2 and the frame is not
    rotated; otherwise the A–G gap is exactly that of the frame rotation (MODEL.md §10)."""
    q = random_configuration(model1, rng, amplitude=0.05)
    q[2] = q[1]  # φ2 = φ1
    _, srf = _surfaces(model1, q)
    wrapped = dict(zip(map(tuple, srf.edge_nodes), srf.wrapped_edges(), strict=True))
    np.testing.assert_allclose(wrapped[(0, 0, 1)], wrapped[(0, 5, 6)][::-1], atol=1e-12)

    dev = model2.tube.development
    h, r = dev.circumference, dev.radius
    for _ in range(3):
        q = random_configuration(model2, rng, amplitude=0.05)
        kin = model2.kinematics(q)
        xyz = np.asarray(chain.wrap_to_cylinder(model2.global_nodes(q), r))
        for m in range(model2.layout.n_modules):
            rot = kin.frames[m, :2, :2]
            theta = np.arctan2(rot[1, 0], rot[0, 0])
            dz, ds = -h * np.sin(theta), h * np.cos(theta) - h
            gap = np.hypot(dz, 2 * r * np.sin(ds / (2 * r)))
            assert np.linalg.norm(xyz[m, 0] - xyz[m, 6]) == pytest.approx(gap, abs=1e-12)
            if m == 0:  # placed by the base TPC: no rotation, A ≡ G
                assert gap == 0.0


def _edge_observables(points3d: list[np.ndarray], radius: float) -> np.ndarray:
    """Length-weighted mean z, mean s and least-squares tilt θ of the free-end edge, read from
    its wrapped polylines (s recovered as R × the unwrapped polar angle)."""
    chain_pts = np.concatenate(points3d)
    angle = np.unwrap(np.arctan2(chain_pts[:, 1], chain_pts[:, 0]))
    angle -= 2 * np.pi * np.round(angle[0] / (2 * np.pi))  # the edge starts at the seam s ≈ 0
    s, z = radius * angle, chain_pts[:, 2]
    ends = np.cumsum([0] + [len(p) for p in points3d])
    segs = np.array([[[z[i], s[i]], [z[j - 1], s[j - 1]]] for i, j in itertools.pairwise(ends)])
    (z0, s0), (z1, s1) = segs[:, 0].T, segs[:, 1].T
    length = np.hypot(z1 - z0, s1 - s0)
    zm = (length * (z0 + z1) / 2).sum() / length.sum()
    sm = (length * (s0 + s1) / 2).sum() / length.sum()
    ss = (length * (s0**2 + s0 * s1 + s1**2) / 3).sum() / length.sum() - sm**2
    zs = (length * (2 * z0 * s0 + z0 * s1 + z1 * s0 + 2 * z1 * s1) / 6).sum() / length.sum()
    return np.array([zm, sm, np.arctan(-(zs - zm * sm) / ss)])


def test_endpoint_read_from_the_3d_surface(model, rng) -> None:
    radius = model.tube.development.radius
    last = model.layout.n_modules - 1
    end_segments = chain.tables(model.layout).end_segments
    readings = []
    for q in (model.zeros(), random_configuration(model, rng, amplitude=0.04)):
        _, srf = _surfaces(model, q)
        wrapped = dict(zip(map(tuple, srf.edge_nodes), srf.wrapped_edges(), strict=True))
        polylines = []
        for _, i0, i1 in end_segments:
            polylines.append(
                wrapped[(last, i0, i1)]
                if (last, i0, i1) in wrapped
                else wrapped[(last, i1, i0)][::-1]
            )
        readings.append(_edge_observables(polylines, radius))
    u_z, u_r, theta = readings[1] - readings[0]
    expected = model.endpoint(q)
    assert u_z == pytest.approx(expected.u_z, abs=1e-10)
    assert u_r == pytest.approx(expected.u_r, abs=1e-10)
    assert theta == pytest.approx(expected.theta, abs=1e-10)


def test_fold_lines_carry_the_kinematic_elongations(model, rng) -> None:
    q = random_configuration(model, rng)
    kin = model.kinematics(q)
    lines = fold_lines(model.layout, model.params.geometry, kin)
    n = model.layout.n_modules
    np.testing.assert_allclose(np.c_[lines.w_start[:n], lines.w_end[:n]], kin.helical)
    np.testing.assert_allclose(lines.w_start[n:], kin.field_start)
    np.testing.assert_allclose(lines.w_end[n:], kin.field_end)
    assert list(lines.fold[:n]) == list(range(n))
    assert set(lines.fold[n:]) == set(range(n, n + model.layout.n_connectors))
    nodes = model.global_nodes(q)
    np.testing.assert_allclose(lines.start[:n], 0.5 * (nodes[:, 3] + nodes[:, 4]))
    mesh = fold_mesh(lines, model.tube.development.radius)
    # Elongation interpolated linearly along each field, topology independent of q.
    for f in range(len(lines.fold)):
        seg = mesh.segments[mesh.field == f]
        w = mesh.w[np.r_[seg[:, 0], seg[-1, 1]]]
        np.testing.assert_allclose(w[[0, -1]], [lines.w_start[f], lines.w_end[f]])
        assert np.all(np.diff(w) * np.sign(lines.w_end[f] - lines.w_start[f]) >= -1e-15)
    ref = fold_mesh(
        fold_lines(model.layout, model.params.geometry, model.kinematics(model.zeros())),
        model.tube.development.radius,
    )
    np.testing.assert_array_equal(ref.segments, mesh.segments)
    np.testing.assert_allclose(
        np.hypot(mesh.points[:, 0], mesh.points[:, 1]),
        mesh.points[0, 0] * 0 + model.tube.development.radius,
    )


def test_branch_index() -> None:
    from biplan import LinearLaw, TrilinearLaw

    law = TrilinearLaw(stiffness=(0.9, -0.2, 0.6), transitions=(0.2, 1.3))
    np.testing.assert_array_equal(branch_index(law, [0.0, 0.5, 2.0]), [0.0, 1.0, 2.0])
    assert np.isnan(branch_index(LinearLaw(stiffness=1.0), [0.3])).all()


def test_surface_rejects_bad_input(model1) -> None:
    nodes = model1.global_nodes(model1.zeros())
    with pytest.raises(ValueError, match="subdivisions"):
        surface(nodes, 2.0, subdivisions=2)
    with pytest.raises(ValueError, match="reference"):
        surface(nodes, 2.0, reference=nodes[:, :5])
