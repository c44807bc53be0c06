"""Shared fixtures of the physics test-suite.

The compiled core takes every tube as data; the JAX oracles (``tests/jax_oracle``) and the
sensitivities compile per tube *layout* (number of modules, base fold, readings), so the suite
reuses four layouts through session-scoped fixtures:

* ``model1``: one standard module on a base circular fold (semi-bistable laws),
* ``model2``: two modules (S, M) on a base fold: TPC at the base, SPC between them,
* ``model6``: the 6-module semi-bistable design of the SI calibration table,
* ``model4``: the 4-module fully bistable design (no base fold).

Law coefficients are traced parameters, so tubes of the same layout with other laws (e.g. a
stiff linear helical fold) share the JAX kernels.
"""

from __future__ import annotations

import os
from pathlib import Path

# The suite shares one persistent JAX compilation cache between its processes (pytest-xdist
# workers, the CLI child processes of the reproduce test): a kernel compiled by one is loaded by
# the others. It lives in the checkout (git-ignored), and starts empty on a clean clone. Set
# before biplan is imported (biplan._compile.setup reads it); child processes inherit it.
os.environ.setdefault(
    "BIPLAN_JAX_CACHE", str(Path(__file__).resolve().parent.parent / ".jax-cache-tests")
)

# The suite checks numbers, not speed (timings live in benchmarks/): its kernels compile with
# LLVM's cheap pipeline (biplan._compile.setup; compilation dominates the suite,
# docs/performance.md,
# "Suite time"). Set before biplan is imported.
os.environ.setdefault("BIPLAN_FAST_COMPILE", "on")

# Without the trace store (biplan._compile.traced): exporting a JAX function to the store costs
# more than tracing it again in the one process that uses it (test_sensitivity.py and
# test_inverse_design.py on empty caches: 195 s with the store, 149 s without; AMD EPYC 2-core
# machine). tests/test_trace_store.py turns it on for its own tests.
os.environ.setdefault("BIPLAN_TRACE_STORE", "off")

import numpy as np
import pytest

import biplan  # enables JAX float64
from biplan._compile.numba_cache import use_own_opt_level
from biplan._compile.setup import limit_blas_threads, release_jax_executables

# Two test workers share the two cores: BLAS on one thread each (as the CLI runs it), else
# OpenBLAS's spinning threads slow every dense solve of the compiled core several times.
limit_blas_threads()
# and compile as the CLI does (LLVM -O1; NUMBA_OPT, inherited by the CLI child processes)
use_own_opt_level()

#: Geometry of the SI calibration table (MODEL.md §3, §14).
GEOMETRY = {"radius": 2.0, "pitch": 3.6, "helical_angle": 60.0}
#: Circular law of the calibration table (MODEL.md §1, CHOICE L1).
CIRCULAR = biplan.TrilinearLaw(stiffness=(0.9, -0.2, 0.6), transitions=(0.2, 1.3))
HELICAL = biplan.LinearLaw(stiffness=1.3)


def make_tube(n_modules: int, helical=HELICAL, circular=CIRCULAR, base_fold: bool = True):
    """A uniform tube of the calibration geometry (default options)."""
    return biplan.Tube.uniform(
        **GEOMETRY,
        n_modules=n_modules,
        helical=helical,
        circular=circular,
        base_fold=base_fold,
    )


@pytest.fixture(autouse=True)
def _bounded_compiled_kernels():
    """Keep the suite's process below Linux's memory-map cap (vm.max_map_count).

    Each XLA:CPU executable holds ~3 mappings; the whole suite compiles well over 20,000
    executables in one process (many layouts, eager finite-difference checks), which crashed
    XLA's compiler with a segmentation fault once the cap was reached. Caches are cleared
    between tests once half the cap is used (kernels then recompile on demand).
    """
    yield
    release_jax_executables(0.5)


@pytest.fixture(scope="module")
def browser():
    """A headless Chromium driven by Playwright (tests/_browser.py), or a loud skip."""
    from _browser import launch

    yield from launch()


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator (the suite must be deterministic)."""
    return np.random.default_rng(20240611)


@pytest.fixture(scope="session")
def model1() -> biplan.Model:
    return biplan.Model(make_tube(1))


@pytest.fixture(scope="session")
def model2() -> biplan.Model:
    return biplan.Model(make_tube(2))


@pytest.fixture(scope="session")
def model6() -> biplan.Model:
    return biplan.Model(biplan.designs.semi_bistable())


@pytest.fixture(scope="session")
def model4() -> biplan.Model:
    return biplan.Model(biplan.designs.fully_bistable())


@pytest.fixture(scope="session")
def model4_element() -> biplan.Model:
    """The fully bistable design under the paper's chain (R3 ``element``, H^TPC = I)."""
    return biplan.Model(biplan.designs.fully_bistable(biplan.ModelOptions()))


@pytest.fixture(scope="session")
def reference6(model6) -> biplan.Solution:
    return biplan.relaxed_reference(model6)


def breakpoints_of(model: biplan.Model) -> tuple[np.ndarray, np.ndarray]:
    """Breakpoints (w1, w2) of every helical law (N, 2) and circular law (Nc, 2)."""
    h = np.asarray([law.coefficients[3:] for law in model.tube.helical_laws], dtype=float)
    c = np.asarray([law.coefficients[3:] for law in model.tube.circular_laws], dtype=float)
    return h.reshape(-1, 2), c.reshape(-1, 2)


def min_breakpoint_distance(model: biplan.Model, q: np.ndarray) -> float:
    """Smallest distance [mm] of any fold-field boundary elongation from its law's breakpoints."""
    hb, cb = breakpoints_of(model)
    kin = model.kinematics(q)
    d = [np.abs(kin.helical[:, :, None] - hb[:, None, :]).min(initial=np.inf)]
    for c, (w0, w1, _) in enumerate(model.circular_fields(q)):
        ends = np.concatenate([w0, w1])
        d.append(np.abs(ends[:, None] - cb[c][None, :]).min(initial=np.inf))
    return float(min(d))


def random_configuration(
    model: biplan.Model,
    rng: np.random.Generator,
    amplitude: float = 0.03,
    gamma: tuple[float, float] = (0.1, 0.8),
    clearance: float = 1e-3,
) -> np.ndarray:
    """Random q (module coordinates ~ N(0, amplitude), γ uniform in ``gamma``) whose field
    boundary elongations all stay ``clearance`` away from the law breakpoints (the Hessian is
    discontinuous there)."""
    n = model.layout.n_modules
    for _ in range(200):
        q = np.concatenate(
            [
                rng.normal(0.0, amplitude, 3 * n),
                rng.uniform(*gamma, model.n_coordinates - 3 * n),
            ]
        )
        if min_breakpoint_distance(model, q) > clearance:
            return q
    raise RuntimeError("could not draw a configuration away from the breakpoints")
