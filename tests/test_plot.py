"""Plotting functions run headless on small results and draw what they promise."""

from __future__ import annotations

from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection

import biplan
from biplan.analysis.response.quasistatic import displacement_sweep
from biplan.plot import cylinder, development, elongation_norm, fold_lines, force_displacement
from biplan.plot.tube import ARC_SUBDIVISIONS, ELEMENT_NODES, element_strips


@pytest.fixture(scope="module")
def model() -> biplan.Model:
    return biplan.Model(biplan.designs.semi_bistable())


@pytest.fixture(scope="module")
def path(model: biplan.Model):
    """A short sweep through phase 1 of the semi-bistable tube (kernels compile once)."""
    return displacement_sweep(model, np.linspace(0.1, 2.5, 8))


@pytest.fixture(scope="module")
def solved_q(path) -> np.ndarray:
    k = int(np.flatnonzero(np.isfinite(path.force))[-1])
    return path.solutions[k].q


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def _n_fields(model: biplan.Model) -> int:
    return sum(len(w0) for w0, _, _ in model.circular_fields(model.zeros()))


# --- force-displacement ------------------------------------------------------------------------
def test_force_displacement_on_sweep(path) -> None:
    ax = force_displacement(path)
    assert isinstance(ax, Axes)
    assert "[mm]" in ax.get_xlabel() and "[N]" in ax.get_ylabel()
    assert tuple(ax.figure.get_size_inches()) == pytest.approx((3.4, 2.6))
    drawn = np.concatenate([ln.get_xdata() for ln in ax.lines if ln.get_linestyle() == "-"])
    finite = path.displacement[np.isfinite(path.force)]
    assert set(np.round(finite, 12)) <= set(np.round(drawn.astype(float), 12))


def test_force_displacement_styles_and_normalisation() -> None:
    """Stable runs solid, unstable dashed, snaps marked, failed steps left out."""
    fake = SimpleNamespace(
        displacement=np.arange(8.0),
        force=np.array([0.0, 1.0, 2.0, 1.5, 1.0, np.nan, 0.5, 1.0]),
        stable=np.array([True, True, True, False, False, False, True, True]),
        switched=np.array([False, False, False, False, False, False, True, False]),
    )
    _, ax = plt.subplots()
    assert force_displacement(fake, ax=ax, normalise=4.0) is ax
    assert "l_0" in ax.get_xlabel()
    dashed = [ln for ln in ax.lines if ln.get_linestyle() == "--"]
    assert len(dashed) == 1
    np.testing.assert_allclose(dashed[0].get_xdata(), [0.5, 0.75, 1.0])
    markers = [ln for ln in ax.lines if ln.get_marker() == "o"]
    assert len(markers) == 1 and list(markers[0].get_xdata()) == [1.5]
    with pytest.raises(ValueError, match="normalise"):
        force_displacement(fake, normalise=0.0)


def _data_points_in_display(ax: Axes) -> np.ndarray:
    """Every vertex of every line of ``ax`` (display coordinates, finite only)."""
    xy = np.concatenate([ln.get_xydata() for ln in ax.lines if len(ln.get_xydata())])
    xy = xy[np.isfinite(xy).all(axis=1)]
    return ax.transData.transform(xy)


@pytest.mark.parametrize("corner", ["upper left", "upper right", "everywhere"])
def test_force_displacement_legend_names_the_styles_off_the_data(corner) -> None:
    """Stable (solid), unstable (dashed), the snap and the limit point are in the legend, and
    the legend covers no data point wherever the curve runs."""
    u = np.linspace(0.0, 1.0, 41)
    f = {"upper left": 1.0 - u, "upper right": u, "everywhere": np.sin(12 * u)}[corner]
    stable = np.ones(u.size, bool)
    stable[15:25] = False
    switched = np.zeros(u.size, bool)
    switched[30] = True
    events = np.zeros(u.size, bool)
    events[15] = True
    fake = SimpleNamespace(displacement=u, force=f, stable=stable, switched=switched,
                           is_event=events)  # fmt: skip
    ax = force_displacement(fake)
    ax.figure.canvas.draw()
    legend = ax.get_legend()
    texts = [t.get_text() for t in legend.get_texts()]
    assert texts == ["stable", "unstable", "branch switch", "limit point / bifurcation"]
    styles = [h.get_linestyle() for h in legend.legend_handles[:2]]
    assert styles == ["-", "--"]
    box = legend.get_window_extent()
    points = _data_points_in_display(ax)
    inside = (
        (points[:, 0] >= box.x0) & (points[:, 0] <= box.x1)
        & (points[:, 1] >= box.y0) & (points[:, 1] <= box.y1)
    )  # fmt: skip
    assert not inside.any()
    assert box.y0 >= ax.get_window_extent().y1 - 1.0  # above the axes
    assert ax.figure.get_window_extent().contains(box.x1 - 1, box.y1 - 1)  # inside the figure


