"""State searches: the relaxation pool, exhaustive vs neighbourhood, resume, size refusal."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import biplan
import biplan.analysis.scaleout
from biplan._compile.setup import jax, jnp
from biplan.analysis.states import seeding
from biplan.analysis.states.catalogue import Enumeration
from biplan.analysis.states.search import Search, enumerate_states
from biplan.io.sweepstore import ChunkStore
from biplan.model.assembly import autodiff_functions

#: Small chunks for the two-module tube (8 seeds → two chunks of four; one compilation).
SMALL = Enumeration(chunk=4)


@pytest.fixture(scope="module")
def model2fb() -> biplan.Model:
    return biplan.Model(biplan.designs.fully_bistable(n_modules=2))


def _catalogue_key(cat):  # type: ignore[no-untyped-def]
    return [(s.name, s.bits, s.seeds) for s in cat.states]


def test_fully_bistable_single_module_has_its_two_wells():
    """One module, one bistable helical fold (no circular fold): closed and open, by hand."""
    model = biplan.Model(biplan.designs.fully_bistable(n_modules=1))
    for search in Search:
        cat = enumerate_states(model, SMALL, search=search)
        assert [s.label for s in cat.states] == ["0", "1"]
        assert all(s.matches_seed for s in cat.seeds)
        assert cat.state("0").energy == pytest.approx(0.0, abs=1e-10)
        assert all(s.min_eigenvalue > 0.0 for s in cat.states)


def test_neighbourhood_search_finds_the_exhaustive_states(model2fb, model4):
    for model, settings in ((model2fb, SMALL), (model4, Enumeration())):
        full = enumerate_states(model, settings)
        near = enumerate_states(model, settings, search=Search.NEIGHBOURHOOD)
        assert [s.name for s in near.states] == [s.name for s in full.states]
        for a, b in zip(full.states, near.states, strict=True):
            assert np.max(np.abs(a.q - b.q)) < settings.duplicate_tolerance
        assert len(near.seeds) <= len(full.seeds)
    # two modules: three bistable folds, six of the eight fold states are stable
    assert [s.label for s in enumerate_states(model2fb, SMALL).states] == [
        "0",
        "1",
        "2",
        "3",
        "6",
        "7",
    ]
    assert len(full) == 66  # four modules


def test_every_state_is_a_stable_equilibrium_recomputed(model2fb):
    cat = enumerate_states(model2fb, SMALL, search=Search.NEIGHBOURHOOD)
    residual = autodiff_functions(model2fb.layout).residual
    for s in cat.states:
        r = np.asarray(residual(model2fb.params, s.z, biplan.Load.of_force(0.0)))
        assert np.max(np.abs(r)) < 1e-7, s.name
        sol = biplan.solve_equilibrium(model2fb, None, s.z)
        assert biplan.classify(model2fb, sol).verdict is biplan.Verdict.STABLE, s.name


class _Killed(Exception):
    pass


class _DiesAfter(ChunkStore):
    """A chunk store whose run is killed after ``left`` saved chunks."""

    left = 1

    def save(self, chunk, result):  # type: ignore[no-untyped-def]
        super().save(chunk, result)
        type(self).left -= 1
        if type(self).left == 0:
            raise _Killed


def test_resumed_enumeration_equals_an_uninterrupted_one(model2fb, tmp_path):
    whole = enumerate_states(model2fb, SMALL)
    description = {"design": "fully bistable, 2 modules", "chunk": SMALL.chunk}
    with pytest.raises(_Killed):
        enumerate_states(model2fb, SMALL, sink=_DiesAfter(tmp_path, description, 2, False))
    store = ChunkStore(tmp_path, description, 2, resume=True)
    assert store.reused == 1
    resumed = enumerate_states(model2fb, SMALL, sink=store)
    assert _catalogue_key(resumed) == _catalogue_key(whole)
    for a, b in zip(whole.states, resumed.states, strict=True):
        np.testing.assert_array_equal(a.z, b.z)
        assert a.energy == b.energy


def test_a_large_exhaustive_search_is_refused_with_its_cost_before_any_work(monkeypatch):
    model = biplan.Model(biplan.designs.fully_bistable(n_modules=9))  # 17 folds
    monkeypatch.setattr(seeding, "evaluate", _forbidden)
    monkeypatch.setattr(biplan.analysis.scaleout, "available_cores", lambda: 2)
    # 131,072 seeds × 4.0e-5 s × 9² on 2 threads = 212 s
    with pytest.raises(biplan.ConfigError, match=r"131,072 seeds.*confirm.*about 4 min .* 2 thre"):
        enumerate_states(model)
    with pytest.raises(biplan.ConfigError, match="search"):
        enumerate_states(model, search="exhaustive")  # type: ignore[arg-type]
    eleven = biplan.Model(biplan.designs.fully_bistable(n_modules=11))  # 21 folds
    with pytest.raises(biplan.ConfigError, match=r"21 bistable folds.*at most 20 for the exhaus"):
        enumerate_states(eleven, confirm=True)


def _forbidden(*args, **kwargs):  # type: ignore[no-untyped-def]
    raise AssertionError("work started before the request was checked")


def test_dask_workers_give_the_states_of_one_process_even_when_one_dies():
    """Five modules (512 seeds, 4 chunks) on a 2-worker LocalCluster; one worker process is
    killed after the first chunk arrives: Dask runs its chunks again, none is lost or counted
    twice, and the states equal the in-process search."""
    import os
    import signal

    from dask.distributed import Client, LocalCluster

    from biplan.analysis.scaleout import dask_runner

    model = biplan.Model(biplan.designs.fully_bistable(n_modules=5))
    alone = enumerate_states(model)
    cluster = LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    )
    try:
        with Client(cluster) as client:
            pids = list(client.run(os.getpid).values())
        killed: list[int] = []
        done: list[int] = []

        def progress(k: int, n: int) -> None:
            done.append(k)
            if k and not killed:  # after the first chunk came back
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])

        spread = enumerate_states(
            model, progress=progress, runner=dask_runner(cluster.scheduler_address)
        )
    finally:
        cluster.close()
    assert killed and done == [0, 128, 256, 384, 512]
    assert _catalogue_key(spread) == _catalogue_key(alone)
    for a, b in zip(alone.states, spread.states, strict=True):
        np.testing.assert_allclose(a.z, b.z, rtol=0, atol=1e-12)


def test_states_command_checks_the_search_request_first(tmp_path, monkeypatch, capsys):
    from biplan.cli.main import EXIT_BIPLAN_ERROR, main

    monkeypatch.setattr(seeding, "evaluate", _forbidden)
    config = "examples/fully_bistable_4.toml"
    big = tmp_path / "fb9.toml"
    text = Path(config).read_text(encoding="utf-8").replace("n_modules = 4", "n_modules = 9")
    big.write_text(text, encoding="utf-8")
    out = str(tmp_path / "out")
    cases = [
        ([config, "--search", "everything"], "invalid --search = 'everything'"),
        ([config, "--search", "neighbourhood", "--resume"], "invalid --resume"),
        ([config, "--search", "neighbourhood", "--workers", "2"], "invalid --workers"),
        ([config, "--workers", "0"], "invalid --workers = 0"),
        ([str(big)], "131,072 seeds"),
    ]
    for args, message in cases:
        with pytest.raises(SystemExit) as info:
            main(["states", *args, "--out", out])
        err = capsys.readouterr().err
        assert info.value.code == EXIT_BIPLAN_ERROR, (args, err)
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and message in lines[0], (args, err)


@pytest.mark.parametrize("which", ["fully_bistable_2", "base_fold_1"])
def test_at_rest_assembly_equals_the_general_one_at_zero_load(which, model2fb, model1):
    """The polish of the searches drops the load point's terms at rest: same r and KKT J."""
    from biplan.model import lagrangian
    from biplan.model.params import Load

    model = model2fb if which == "fully_bistable_2" else model1
    zero = Load.of_force(0.0).for_jax()
    layout, params = model.layout, model.params

    @jax.jit
    @jax.vmap
    def both(z):  # type: ignore[no-untyped-def]
        return (
            lagrangian.residual_at_rest(layout, params, z),
            lagrangian.residual(layout, params, z, zero),
            lagrangian.kkt_jacobian_at_rest(layout, params, z),
            lagrangian.kkt_jacobian(layout, params, z, zero),
        )

    z = np.random.default_rng(7).normal(scale=0.05, size=(3, model.n_unknowns))
    r_rest, r, j_rest, j = both(jnp.asarray(z))
    np.testing.assert_allclose(r_rest, r, rtol=0, atol=1e-12)
    np.testing.assert_allclose(j_rest, j, rtol=0, atol=1e-12)


