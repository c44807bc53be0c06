"""Dense linear algebra for ``vmap``-ped kernels without batched LAPACK calls.

Why: on the CPU backend, jaxlib 0.10 runs a *batched* LAPACK custom call (LU, SVD, symmetric
eigenvalues, …) by splitting the batch into chunks on XLA's intra-op thread pool and blocking
the calling pool thread until they finish (``jax::ParallelBatchMap`` → ``BlockingCounter::
Wait``). When XLA's thunk executor runs as many independent batched LAPACK calls at once as
the pool has threads (two on a 2-core machine), every pool thread waits for chunks that no
thread is left to run: the process deadlocks, idle, in ``block_until_ready``. Observed in
biplan: the design-map kernel with a 16-point batch hung on every run (native stacks: two
pool threads in ``ParallelBatchMap``), the same kernel with 4 points did not; earlier hangs of
the states and stability kernels had the same signature. jaxlib 0.11 removes that parallel
path; 0.10.2 is the newest on the package index as of this writing.

The functions below are drop-in replacements whose ``vmap`` runs the batch as a sequential
``lax.map`` of unbatched calls (:func:`jax.custom_batching.custom_vmap`), so no LAPACK call
inside a biplan kernel is ever batched. They are for use inside jitted, vmapped solver
kernels (they are not differentiable: the solvers never differentiate through a linear solve).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

from biplan._compile.setup import jax, jnp

__all__ = [
    "cholesky",
    "eigvalsh",
    "lu_factor",
    "lu_solve",
    "pinv",
    "sequential_vmap",
    "solve",
    "svd",
]


def sequential_vmap(fn: Callable[..., Any]) -> Callable[..., Any]:
    """``fn`` whose batching rule maps the batch sequentially (``lax.map``).

    Parameters
    ----------
    fn : callable
        A function of arrays (positional only) returning an array or a tuple of arrays.
    """

    @functools.cache
    def build() -> Any:  # on first call: importing this module does not import JAX
        wrapped = jax.custom_batching.custom_vmap(fn)

        @wrapped.def_vmap
        def _rule(axis_size: int, in_batched: list[bool], *args: Any) -> tuple[Any, Any]:
            full = [
                a if b else jnp.broadcast_to(a, (axis_size, *jnp.shape(a)))
                for a, b in zip(args, in_batched, strict=True)
            ]
            out = jax.lax.map(lambda xs: wrapped(*xs), tuple(full))
            return out, jax.tree_util.tree_map(lambda _: True, out)

        return wrapped

    @functools.wraps(fn)
    def call(*args: Any) -> Any:
        return build()(*args)

    return call


@sequential_vmap
def solve(a: Any, b: Any) -> Any:
    """x with a x = b (LU with partial pivoting); a (n, n), b (n,)."""
    return jnp.linalg.solve(a, b)


@sequential_vmap
def lu_factor(a: Any) -> tuple[Any, Any]:
    """LU factors with partial pivoting (lu, pivots) of a (n, n), for :func:`lu_solve`."""
    lu, piv = jax.scipy.linalg.lu_factor(a)
    return lu, piv


@sequential_vmap
def lu_solve(lu: Any, piv: Any, b: Any) -> Any:
    """x with a x = b from the factors of :func:`lu_factor`; b (n,)."""
    return jax.scipy.linalg.lu_solve((lu, piv), b)


@sequential_vmap
def svd(a: Any) -> tuple[Any, Any, Any]:
    """Full SVD (u, s, vᵀ) of a (m, n)."""
    u, s, vt = jnp.linalg.svd(a, full_matrices=True)
    return u, s, vt


@sequential_vmap
def cholesky(a: Any) -> Any:
    """Lower Cholesky factor of the symmetric matrix a (n, n); NaN entries where a is not
    positive definite (LAPACK's failure, as :func:`jax.numpy.linalg.cholesky` reports it)."""
    return jnp.linalg.cholesky(a)


@sequential_vmap
def eigvalsh(a: Any) -> Any:
    """Eigenvalues (ascending) of the symmetric matrix a (n, n)."""
    return jnp.linalg.eigvalsh(a)


def pinv(a: Any, rtol: float = 1e-10) -> Any:
    """Moore–Penrose pseudo-inverse of a (m, n) (through :func:`svd`)."""
    u, s, vt = svd(a)
    k = min(a.shape[-2], a.shape[-1])
    s = s[..., :k]
    cutoff = rtol * jnp.max(s, axis=-1, keepdims=True)
    s_inv = jnp.where(s > cutoff, 1.0 / jnp.where(s > cutoff, s, 1.0), 0.0)
    return jnp.swapaxes(vt[..., :k, :], -1, -2) @ (
        s_inv[..., :, None] * jnp.swapaxes(u[..., :, :k], -1, -2)
    )
