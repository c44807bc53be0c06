"""What a load-controlled test does (:func:`biplan.analysis.response.loadcontrol.load_response`),
and
the numerical path that is not one (:func:`biplan.trace_path` never runs back past its start).

Physics checked: every recorded state is a stable equilibrium (reduced Hessian), the force is
never below zero and rises along each stable branch, the first snap is the located first loss
of stability of the equilibrium path (the phase-1 peak force), every circular fold is open
after the last snap, and the stable branch after it reaches the stop value. The same on a
second tube (β = 50°), whose peak differs.
"""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import biplan
from biplan.analysis.response.loadcontrol import first_snap, load_response
from biplan.analysis.response.summary import softening_steps, summarize
from biplan.model.tube import Tube
from biplan.solvers.path_results import PathStatus

ROOT = Path(__file__).resolve().parents[1]


def _tube(beta: float | None = None) -> Tube:
    tube = biplan.designs.semi_bistable()
    if beta is None:
        return tube
    return replace(
        tube,
        development=replace(tube.development, helical_angle=beta),
        name="semi-bistable laws, β = 50°",
    )


@pytest.fixture(scope="module", params=[None, 50.0], ids=["semi-bistable", "beta-50"])
def pulled(request: pytest.FixtureRequest) -> tuple[biplan.Model, biplan.EquilibriumPath]:
    model = biplan.Model(_tube(request.param))
    return model, load_response(model, biplan.Control.force(2.5))


def _circular(model: biplan.Model) -> np.ndarray:
    return np.arange(model.layout.n_modules, model.layout.n_modules + len(model.layout.connectors))


def test_every_state_is_stable_and_the_force_never_below_zero(pulled) -> None:
    model, r = pulled
    assert r.status is PathStatus.COMPLETED, r.message
    assert r.load_parameter[-1] == pytest.approx(2.5, abs=1e-9)
    assert (r.force >= -1e-9).all()
    assert r.stable.all()
    for k in np.flatnonzero(r.switched)[:2]:  # landing states, re-classified independently
        sol = biplan.solve_equilibrium(model, None, r.z[k], biplan.Load.of_force(r.force[k]))
        assert biplan.classify(model, sol).verdict is biplan.Verdict.STABLE
    # along each stable branch the load rises; snaps happen at non-decreasing loads
    for seg in np.unique(r.segment):
        f = r.force[r.segment == seg]
        assert (np.diff(f) > -1e-9).all()
    loads = [s.force for s in r.snaps]
    assert loads == sorted(loads) and len(r.snaps) >= 1


def test_first_snap_is_the_located_loss_of_stability_of_the_path(pulled) -> None:
    model, r = pulled
    arc = biplan.trace_path(model, biplan.ArcLength(), None, biplan.Control.force(2.5))
    located = arc.events[0]
    assert located.kind in ("limit point", "bifurcation")
    assert r.snaps[0].force == pytest.approx(located.force, rel=5e-3)
    # the force-controlled curve follows the equilibrium path exactly up to the snap
    before = r.segment == 0
    assert r.displacement[before].max() == pytest.approx(located.displacement, rel=5e-3)
    # one number for the phase-1 peak: first_snap is this response's first snap
    peak = first_snap(model)
    assert peak is not None and peak.force == r.snaps[0].force
    assert summarize(r, peak=peak).peak_force == peak.force


def test_after_the_last_snap_every_circular_fold_is_open(pulled) -> None:
    model, r = pulled
    open_ = r.phase_fraction[:, :, 2]
    circular = _circular(model)
    assert (open_[0, circular] < 0.5).all()
    last = r.segment == r.segment.max()
    assert (open_[last][:, circular] > 0.5).all()
    assert r.segment.max() == len(r.snaps)
    # each snap names the folds it opened; together they are every circular fold
    names = {n for s in r.snaps for n in s.folds}
    assert {f"circular {c.lower + 1 if c.lower is not None else 0}|{c.upper + 1}"
            for c in model.layout.connectors} <= names  # fmt: skip
    assert all(s.displacement_after > s.displacement_before for s in r.snaps)


def test_the_two_tubes_snap_at_different_forces() -> None:
    a = first_snap(biplan.Model(_tube()))
    b = first_snap(biplan.Model(_tube(50.0)))
    assert a is not None and b is not None
    assert abs(a.force - b.force) > 1e-3


def test_stop_at_snap_ends_at_the_peak() -> None:
    model = biplan.Model(_tube())
    r = load_response(model, biplan.Control.force(2.5), stop_at_snap=True)
    assert r.status is PathStatus.SNAPPED and len(r.snaps) == 1
    assert r.force[-1] == r.snaps[0].force and r.stable.all()
    assert np.isnan(r.snaps[0].displacement_after)