def _pairwise_merge(
    q: np.ndarray, keep: np.ndarray, tolerance: float
) -> tuple[np.ndarray, list[int]]:
    """The merge rule written pairwise: each kept row joins the first earlier representative
    within the tolerance (max norm), or is one; (rep of each row, −1 if not kept; the reps)."""
    expected = np.full(len(q), -1)
    reps: list[int] = []
    for i in np.flatnonzero(keep):
        hits = [r for r in reps if np.max(np.abs(q[r] - q[i])) < tolerance]
        expected[i] = min(hits) if hits else i
        if not hits:
            reps.append(i)
    return expected, reps


def test_merging_equals_the_pairwise_rule() -> None:
    """merge_rows (candidates from a sorted projection) against the rule written pairwise:
    each kept row joins the first earlier representative within the tolerance (max norm)."""
    rng = np.random.default_rng(1)
    centres = rng.uniform(-1.0, 1.0, (60, 9))
    q = centres[rng.integers(0, 60, 600)] + rng.uniform(-1e-9, 1e-9, (600, 9))
    q[::7] += 6e-6  # within the tolerance of their centre's other rows
    q[::11, 3] += 2e-5  # beyond it in one coordinate only
    keep = rng.random(600) > 0.1
    tolerance = 1e-5
    expected, reps = _pairwise_merge(q, keep, tolerance)
    got = seeding.merge_rows(q, keep, tolerance)
    np.testing.assert_array_equal(got, expected)
    assert 60 < len(reps) < 600


