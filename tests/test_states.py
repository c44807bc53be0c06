"""Stable-state enumeration, labels, transition graph, hierarchy (issue "stable states")."""

from __future__ import annotations

import itertools

import networkx as nx
import numpy as np
import pytest

import biplan
from biplan.analysis.states.catalogue import StateCatalogue
from biplan.analysis.states.hierarchy import hierarchy
from biplan.analysis.states.labels import (
    bistable_folds,
    bits_to_label,
    hamming,
    label_to_bits,
    physical_folds,
)
from biplan.analysis.states.search import enumerate_states, relax_state, state_bits
from biplan.analysis.states.transitions import pathway, transition_graph
from biplan.io.graphml import write_graphml
from biplan.model.assembly import autodiff_functions

RESIDUAL_TOL = 1e-7


@pytest.fixture(scope="module")
def catalogue4(model4):
    return enumerate_states(model4)


@pytest.fixture(scope="module")
def catalogue1(model1):
    return enumerate_states(model1)


# --- labels -------------------------------------------------------------------------------
def test_paper_label_example():
    assert bits_to_label((0, 0, 1, 1, 0, 1, 1)) == "1B"
    assert bits_to_label((0, 1, 0, 1, 0, 1, 0)) == "2A"
    assert bits_to_label((1, 1, 0, 0, 1, 1, 0)) == "66"
    assert label_to_bits("1B", 7) == (0, 0, 1, 1, 0, 1, 1)


@pytest.mark.parametrize("n", [1, 3, 4, 7, 9])
def test_labels_round_trip(n):
    for bits in itertools.product((0, 1), repeat=n):
        label = bits_to_label(bits)
        assert len(label) == (n + 3) // 4
        assert label_to_bits(label, n) == bits


def test_bad_labels_are_rejected():
    with pytest.raises(biplan.ConfigError, match="label"):
        label_to_bits("ZZ", 7)
    with pytest.raises(biplan.ConfigError, match="label"):
        label_to_bits("80", 7)  # needs 8 bits
    with pytest.raises(biplan.ConfigError, match="bits"):
        bits_to_label((0, 2))


def test_physical_fold_order(model4, model1):
    # Four modules without a base fold: H4 C34 H3 C23 H2 C12 H1 (MODEL §15 CHOICE B1).
    order = [(f.set, f.index) for f in physical_folds(model4.tube)]
    assert order == [
        ("helical", 3),
        ("circular", 2),
        ("helical", 2),
        ("circular", 1),
        ("helical", 1),
        ("circular", 0),
        ("helical", 0),
    ]
    # One module on a base fold with a linear helical law: only the base fold is bistable.
    assert [(f.set, f.index) for f in bistable_folds(model1.tube)] == [("circular", 0)]


# --- enumeration --------------------------------------------------------------------------
def test_single_bistable_fold_has_two_states_known_by_hand(catalogue1, model1):
    """One module on a bistable base fold: closed (q = 0) and the uniformly open fold."""
    assert sorted(s.label for s in catalogue1.states) == ["0", "1"]
    closed, open_ = catalogue1.state("0"), catalogue1.state("1")
    np.testing.assert_allclose(closed.q, 0.0, atol=1e-6)  # SFB smoothing: w·λ = ε²/2
    assert closed.energy == pytest.approx(0.0, abs=1e-10)
    law = model1.tube.circular_laws[0]
    w_s = law.wells()[-1]
    circumference = 2 * np.pi * model1.tube.development.radius
    # The open base fold is uniform at the open well (the linear helical fold is unstrained).
    assert open_.energy == pytest.approx(circumference * float(law.energy_density(w_s)), rel=1e-6)
    assert open_.u_z == pytest.approx(w_s, rel=1e-6)
    assert abs(open_.u_r) < 1e-6 and abs(open_.theta) < 1e-6
    assert all(s.matches_seed for s in catalogue1.seeds)
    # both states are straight: Θ = 0, not rounding-level θ divided by a rounding-level max
    assert [row["Theta"] for row in catalogue1.rows()] == [0.0, 0.0]


def test_states_are_stable_equilibria(catalogue4, model4):
    assert len(catalogue4) >= 4
    zero = biplan.Load.of_force(0.0)
    residual = autodiff_functions(model4.layout).residual
    for s in catalogue4.states:
        r = np.asarray(residual(model4.params, s.z, zero))
        assert np.max(np.abs(r)) < RESIDUAL_TOL, s.name
        sol = biplan.solve_equilibrium(model4, None, s.z)
        assert sol.converged
        np.testing.assert_allclose(sol.q, s.q, atol=1e-7)
        verdict = biplan.classify(model4, sol)
        assert verdict.verdict is biplan.Verdict.STABLE, s.name
        assert verdict.min_eigenvalue == pytest.approx(s.min_eigenvalue, rel=1e-5, abs=1e-8)