def test_force_displacement_legend_follows_label_and_can_be_left_out() -> None:
    fake = SimpleNamespace(displacement=np.arange(4.0), force=np.arange(4.0),
                           stable=np.ones(4, bool))  # fmt: skip
    ax = force_displacement(fake, label="path")
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["path, stable"]
    _, ax = plt.subplots()
    assert force_displacement(fake, ax=ax, legend=False).get_legend() is None


# --- development ---------------------------------------------------------------------------------
@pytest.mark.parametrize("state", ["reference", "solved"])
def test_development_draws_every_fold_field(model, solved_q, state) -> None:
    q = model.zeros() if state == "reference" else solved_q
    ax = development(model, q, reference=True)
    assert isinstance(ax, Axes)
    gids = [c.get_gid() or "" for c in ax.collections if isinstance(c, LineCollection)]
    helical = [g for g in gids if g.startswith("helical-fold")]
    circular = [g for g in gids if g.startswith("circular-field")]
    assert len(helical) == model.layout.n_modules == 6
    assert len(circular) == _n_fields(model) == 9
    assert len(helical) + len(circular) == model.layout.n_modules + _n_fields(model)
    assert any(c.get_gid() == "reference" for c in ax.collections)
    assert ax.get_aspect() == 1.0
    assert "s" in ax.get_xlabel() and "z" in ax.get_ylabel()
    labels = [a.get_ylabel() for a in ax.figure.axes if a is not ax]
    assert any("w" in lab and "[mm]" in lab for lab in labels)


def test_development_colours_follow_elongation(model, solved_q) -> None:
    norm = elongation_norm(model, [model.zeros(), solved_q])
    ax = development(model, solved_q, norm=norm, colorbar=False)
    assert len(ax.figure.axes) == 1
    lines = {gid: (start, end) for gid, start, end, _ in fold_lines(model, solved_q)}
    for c in ax.collections:
        if (c.get_gid() or "") in lines:
            start, end = lines[c.get_gid()]
            values = np.asarray(c.get_array())
            assert values.min() >= min(start[2], end[2]) - 1e-12
            assert values.max() <= max(start[2], end[2]) + 1e-12
            assert c.norm is norm


def test_fold_lines_match_kinematics(model, solved_q) -> None:
    kin = model.kinematics(solved_q)
    nodes = model.global_nodes(solved_q)
    lines = fold_lines(model, solved_q)
    for n in range(model.layout.n_modules):
        gid, start, end, _ = lines[n]
        assert gid == f"helical-fold-{n}"
        np.testing.assert_allclose(start[:2], 0.5 * (nodes[n, 3] + nodes[n, 4]))
        np.testing.assert_allclose(end[:2], 0.5 * (nodes[n, 2] + nodes[n, 5]))
        np.testing.assert_allclose([start[2], end[2]], kin.helical[n])
    circular = np.array([[s[2], e[2]] for _, s, e, _ in lines[model.layout.n_modules :]])
    np.testing.assert_allclose(circular[:, 0], kin.field_start)
    np.testing.assert_allclose(circular[:, 1], kin.field_end)


def test_development_phase_view(model, solved_q) -> None:
    ax = development(model, solved_q, color_by="phase")
    cbar = ax.figure.axes[-1]
    assert [t.get_text() for t in cbar.get_yticklabels()] == ["closed", "spinodal", "open"]
    with pytest.raises(ValueError, match="color_by"):
        development(model, solved_q, color_by="energy")


# --- cylinder -------------------------------------------------------------------------------------
def _area(poly: np.ndarray) -> float:
    z, s = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.sum(z * np.roll(s, -1) - np.roll(z, -1) * s)))


@pytest.mark.parametrize("state", ["reference", "solved"])
def test_element_strips_tile_the_element(model, solved_q, state) -> None:
    q = model.zeros() if state == "reference" else solved_q
    nodes = model.global_nodes(q)
    width = model.tube.development.circumference / ARC_SUBDIVISIONS
    for n in range(model.layout.n_modules):
        for idx in ELEMENT_NODES:
            corners = nodes[n, list(idx)]
            strips = element_strips(corners, width)
            assert sum(_area(p) for p in strips) == pytest.approx(_area(corners), rel=1e-12)
            for p in strips:
                assert 3 <= len(p) <= 6
                assert np.ptp(p[:, 1]) <= width * (1 + 1e-12)
                k = np.floor(p[:, 1].min() / width + 1e-9)  # strips sit on the global grid
                assert p[:, 1].max() <= (k + 1) * width + 1e-9


