"""Lane-refilling Newton pool, sequential-batching linear algebra and the Jacobian-block
stability test (the pieces behind the fast map kernels)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from biplan._compile import linalg
from biplan._compile.setup import jax, jnp, kernel_options
from biplan.model.lagrangian import kkt_jacobian
from biplan.model.params import Load
from biplan.model.potential import contact_gaps
from biplan.solvers.newton import Newton, Status, newton_loop, solve_loop
from biplan.solvers.observe import kkt_min_eigenvalue, observe
from biplan.solvers.pool import newton_pool


def test_sequential_vmap_matches_batched_linear_algebra() -> None:
    rng = np.random.default_rng(0)
    a = rng.normal(size=(3, 4, 6, 6))
    b = rng.normal(size=(3, 4, 6))
    x = jax.jit(jax.vmap(jax.vmap(linalg.solve)))(a, b)
    assert np.allclose(np.einsum("...ij,...j->...i", a, x), b, atol=1e-12)
    # one side batched, the other broadcast
    x1 = jax.vmap(linalg.solve, in_axes=(0, None))(a[:, 0], b[0, 0])
    assert np.allclose(x1, np.linalg.solve(a[:, 0], b[0, 0]), atol=1e-12)
    s = a + np.swapaxes(a, -1, -2)
    assert np.allclose(jax.vmap(jax.vmap(linalg.eigvalsh))(s), np.linalg.eigvalsh(s), atol=1e-12)
    m = rng.normal(size=(4, 3, 5))
    _, sv, _ = jax.vmap(linalg.svd)(m)
    assert np.allclose(sv, np.linalg.svd(m)[1], atol=1e-12)
    assert np.allclose(jax.vmap(linalg.pinv)(m), np.linalg.pinv(m), atol=1e-12)
    lu, piv = jax.vmap(jax.vmap(linalg.lu_factor))(a)
    x2 = jax.jit(jax.vmap(jax.vmap(linalg.lu_solve)))(lu, piv, b)
    assert np.allclose(x2, x, atol=1e-12)
    # no batched LAPACK call is left in the compiled kernel: the batch is a loop
    hlo = jax.jit(jax.vmap(linalg.solve)).lower(a[0], b[0]).as_text()
    assert "while" in hlo


@pytest.fixture(scope="module")
def tasks(model6):
    """Seeds of the displacement-controlled search at two displacements: fast and slow ones."""
    from biplan.analysis.maps.stability_seeds import seeds

    m = model6
    u = np.r_[0.01, 0.1] * m.tube.initial_length
    z0 = np.concatenate([seeds(m, ui, "patterns") for ui in u])
    uu = np.repeat(u, len(z0) // 2)
    return m, z0, uu


def test_pool_equals_one_newton_loop_per_task(tasks) -> None:
    m, z0, uu = tasks
    settings = Newton(max_steps=15, max_backtracks=4).settings()
    params = jax.tree_util.tree_map(lambda a: jnp.asarray(a)[None], m.params)
    n = len(z0)
    pad = 5  # padding tasks are never solved
    zz = np.concatenate([z0, np.zeros((pad, z0.shape[1]))])
    loads = Load(jnp.zeros(n + pad), jnp.asarray(np.r_[uu, np.zeros(pad)]), jnp.ones(n + pad))
    cheap = kernel_options()  # the suite's pipeline (BIPLAN_FAST_COMPILE): same arithmetic
    out = jax.jit(newton_pool.fun, static_argnums=(0, 1), compiler_options=cheap)(
        m.layout, 4, params, jnp.zeros(n + pad, dtype=jnp.int32), jnp.asarray(zz), loads,
        jnp.asarray(n), settings,
    )  # fmt: skip
    assert (np.asarray(out.status)[n:] == -1).all()
    one = jax.jit(jax.vmap(lambda z, u: newton_loop(
        m.layout, m.params, z, Load(jnp.asarray(0.0), u, jnp.asarray(1.0)), settings,
        line_search_loop=True)), compiler_options=cheap)  # fmt: skip
    ref = one(jnp.asarray(z0), jnp.asarray(uu))
    assert np.array_equal(np.asarray(out.status)[:n], np.asarray(ref.status))
    assert np.array_equal(np.asarray(out.evals)[:n], np.asarray(ref.evals))
    conv = np.asarray(ref.status) == Status.CONVERGED.value
    assert conv.sum() >= n // 2
    assert np.allclose(np.asarray(out.z)[:n][conv], np.asarray(ref.z)[conv], rtol=0, atol=1e-12)
    # the default one-pass driver visits the same trial points: same solutions
    loop = solve_loop.compiled(m.layout)
    for i in np.flatnonzero(conv)[::4]:
        load = Load(jnp.asarray(0.0), jnp.asarray(uu[i]), jnp.asarray(1.0))
        sol = loop(m.params, jnp.asarray(z0[i]), load, settings)[0]
        assert int(sol.status) == Status.CONVERGED.value
        assert np.allclose(np.asarray(sol.z), np.asarray(ref.z)[i], rtol=0, atol=1e-9)


def test_stability_from_the_kkt_jacobian_equals_the_fresh_hessian(tasks) -> None:
    """kkt_min_eigenvalue (blocks of the KKT Jacobian) = observe (Hessian and constraint
    Jacobian evaluated afresh), at converged equilibria of both signs of λ_min."""
    m, z0, uu = tasks
    settings = Newton().settings()
    loop = solve_loop.compiled(m.layout)

    @functools.partial(jax.jit, compiler_options=kernel_options())
    def both(params, z, load):  # the two λ_min of one converged state, compiled once
        q = z[: m.n_coordinates]
        jac = kkt_jacobian(m.layout, params, z, load)
        lam = kkt_min_eigenvalue(m.layout, z, jac, contact_gaps(m.layout, params, q), load)
        return lam, observe(m.layout, params, z, load).min_eigenvalue

    lams = []
    for z, u in zip(z0[::3], uu[::3], strict=True):
        load = Load(jnp.asarray(0.0), jnp.asarray(u), jnp.asarray(1.0))
        sol = loop(m.params, jnp.asarray(z), load, settings)[0]
        if int(sol.status) != Status.CONVERGED.value:
            continue
        lam, ref = both(m.params, sol.z, load)
        assert float(lam) == pytest.approx(float(ref), rel=1e-8, abs=1e-10)
        lams.append(float(ref))
    assert len(lams) >= 3


def test_pin_process_restricts_every_thread_and_can_be_undone() -> None:
    import contextlib
    import os

    from biplan.analysis.scaleout import _available_cores, _pin_process

    if not hasattr(os, "sched_setaffinity"):
        pytest.skip("no CPU affinity on this platform")
    before = os.sched_getaffinity(0)
    core = _available_cores()[-1]
    try:
        assert _pin_process(core) == core
        for tid in os.listdir("/proc/self/task"):
            assert os.sched_getaffinity(int(tid)) == {core}
    finally:
        for tid in os.listdir("/proc/self/task"):
            with contextlib.suppress(OSError):
                os.sched_setaffinity(int(tid), before)
    assert os.sched_getaffinity(0) == before