def test_rejected_equilibria_are_not_stable(catalogue4, model4):
    for z, eig in zip(catalogue4.unstable_z, catalogue4.unstable_eigenvalues, strict=True):
        assert eig <= catalogue4.settings.stability_tolerance
        sol = biplan.solve_equilibrium(model4, None, z)
        assert sol.converged
        assert biplan.classify(model4, sol).min_eigenvalue <= 1e-8


def test_states_are_distinct_and_every_seed_is_accounted_for(catalogue4):
    qs = np.array([s.q for s in catalogue4.states])
    for i, j in itertools.combinations(range(len(qs)), 2):
        assert np.max(np.abs(qs[i] - qs[j])) > catalogue4.settings.duplicate_tolerance
    assert len(catalogue4.seeds) == 2**7
    assert len(set(catalogue4.names)) == len(catalogue4)
    reached = {name for s in catalogue4.seeds if s.state for name in [s.state]}
    assert reached == set(catalogue4.names)
    for s in catalogue4.states:
        assert s.seeds, s.name
    for seed in catalogue4.seeds:
        if seed.outcome == "stable":
            assert catalogue4.state(seed.state).bits == seed.reached_bits


def test_a_named_state_relaxed_alone_is_the_enumerated_one(catalogue4, model4):
    """relax_state (one seed, then Newton to 1e-12) lands on the catalogue's state, with its
    bits; a label of no stable state is refused with what its seed reached instead."""
    by_name = {s.name: s for s in catalogue4.states}
    for label in ("1B", "66"):
        sol = relax_state(model4, label)
        assert sol.converged and sol.residual_norm < 1e-11
        assert state_bits(model4, sol.q) == by_name[label].bits
        np.testing.assert_allclose(sol.q, by_name[label].q, atol=1e-6)
    missing = next(o for o in catalogue4.seeds if o.outcome == "stable" and not o.matches_seed)
    if missing.seed not in by_name:
        with pytest.raises(biplan.ConvergenceError, match=f"state {missing.seed}"):
            relax_state(model4, missing.seed)
    with pytest.raises(biplan.ConfigError, match="label"):
        relax_state(model4, "FF")


def test_closed_state_is_found(catalogue4):
    closed = catalogue4.state("00")
    np.testing.assert_allclose(closed.q, 0.0, atol=1e-6)


# --- graph --------------------------------------------------------------------------------
def test_graph_edges_are_exactly_hamming_one(catalogue4, tmp_path):
    g = transition_graph(catalogue4)
    assert set(g.nodes) == set(catalogue4.names)
    for a, b in itertools.combinations(catalogue4.states, 2):
        assert g.has_edge(a.name, b.name) == (hamming(a.bits, b.bits) == 1)
    back = nx.read_graphml(write_graphml(g, tmp_path / "t.graphml"))
    assert set(back.edges) == {tuple(e) for e in g.edges} | {(b, a) for a, b in g.edges} & set(
        back.edges
    )
    assert back.number_of_edges() == g.number_of_edges()
    # each edge names its fold as the result files do (modules from 1, "circular 1|2")
    names = catalogue4.model.layout.fold_names
    for _, _, data in g.edges(data=True):
        fold = catalogue4.folds[data["fold"]]
        assert data["fold_name"] == catalogue4.model.layout.fold_name(fold) in names
        assert data["fold_name"].split()[0] == fold.set


def test_pathway_is_a_shortest_chain_of_single_fold_switches(catalogue4):
    g = transition_graph(catalogue4)
    component = max(nx.connected_components(g), key=len)
    names = sorted(component)
    start, target = names[0], names[-1]
    path = pathway(g, start, target)
    assert path[0] == start and path[-1] == target
    assert len(path) - 1 == nx.shortest_path_length(g, start, target)
    for u, v in itertools.pairwise(path):
        assert hamming(catalogue4.state(u).bits, catalogue4.state(v).bits) == 1
    every = pathway(g, start, target, all_paths=True)
    assert path in every and all(len(p) == len(path) for p in every)
    with pytest.raises(biplan.ConfigError, match="start"):
        pathway(g, "ZZ", target)


