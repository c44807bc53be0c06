"""``analysis.response.summarize``: the phase-1 peak, the spinodal regime and stable softening
read off a response, checked on hand-made curves whose answers are known by construction."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from biplan.analysis.response.summary import summarize


def _curve(force, stable=None, switched=None, step: float = 0.2) -> SimpleNamespace:
    f = np.asarray(force, dtype=float)
    zp = step * np.arange(1, f.size + 1)
    out = SimpleNamespace(
        force=f,
        displacement=zp,
        u_z=zp,
        u_r=-0.1 * zp,
        theta=-0.01 * zp,
        stable=np.ones(f.size, bool) if stable is None else np.asarray(stable, bool),
    )
    if switched is not None:
        out.switched = np.asarray(switched, bool)
    return out


def test_stable_softening_ends_phase_one() -> None:
    """Two folds in series with (n − 1)|k₂| < k₁: the force falls along stable states (no snap,
    no unstable state) and rises again on the open branch, past the first peak. The phase-1
    peak is the first maximum, not the larger force at the end."""
    force = [1.0, 2.0, 3.0, 2.5, 1.0, -0.5, 0.5, 4.0, 9.0]
    s = summarize(_curve(force), initial_length=10.0)
    assert (s.peak_force, s.peak_displacement) == (3.0, pytest.approx(0.6))
    assert (s.softening_start, s.softening_end) == (pytest.approx(0.8), pytest.approx(1.2))
    assert np.isnan(s.spinodal_start) and s.spinodal_span == 0.0
    text = "\n".join(s.lines())
    assert "stable softening" in text and "0.800 … 1.200 mm" in text


def test_snaps_and_instability_end_phase_one() -> None:
    """A snap (``switched``) or an unstable state ends phase 1 where it occurs; a force that
    only rises has no softening; a drop smaller than the tolerance is not one."""
    rising = [1.0, 2.0, 2.0 - 1e-12, 3.0, 4.0]
    s = summarize(_curve(rising), initial_length=1.0)
    # a force that only rises never leaves phase 1: its largest force is no peak
    assert np.isnan(s.peak_force) and s.largest_force == 4.0 and np.isnan(s.softening_start)
    assert "softening" not in "\n".join(s.lines())
    assert "phase 1 not left (largest force 4.0000 N)" in s.lines()[0]
    snap = summarize(_curve([1, 2, 0.5, 3, 4], switched=[0, 0, 1, 0, 0]), initial_length=1.0)
    assert snap.peak_force == 2.0 and np.isnan(snap.softening_start)  # a snap is no softening
    lost = summarize(_curve([1, 2, 2.5, 2.4, 5], stable=[1, 1, 0, 0, 1]), initial_length=1.0)
    assert lost.peak_force == 2.0
    assert (lost.spinodal_start, lost.spinodal_end) == (pytest.approx(0.6), pytest.approx(0.8))
    assert np.isnan(lost.softening_start)  # the fall 2.5 → 2.4 is along unstable states


def test_state_at_the_terminal_force_is_interpolated() -> None:
    s = summarize(_curve([0.0, 1.0, 2.0]), force=1.5, initial_length=2.0)
    assert s.u_z_ratio == pytest.approx(0.5 * 0.5 * (0.4 + 0.6))
    assert s.u_r_ratio == pytest.approx(-0.1 * s.u_z_ratio) and s.at_force == 1.5
    assert "at F = 1.5 N: u_z/l0 = 0.2500" in s.lines()[-1]


def test_a_force_never_reached_is_said_not_printed_as_nan() -> None:
    """A compression run (forces ≤ 0) never reaches the reported tensile force: the summary
    says so instead of printing u_z/l0 = nan."""
    s = summarize(_curve([0.0, -1.0, -2.0]), force=1.6, initial_length=2.0)
    assert np.isnan(s.u_z_ratio)
    assert s.lines()[-1] == "F = 1.6 N is not reached by the recorded response"
    assert "nan" not in "\n".join(s.lines())


def test_phase_one_is_one_definition() -> None:
    """``summarize``, the demo's snapshots and the reproduce report end phase 1 at the same
    step: the first failure, instability, snap or stable fall of the force."""
    from biplan.analysis.response.demo import phase_one
    from biplan.analysis.response.summary import phase_one_end
    from biplan.reproduction.facts import SemiBistableFacts

    cases = {
        "softening": ([1.0, 2.0, 3.0, 2.5, 9.0], [1] * 5, [0] * 5, 3),
        "failure": ([1.0, 2.0, np.nan, 4.0, 5.0], [1] * 5, [0] * 5, 2),
        "unstable": ([1.0, 2.0, 3.0, 4.0, 5.0], [1, 1, 1, 0, 1], [0] * 5, 3),
        "snap": ([1.0, 2.0, 0.5, 4.0, 5.0], [1] * 5, [0, 0, 1, 0, 0], 2),
        "regular": ([1.0, 2.0, 3.0, 4.0, 5.0], [1] * 5, [0] * 5, 5),
    }
    for name, (f, st, sw, end) in cases.items():
        curve = _curve(f, stable=st, switched=sw)
        assert phase_one_end(curve.force, curve.stable, curve.switched) == end, name
        assert phase_one(curve) == slice(0, end), name
        u = curve.displacement
        facts = SemiBistableFacts(0.5, 1.0, 1.0, u, curve.force, u, u, u, curve.stable,
                                  curve.switched)  # fmt: skip
        assert facts.phase_one == slice(0, end), name
        # a peak only where phase 1 ends inside the response
        peak = np.nanmax(curve.force[:end]) if 0 < end < len(f) else np.nan
        assert summarize(curve, initial_length=1.0).peak_force == pytest.approx(
            peak, nan_ok=True
        ), name