def test_cylinder_draws_wrapped_elements(model, solved_q) -> None:
    ax = cylinder(model, model.zeros())
    assert isinstance(ax, Axes) and ax.name == "3d"
    polys = [c for c in ax.collections if c.get_gid() == "cylinder"]
    assert len(polys) == 1
    # Element 1 spans the full turn, element 2 the helical span H2 (plus boundary strips).
    dev = model.tube.development
    per_module = ARC_SUBDIVISIONS * (1 + dev.helical_span / dev.circumference)
    n_facets = len(polys[0].get_facecolor())
    assert per_module * model.layout.n_modules <= n_facets <= (per_module + 2) * 6
    r = model.tube.development.radius
    assert ax.get_xlim() == pytest.approx((-1.8 * r, r), abs=1e-6)
    assert ax.get_zlim()[1] == pytest.approx(model.tube.initial_length, rel=1e-6)
    # A second state beside the first: the view grows to hold both.
    cylinder(model, solved_q, ax=ax, offset=(5 * r, 0.0))
    assert ax.get_xlim()[1] == pytest.approx(6 * r, abs=1e-6)
    assert ax.get_zlim()[1] > model.tube.initial_length
    ax.figure.canvas.draw()  # renders headless


def _stability_ds(regime: np.ndarray, band: np.ndarray | None = None):
    import xarray as xr

    u = np.array([0.01, 0.06, 0.11, 0.16, 0.21])
    c = np.array([0.5, 1.75, 3.0])
    band = np.zeros_like(regime, dtype=bool) if band is None else band
    return xr.Dataset(
        {"regime": (("C", "displacement"), regime), "transition": (("C", "displacement"), band)},
        coords={"C": c, "displacement": u},
    )


def test_stability_map_cells_and_band_outline() -> None:
    """The axes end at the grid (the outer points' cells are half cells), and the band outline
    is the boundary of the union of the hatched band cells: a 2 × 2 block in a 3 × 5 grid has
    a perimeter of 8 cell sides."""
    from biplan.plot.maps import _band_outline, grid_edges, stability_map
    from biplan.plot.response import cell_edges

    regime = np.array([[1, 2, 3, 2, 2], [1, 2, 3, 2, 2], [1, 1, 2, 2, 2]], dtype=float)
    band = np.zeros_like(regime, dtype=bool)
    band[:2, 1:3] = True
    ds = _stability_ds(regime, band)
    u, c = ds["displacement"].values, ds["C"].values
    ax = stability_map(ds)
    assert ax.get_xlim() == pytest.approx((0.01, 0.21))  # the grid's first and last U/l0
    assert ax.get_ylim() == pytest.approx((0.5, 3.0))  # and C
    np.testing.assert_allclose(grid_edges(c), [0.5, 1.125, 2.375, 3.0])
    np.testing.assert_allclose(grid_edges(np.array([0.2])), [0.0, 0.7])  # one value: a cell
    np.testing.assert_allclose(cell_edges(c), [-0.125, 1.125, 2.375, 3.625])
    np.testing.assert_allclose(cell_edges(np.array([-1.0, 1.0]), True), [-2.0, 0.0, 2.0])
    segments = _band_outline(band, grid_edges(u), grid_edges(c))
    assert len(segments) == 8
    # every segment lies on the boundary of the block [0.035, 0.135] × [0.5, 2.375]
    for (x0, y0), (x1, y1) in segments:
        vertical = x0 == x1 and min(abs(x0 - 0.035), abs(x0 - 0.135)) < 1e-12
        horizontal = y0 == y1 and min(abs(y0 - 0.5), abs(y0 - 2.375)) < 1e-12
        assert vertical != horizontal
    lines = [coll for coll in ax.collections if isinstance(coll, LineCollection)]
    assert len(lines) == 1 and len(lines[0].get_segments()) == 8
    # the regions fill the frame exactly: the mesh spans the grid
    mesh = ax.collections[0]
    corners = mesh.get_coordinates().reshape(-1, 2)
    assert corners[:, 0].min() == pytest.approx(0.01) and corners[:, 0].max() == pytest.approx(0.21)
    plt.close(ax.figure)