# --- hierarchy ----------------------------------------------------------------------------
def test_hierarchy_counts_and_branches(catalogue4):
    h = hierarchy(catalogue4)
    n = len(catalogue4)
    assert int(h["count_Theta"].sum()) == n
    assert int(h["count_u_z"].sum()) == n
    assert int(h["count"].sum()) == n
    assert float(np.max(np.abs(h["Theta"]))) == pytest.approx(1.0)
    for s, branch, sub in zip(
        catalogue4.states, h["slope_branch"].values, h["sub_branch"].values, strict=True
    ):
        hel, circ = catalogue4.open_counts(s)
        assert (branch, sub) == (hel, circ)
    for b in h["branch"].values:
        sel = h["slope_branch"].values == b
        rms = np.sqrt(np.mean(h["u_z_rel"].values[sel] ** 2))
        assert float(h["rms_u_z_rel"].sel(branch=b)) == pytest.approx(rms)


def test_dataset_round_trip(catalogue4, tmp_path):
    import xarray as xr

    ds = catalogue4.to_dataset()
    assert ds.attrs["kind"] == "states" and ds.attrs["n_stable"] == len(catalogue4)
    ds.to_netcdf(tmp_path / "s.nc", engine="h5netcdf")
    back = xr.load_dataset(tmp_path / "s.nc", engine="h5netcdf")
    np.testing.assert_array_equal(back["q"].values, ds["q"].values)
    assert list(back["label"].values) == [s.label for s in catalogue4.states]
    assert list(back["fold"].values) == list(catalogue4.model.layout.fold_names)
    # the catalogue comes back from the file (what `biplan path --states` reads)
    again = StateCatalogue.from_dataset(back, catalogue4.model)
    assert again.names == catalogue4.names and again.folds == catalogue4.folds
    for a, b in zip(again.states, catalogue4.states, strict=True):
        assert a.bits == b.bits and a.seeds == b.seeds and a.energy == b.energy
        np.testing.assert_array_equal(a.z, b.z)
    assert again.rows() == catalogue4.rows()
    assert [(s.seed, s.state, s.reached_bits) for s in again.seeds] == [
        (s.seed, s.state, s.reached_bits) for s in catalogue4.seeds
    ]
    edges = sorted(transition_graph(again).edges(data="fold_name"))
    assert edges == sorted(transition_graph(catalogue4).edges(data="fold_name"))
    # the states alone (the endpoint figure's dataset): the same, without the seeds
    seed_vars = [v for v in ds.data_vars if str(v).startswith("seed_")]
    assert len(seed_vars) == 4
    xr.testing.assert_identical(
        catalogue4.to_dataset(seeds=False), ds.drop_vars([*seed_vars, "seed"])
    )


# --- R3 EDGE_FIT reading (the fully bistable design's default) ----------------------------
def _fit_rotation(ref: np.ndarray, cur: np.ndarray, weights: np.ndarray) -> float:
    """Angle [rad] of the weighted least-squares rigid motion (Procrustes) ref → cur, 2D."""
    pc = (weights[:, None] * ref).sum(0) / weights.sum()
    qc = (weights[:, None] * cur).sum(0) / weights.sum()
    h = ((ref - pc) * weights[:, None]).T @ (cur - qc)
    return float(np.arctan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1]))


def test_edge_fit_stacks_fitted_edges(catalogue4, model4):
    """Across every connector the least-squares rigid motion of the upper module's bottom edge
    has the rotation of the lower module's top edge, in global coordinates (edge-fit
    stacking: the fitted edges stay parallel)."""
    assert model4.tube.options.chain_attachment.value == "edge_fit"
    for s in catalogue4.states[:12]:
        nodes = model4.global_nodes(s.q)
        ref = model4.global_nodes(np.zeros_like(s.q))
        for spec in model4.layout.connectors:
            if spec.lower is None:
                continue
            angles = []
            for m, edge in ((spec.lower, spec.lower_edge), (spec.upper, spec.upper_edge)):
                idx = np.array([[a, b] for _, a, b in edge.segments]).reshape(-1)
                w = np.repeat(
                    [np.linalg.norm(ref[m, b] - ref[m, a]) for _, a, b in edge.segments], 2
                )
                angles.append(_fit_rotation(ref[m, idx], nodes[m, idx], w))
            assert angles[0] == pytest.approx(angles[1], abs=1e-9), s.name


def test_edge_fit_slope_branches_follow_open_helical_folds(catalogue4):
    """Under edge-fit stacking every open helical fold tilts the end: |Θ| grows with the
    number of open helical folds, so 66 and 1B (two each) share a slope branch."""
    by_count: dict[int, list[float]] = {}
    for s in catalogue4.states:
        by_count.setdefault(catalogue4.open_counts(s)[0], []).append(abs(catalogue4.slope(s)))
    counts = sorted(by_count)
    assert by_count[0] and max(by_count[0]) < 1e-6
    for a, b in itertools.pairwise(counts):
        assert max(by_count[a]) < min(by_count[b]), (a, b)
    assert catalogue4.open_counts(catalogue4.state("66"))[0] == 2
    assert catalogue4.open_counts(catalogue4.state("1B"))[0] == 2