def test_a_state_whose_active_rows_lapack_svd_spoils_is_observed():
    """Seed 396431 of the ten-module fully bistable tube converges to a state with 43 active
    constraint rows of rank 31, for which LAPACK's divide-and-conquer SVD (``gesdd``) returns
    NaN singular vectors (on the AMD EPYC development machine). Its stability comes from the
    SVD of R (rows = Q R) instead, and equals the one computed with the QR-iteration SVD
    (``gesvd``), an independent LAPACK routine; the numpy null space of the analysis layer
    agrees too."""
    import scipy.linalg

    from biplan.analysis.stability import null_space
    from biplan.analysis.states.labels import bistable_folds
    from biplan.solvers import observation

    model = biplan.Model(biplan.designs.fully_bistable(n_modules=10))
    folds = bistable_folds(model.tube)
    settings = Enumeration()
    res = seeding.evaluate(model, folds, np.array([396431, 0]), settings)
    converged, stable = seeding.outcome_masks(res, settings.stability_tolerance)
    assert converged.all() and stable[0]
    # the state's active rows and Hessian, as the observation builds them
    z = res["z"][0]
    system = model.system()
    jac = system.jacobian(z)
    n_q, n_g, n_c = system.sizes
    contacts = -jac[:n_q, n_q + n_g : n_q + n_g + n_c].T
    rows = np.concatenate(
        [jac[:n_q, n_q : n_q + n_g].T, contacts[z[n_q + n_g : -1] > observation.ACTIVE_MULTIPLIER]]
    )
    # on the AMD EPYC machine, numpy's and Numba's gesdd both return NaN vectors for these rows
    s, vt = observation.right_singular(np.ascontiguousarray(rows))
    _, s_ref, vt_ref = scipy.linalg.svd(rows, lapack_driver="gesvd")
    np.testing.assert_allclose(s, s_ref, rtol=0, atol=1e-12 * s_ref[0])
    rank = int((s_ref > observation.RANK_RTOL * s_ref[0]).sum())
    basis, basis_ref = vt[rank:].T, vt_ref[rank:].T
    np.testing.assert_allclose(basis @ basis.T, basis_ref @ basis_ref.T, atol=1e-12)  # one space
    np.testing.assert_allclose(
        null_space(rows) @ null_space(rows).T, basis_ref @ basis_ref.T, atol=1e-12
    )
    k = jac[:n_q, :n_q]
    reduced = basis_ref.T @ (0.5 * (k + k.T)) @ basis_ref
    lam_ref = np.linalg.eigvalsh(0.5 * (reduced + reduced.T))[0]
    assert lam_ref > settings.stability_tolerance
    np.testing.assert_allclose(res["min_eigenvalue"][0], lam_ref, rtol=1e-10)
    # a non-finite Hessian gives NaN, not an exception, and the seed counts as failed
    active = np.ones(len(rows), dtype=bool)
    lam, dof = observation.min_reduced_eigenvalue(np.full_like(k, np.nan), rows, active)
    assert np.isnan(lam) and dof == len(k) - rank
    lam, dof = observation.min_reduced_eigenvalue(k, np.full_like(rows, np.inf), active)
    assert np.isnan(lam) and dof == -1
    res = {**res, "min_eigenvalue": np.array([1.0, np.nan])}
    converged, _ = seeding.outcome_masks(res, settings.stability_tolerance)
    assert converged[0] and not converged[1]


def test_merging_a_state_most_seeds_reach_equals_the_pairwise_rule() -> None:
    """Most rows at one state (within 10⁻⁹), a few elsewhere, some between: the blocked
    merge gives the pairwise rule's representatives (each row is compared with the
    representatives near it, not with every row near it)."""
    rng = np.random.default_rng(4)
    n = 6000
    q = rng.uniform(-1e-9, 1e-9, (n, 5))
    others = rng.random(n) < 0.05
    q[others] += rng.uniform(-1.0, 1.0, (others.sum(), 5)).round(1)  # a few hundred states
    q[::97, 2] += 7e-6  # within the tolerance of the main state, beyond it of its neighbours
    keep = rng.random(n) > 0.02
    tolerance = 1e-5
    expected, reps = _pairwise_merge(q, keep, tolerance)
    np.testing.assert_array_equal(seeding.merge_rows(q, keep, tolerance), expected)
    assert 10 < len(reps) < 400
