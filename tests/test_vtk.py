"""VTK export: .vtu files load back with meshio with the right counts and fields; .pvd series."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from _datasets import result_dataset
from biplan.geometry import surface
from biplan.io.vtk import export_result, tube_mesh, write_pvd, write_vtu
from conftest import random_configuration


def _expected_counts(model, q):
    rec = surface.reconstruct(
        model.layout,
        model.params.geometry,
        model.kinematics(q),
        model.kinematics(model.zeros()),
    )
    tri, _ = rec.surface.triangles()
    n_points = len(rec.surface.points) + len(rec.folds.points)
    return rec, n_points, len(tri), len(rec.folds.segments)


@pytest.mark.parametrize("name", ["model2", "model6"])
def test_vtu_round_trip(request, name, rng, tmp_path) -> None:
    model = request.getfixturevalue(name)
    q = random_configuration(model, rng, amplitude=0.04)
    rec, n_points, n_tri, n_lines = _expected_counts(model, q)
    path = write_vtu(tmp_path / "tube.vtu", model, q)
    mesh = meshio.read(path)
    assert len(mesh.points) == n_points
    assert [(c.type, len(c.data)) for c in mesh.cells] == [("triangle", n_tri), ("line", n_lines)]
    assert set(mesh.point_data) == {"elongation", "development"}
    assert set(mesh.cell_data) == {"module", "element", "fold", "elongation", "phase"}
    n_srf = len(rec.surface.points)
    np.testing.assert_allclose(mesh.points[:n_srf], rec.surface.points)
    w = mesh.point_data["elongation"]
    assert np.isnan(w[:n_srf]).all()
    np.testing.assert_allclose(w[n_srf:], rec.folds.w)
    np.testing.assert_allclose(mesh.point_data["development"][n_srf:], rec.folds.plane)
    module, element = mesh.cell_data["module"], mesh.cell_data["element"]
    assert set(module[0]) == set(range(model.layout.n_modules)) and set(element[0]) == {0, 1}
    assert (element[1] == -1).all() and (mesh.cell_data["fold"][0] == -1).all()
    n_folds = model.layout.n_modules + model.layout.n_connectors
    assert set(mesh.cell_data["fold"][1]) == set(range(n_folds))
    assert np.isnan(mesh.cell_data["elongation"][0]).all()
    # Phases: helical folds of these designs are linear (no phase, -1), circular trilinear.
    phase_lines = mesh.cell_data["phase"][1]
    is_helical = mesh.cell_data["fold"][1] < model.layout.n_modules
    assert (phase_lines[is_helical] == -1).all()
    assert set(phase_lines[~is_helical]) <= {0, 1, 2}


def test_mesh_topology_is_the_same_for_every_state(model6, rng) -> None:
    a = tube_mesh(model6, model6.zeros())
    b = tube_mesh(model6, random_configuration(model6, rng))
    for ca, cb in zip(a.cells, b.cells, strict=True):
        np.testing.assert_array_equal(ca.data, cb.data)


def test_pvd_series(model2, rng, tmp_path) -> None:
    qs = np.array([random_configuration(model2, rng) for _ in range(3)])
    path = write_pvd(tmp_path / "series.pvd", model2, qs, times=[0.0, 0.5, 1.25])
    root = ET.parse(path).getroot()
    sets = root.findall("./Collection/DataSet")
    assert [float(s.get("timestep")) for s in sets] == [0.0, 0.5, 1.25]
    for s, q in zip(sets, qs, strict=True):
        mesh = meshio.read(tmp_path / s.get("file"))
        _, n_points, n_tri, _ = _expected_counts(model2, q)
        assert len(mesh.points) == n_points and len(mesh.cells[0].data) == n_tri
    assert (tmp_path / "series" / "series_0002.vtu").exists()
    with pytest.raises(ValueError, match="times"):
        write_pvd(tmp_path / "bad.pvd", model2, qs, times=[0.0])


def test_export_result(model2, rng, tmp_path) -> None:
    qs = np.array([random_configuration(model2, rng) for _ in range(5)])
    traj = result_dataset(model2, qs, np.linspace(0, 1, 5), times=np.linspace(0, 0.4, 5))
    pvd = export_result(traj, model2, tmp_path / "traj.pvd", stride=2)
    stamps = [float(s.get("timestep")) for s in ET.parse(pvd).getroot().iter("DataSet")]
    assert stamps == pytest.approx([0.0, 0.2, 0.4])
    path = result_dataset(model2, qs, np.linspace(0, 1, 5))
    vtu = export_result(path, model2, tmp_path / "last.vtu")
    np.testing.assert_allclose(meshio.read(vtu).points, tube_mesh(model2, qs[-1]).points)
    with pytest.raises(ValueError, match=r"\.vtu or \.pvd"):
        export_result(path, model2, tmp_path / "x.vtk")
    with pytest.raises(ValueError, match="stride"):
        export_result(path, model2, tmp_path / "x.pvd", stride=0)