def test_stability_map_over_decades_of_c_is_drawn_on_a_log_axis() -> None:
    """C log-spaced over almost two decades (the reproduction's grid): cell edges at the
    geometric means of neighbours, a log C axis that ends at the grid."""
    from biplan.plot.maps import grid_edges, stability_map

    regime = np.array([[3, 3, 3, 3, 3], [2, 2, 3, 3, 3], [1, 1, 2, 2, 2]], dtype=float)
    ds = _stability_ds(regime, np.zeros_like(regime, dtype=bool))
    c = np.geomspace(0.05, 3.0, 3)
    ds = ds.assign_coords(C=c)
    np.testing.assert_allclose(
        grid_edges(c, log=True), [0.05, np.sqrt(c[0] * c[1]), np.sqrt(c[1] * c[2]), 3.0]
    )
    ax = stability_map(ds)
    assert ax.get_yscale() == "log"
    assert ax.get_ylim() == pytest.approx((0.05, 3.0))
    plt.close(ax.figure)


@pytest.mark.parametrize(
    ("regime", "labels"),
    [
        (np.full((3, 5), 2.0), ["bistable"]),
        (np.array([[1, 1, 2, 2, 2]] * 3, dtype=float), ["monostable", "bistable"]),
        (np.array([[0, 3, 3, np.nan, 1]] * 3, dtype=float),
         ["monostable", "multistable", "none found", "failed"]),
    ],
)  # fmt: skip
def test_stability_map_legend_names_only_the_regimes_present(regime, labels) -> None:
    from biplan.plot.maps import stability_map

    ax = stability_map(_stability_ds(regime))
    assert [t.get_text() for t in ax.get_legend().get_texts()] == labels  # no transition band
    band = np.zeros_like(regime, dtype=bool)
    band[0, 0] = True
    ax = stability_map(_stability_ds(regime, band))
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [*labels, "transition"]


def test_design_map_stars_the_swept_design() -> None:
    """The star marks the design the map was swept from (``base_value`` of the b and C
    coordinates), the validated design when the map does not record it, nothing for None."""
    import xarray as xr

    from biplan.plot.maps import VALIDATED_DESIGN, design_map

    b, c = np.array([0.3, 0.45, 0.6]), np.array([0.5, 1.5, 3.0])
    u_z = 0.02 + 0.01 * b[:, None] - 0.001 * c[None, :]

    def star_of(ds: xr.Dataset, **kw: object) -> tuple[float, float] | None:
        ax = design_map(ds, "u_z", **kw)
        stars = [ln for ln in ax.get_lines() if ln.get_marker() == "*"]
        plt.close(ax.figure)
        return (float(stars[0].get_xdata()[0]), float(stars[0].get_ydata()[0])) if stars else None

    plain = xr.Dataset({"u_z": (("b", "C"), u_z)}, coords={"b": b, "C": c})
    assert star_of(plain) == VALIDATED_DESIGN
    assert star_of(plain, star=None) is None
    based = plain.assign_coords(b=("b", b, {"base_value": 0.3}), C=("C", c, {"base_value": 1.444}))
    assert star_of(based) == (0.3, 1.444)
    assert star_of(based, star=(0.45, 2.0)) == (0.45, 2.0)
    assert star_of(based, star=(0.7, 1.444)) is None  # off the map (b ≤ 0.6): not drawn
    with pytest.raises(biplan.ConfigError, match="star"):
        design_map(based, "u_z", star="validated")


def test_design_map_highlights_one_level() -> None:
    """``highlight`` draws the contour of one value (the 1.6 N ramp on a first-instability
    map) over the filled levels, labelled; a value outside the map's range draws nothing."""
    import xarray as xr
    from matplotlib.contour import ContourSet

    from biplan.plot.maps import design_map

    b, c = np.linspace(0.3, 0.95, 4), np.geomspace(0.05, 3.0, 4)
    force = 1.0 + np.log10(c)[None, :] * 0.5 + 0.5 * (1.0 - b[:, None]) + 0.8
    ds = xr.Dataset({"force": (("b", "C"), force)}, coords={"b": b, "C": c})

    def lines(**kw: object) -> list[ContourSet]:
        ax = design_map(ds, "force", **kw)
        found = [cs for cs in ax.findobj(ContourSet) if not cs.filled and list(cs.levels) == [1.6]]
        assert ax.get_yscale() == "log"  # C spans almost two decades
        plt.close(ax.figure)
        return found

    assert lines() == []
    assert len(lines(highlight=1.6)) == 1
    assert lines(highlight=1.6 + 10.0) == []
