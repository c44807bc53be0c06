"""Sequential-batching linear algebra of the JAX kernels and the Jacobian-block stability test
(``jax_oracle.observe.kkt_min_eigenvalue``)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from biplan._compile import linalg
from biplan._compile.setup import jax, jnp, xla_options
from biplan.model.lagrangian import kkt_jacobian
from biplan.model.params import Load
from biplan.model.potential import contact_gaps
from biplan.solvers.newton import Newton, Status
from jax_oracle.newton import settings_of, solve_loop
from jax_oracle.observe import kkt_min_eigenvalue, observe


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


def test_stability_from_the_kkt_jacobian_equals_the_fresh_hessian(model6) -> None:
    """kkt_min_eigenvalue (blocks of the KKT Jacobian) = observe (Hessian and constraint
    Jacobian evaluated afresh), at converged equilibria of both signs of λ_min: the stability
    map's pattern seeds at two displacements, solved under displacement control."""
    from biplan.analysis.maps.stability_seeds import Seeding, seeds

    m = model6
    u = np.r_[0.01, 0.1] * m.tube.initial_length
    z0 = np.concatenate([seeds(m, ui, Seeding.PATTERNS) for ui in u])
    uu = np.repeat(u, len(z0) // 2)
    settings = settings_of(Newton())
    loop = solve_loop.compiled(m.layout)

    @functools.partial(jax.jit, compiler_options=xla_options())
    def both(params, z, load):  # the two λ_min of one converged state, compiled once
        q = z[: m.n_coordinates]
        jac = kkt_jacobian(m.layout, params, z, load)
        lam = kkt_min_eigenvalue(m.layout, z, jac, contact_gaps(m.layout, params, q), load)
        return lam, observe(m.layout, params, z, load).min_eigenvalue

    lams = []
    for z, ui in zip(z0[::3], uu[::3], strict=True):
        load = Load(jnp.asarray(0.0), jnp.asarray(ui), jnp.asarray(1.0))
        sol = loop(m.params, jnp.asarray(z), load, settings)[0]
        if int(sol.status) != Status.CONVERGED.value:
            continue
        lam, ref = both(m.params, sol.z, load)
        assert float(lam) == pytest.approx(float(ref), rel=1e-8, abs=1e-10)
        lams.append(float(ref))
    assert len(lams) >= 3
    assert min(lams) < 0 < max(lams)  # both signs