def test_arclength_never_runs_back_past_its_start() -> None:
    """The equilibrium path under force control passes the peak and comes back down; it
    stops where the force would change sign instead of running into compression."""
    model = biplan.Model(_tube())
    arc = biplan.trace_path(model, biplan.ArcLength(), None, biplan.Control.force(2.5))
    assert arc.status is PathStatus.RETURNED
    assert (arc.load_parameter >= 0.0).all()
    assert arc.load_parameter.max() > 2.0 and arc.load_parameter[-1] < 0.5
    assert "back past its start" in arc.message
    # an unstable stretch whose force falls with falling displacement is no stable softening
    assert np.isnan(summarize(arc).softening_start)


def test_softening_needs_the_displacement_to_rise() -> None:
    f = np.array([0.0, 1.0, 2.0, 1.5, 1.0])
    stable = np.ones(5, bool)
    rising = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    falling = np.array([0.0, 1.0, 2.0, 1.9, 1.8])
    assert softening_steps(f, stable, displacement=rising).tolist() == [0, 0, 0, 1, 1]
    assert not softening_steps(f, stable, displacement=falling).any()


def test_pressure_control_reaches_its_stop_in_kpa_files() -> None:
    from biplan.io.results import dataset

    model = biplan.Model(_tube())
    r = load_response(model, biplan.Control.pressure(0.2))
    assert r.status is PathStatus.COMPLETED and r.stable.all()
    ds = dataset(r)
    assert ds["load_parameter"].attrs["units"] == "kPa" and ds.attrs["control_unit"] == "kPa"
    assert float(ds["load_parameter"][-1]) == pytest.approx(200.0)
    assert ds.attrs["control_stop"] == pytest.approx(200.0)
    # pressure acts as the end force p π R²: the first snap at the force-controlled peak
    peak = first_snap(model)
    assert peak is not None
    area = np.pi * model.tube.development.radius**2
    assert r.snaps[0].load_parameter * area == pytest.approx(peak.force, rel=1e-3)
    assert "segment" in ds and int(ds["switched"].sum()) == len(r.snaps)
    # `biplan plot --kind response` of the file draws the controlled pressure [kPa]
    from biplan.cli.plot import Kind
    from biplan.plot.results import result_figure as _figure

    fig = _figure(ds, Kind.response, 0, "elongation", False, {})
    ax = fig.axes[0]
    assert "[kPa]" in ax.get_ylabel()
    drawn = np.concatenate([line.get_ydata() for line in ax.get_lines() if len(line.get_ydata())])
    assert drawn.max() == pytest.approx(200.0)


def test_readme_reports_the_located_peak() -> None:
    text = (ROOT / "README.md").read_text()
    quoted = re.search(r"# snap at ([\d.]+) ±", text)
    assert quoted is not None
    peak = first_snap(biplan.Model(_tube()))
    assert peak is not None and float(quoted[1]) == pytest.approx(peak.force, abs=5e-5)


def test_a_response_stalled_against_closed_folds_says_so() -> None:
    """A tube the repo does not ship (three modules, point-mirrored, loaded at the seam) is
    pressed shut after its snap: the stable response stalls at 2.23 N with its contacts
    carrying 0.95 N, and its message says that the load goes into closed folds; with ten
    times the contact compliance the same response ends with FULL_CONTACT. A path that
    completes carries no such sentence, and its contacts almost nothing."""
    from biplan.laws.linear import LinearLaw
    from biplan.laws.trilinear import TrilinearLaw
    from biplan.options import ChainAttachment, EndpointDefinition, LoadPoint, MirrorConvention
    from biplan.solvers.path_results import PRESSED_SHUT_SHARE

    options = biplan.ModelOptions(
        mirror=MirrorConvention.POINT,
        chain_attachment=ChainAttachment.EDGE_FIT,
        endpoint=EndpointDefinition.SEAM_NODE,
        load_point=LoadPoint.SEAM,
    )
    tube = Tube.uniform(
        radius=1.9732945962148376,
        pitch=3.558060087555341,
        helical_angle=58.86110658553659,
        n_modules=3,
        helical=LinearLaw(1.29668381809041),
        circular=TrilinearLaw(
            (0.8977041817548992, -0.19948981816775538, 0.598469454503266), (0.2, 1.3)
        ),
        options=options,
    )
    stalled = load_response(biplan.Model(tube), biplan.Control.force(2.5))
    assert stalled.status is PathStatus.STALLED
    reaction, force = stalled.contact_share()
    assert 2.2 < force < 2.3 and reaction > 0.4 * force
    assert f"contacts carry up to {reaction:.3g} N" in stalled.message
    assert "the tube is pressed shut" in stalled.message
    compliant = tube.with_options(contact_compliance=1e-5)
    shut = load_response(biplan.Model(compliant), biplan.Control.force(2.5))
    assert shut.status is PathStatus.FULL_CONTACT
    assert shut.force[-1] == pytest.approx(force, abs=0.05)
    done = load_response(biplan.Model(_tube()), biplan.Control.force(2.5))
    reaction, force = done.contact_share()
    assert done.completed and reaction < 0.01 * PRESSED_SHUT_SHARE * force
    assert "closed folds" not in done.message