def test_laws_inferred_from_fig4_meet_the_papers_elongation(model4):
    """designs.fully_bistable(laws=INFERRED_FIG4): 66 and 1B stable at the paper's
    u_z/l0 = 0.9 (one digit: ± 0.05), 1B deflecting more (main text, Fig. 4 B)."""
    laws = biplan.designs.FullyBistableLaws.INFERRED_FIG4
    model = biplan.Model(biplan.designs.fully_bistable(laws=laws))
    assert model.layout == model4.layout and "inferred" in model.tube.name
    l0 = model.tube.initial_length
    ends = {label: model.endpoint(relax_state(model, label).q) for label in ("66", "1B")}
    for e in ends.values():
        assert abs(e.u_z / l0 - 0.9) < 0.05
    assert abs(ends["1B"].u_r) > abs(ends["66"].u_r)
    assert biplan.designs.fully_bistable(laws="inferred-from-fig4") == model.tube
    with pytest.raises(biplan.ConfigError, match="laws"):
        biplan.designs.fully_bistable(laws="fitted")


def test_laws_inferred_from_fig4_under_the_printed_sign() -> None:
    """designs.fully_bistable(laws=INFERRED_FIG4_PRINTED): built under the printed TPC sign it
    was searched under; 00, 2A, 1B and 66 stable, 42 states, slope levels in thirds (no state
    with four open helical folds), 66 and 1B within 0.05 of u_z/l0 = 0.9 and 0.1 of Θ = 2/3,
    1B deflecting more (docs/fidelity.md, "Fig. 4 under the printed TPC sign")."""
    from biplan.analysis.states.search import enumerate_states
    from biplan.options import ChainAttachment, TpcSign

    laws = biplan.designs.FullyBistableLaws.INFERRED_FIG4_PRINTED
    tube = biplan.designs.fully_bistable(laws="inferred-from-fig4-printed")
    assert tube.options.tpc_sign is TpcSign.AS_PRINTED
    assert tube.options.chain_attachment is ChainAttachment.EDGE_FIT and "printed" in tube.name
    catalogue = enumerate_states(biplan.Model(tube))
    assert {"00", "2A", "1B", "66"} <= set(catalogue.names) and len(catalogue) == 42
    assert max(catalogue.open_counts(s)[0] for s in catalogue.states) == 3
    l0 = tube.initial_length
    pair = [catalogue.state(label) for label in ("66", "1B")]
    for s in pair:
        assert abs(s.u_z / l0 - 0.9) < 0.05 and abs(abs(catalogue.slope(s)) - 2 / 3) < 0.1
    assert abs(pair[1].u_r) > abs(pair[0].u_r)
    # under the geometric sign the same laws keep the four states but give 66 states
    geometric = biplan.ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT)
    assert (
        len(enumerate_states(biplan.Model(biplan.designs.fully_bistable(geometric, laws=laws))))
        == 66
    )


def test_single_fold_pairs_equal_the_pairwise_hamming_test() -> None:
    """The transition graph's edges come from a bit-flip lookup; the O(k²) pairwise Hamming
    distance (the reference) gives the same pairs, in the same order, also where two states
    share their bits."""
    from biplan.analysis.states.transitions import _single_fold_pairs

    rng = np.random.default_rng(7)
    bits = [tuple(int(b) for b in row) for row in rng.integers(0, 2, (300, 7))]
    bits += bits[:5]  # repeated bits (states `1B`, `1B.2`)
    reference = [
        (i, j, next(k for k in range(7) if bits[i][k] != bits[j][k]))
        for i in range(len(bits))
        for j in range(i + 1, len(bits))
        if hamming(bits[i], bits[j]) == 1
    ]
    assert len(reference) > 300
    assert _single_fold_pairs(bits) == reference


def test_labels_of_many_seeds_equal_their_one_by_one_labels() -> None:
    """The vectorised labels of a state search's seeds equal :func:`bits_to_label` row by
    row (every width, padded to whole hex digits); rows that are not 0/1 are refused."""
    from biplan.analysis.states.labels import bits_to_labels

    rng = np.random.default_rng(5)
    for n in (1, 4, 7, 19, 62, 63):
        rows = rng.integers(0, 2, (50, n))
        assert bits_to_labels(rows) == [bits_to_label(tuple(r)) for r in rows.tolist()]
    with pytest.raises(biplan.ConfigError, match="0/1"):
        bits_to_labels(np.array([[0, 2, 1]]))
