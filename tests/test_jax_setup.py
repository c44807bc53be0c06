"""JAX set-up: float64, XLA flags, and release of compiled executables (memory-map cap)."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from biplan._compile.setup import (
    CHEAP_PIPELINE,
    LIGHT_PIPELINE,
    jax,
    jnp,
    memory_map_count,
    release_jax_executables,
    xla_options,
)


def test_float64_is_on():
    assert jnp.ones(2).dtype == jnp.float64


def test_xla_flags_disable_the_ynn_fusion():
    assert "--xla_cpu_experimental_ynn_fusion_type=" in os.environ["XLA_FLAGS"]


def test_fast_compile_gives_the_cheap_pipeline_per_kernel(monkeypatch):
    """The suite runs with BIPLAN_FAST_COMPILE=on (conftest): the large kernels get the cheap
    LLVM pipeline as per-kernel compiler options (XLA accepts them), nothing global; off gives
    XLA's default, and a pipeline flag the user set in XLA_FLAGS wins."""
    assert os.environ["BIPLAN_FAST_COMPILE"] == "on"
    assert "xla_backend_optimization_level" not in os.environ["XLA_FLAGS"]
    assert xla_options() == CHEAP_PIPELINE
    assert xla_options(runs_often=True) == LIGHT_PIPELINE
    for options in (xla_options(), xla_options(runs_often=True)):
        f = jax.jit(lambda x: jnp.sin(x) ** 2, compiler_options=options)
        y = f.lower(jnp.ones(3)).compile()(jnp.ones(3))
        assert float(y[0]) == pytest.approx(np.sin(1) ** 2)
    monkeypatch.setenv("XLA_FLAGS", "--xla_backend_optimization_level=2")
    assert xla_options() == {
        "xla_llvm_disable_expensive_passes": True,
        "xla_cpu_use_fusion_emitters": False,
    }
    monkeypatch.setenv("BIPLAN_FAST_COMPILE", "off")
    assert xla_options() is None
    assert xla_options(runs_often=True) is None


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc/self/maps is Linux")
def test_release_jax_executables_frees_memory_maps():
    functions = [jax.jit(lambda x, k=k: jnp.sin(x) * k + x**2) for k in range(100)]
    for f in functions:
        f(jnp.ones(3)).block_until_ready()
    before = memory_map_count()
    assert release_jax_executables(fraction=1.0) is False  # far below the cap: nothing done
    assert release_jax_executables(fraction=0.0) is True
    after = memory_map_count()
    assert after < before - 200  # ~3 mappings per executable released
    assert float(functions[0](jnp.ones(3))[0]) == pytest.approx(1.0)  # recompiles on demand


def test_cache_entries_without_access_time_are_stamped(tmp_path):
    from biplan._compile.setup import _stamp_unlocked_entries

    (tmp_path / "jit_f-abc-cache").write_bytes(b"executable")
    (tmp_path / "jit_g-def-cache").write_bytes(b"executable")
    (tmp_path / "jit_g-def-atime").write_bytes((7).to_bytes(8, "little"))
    _stamp_unlocked_entries(tmp_path)
    assert len((tmp_path / "jit_f-abc-atime").read_bytes()) == 8  # JAX's LRU reads 8 bytes
    assert (tmp_path / "jit_g-def-atime").read_bytes() == (7).to_bytes(8, "little")  # kept


def test_release_fraction_is_validated():
    from biplan import ConfigError

    with pytest.raises(ConfigError, match=r"fraction.*\[0, 1\]"):
        release_jax_executables(fraction=1.5)


def test_a_load_reaches_a_kernel_with_one_input_type(model1):
    """Python and NumPy scalars give the same kernel input type (the residual kernel is
    traced once for both), and arrays pass through."""
    import numpy as np

    from biplan.model.assembly import Load

    py, npy = Load.of_force(0.3).for_jax(), Load.of_force(np.float64(0.3)).for_jax()
    assert [jax.typeof(v) for v in py] == [jax.typeof(v) for v in npy]
    z = np.asarray(model1.pack(model1.zeros()))
    model1.autodiff.residual.clear_cache()
    model1.residual(z, Load.of_force(0.3))
    model1.residual(z, Load(np.float64(0.3), np.float64(0.0), np.float64(0.0)))
    assert model1.autodiff.residual._cache_size() == 1
    batch = Load(np.zeros(3), np.zeros(3), np.zeros(3)).for_jax()
    assert all(v.shape == (3,) for v in batch)


def test_import_help_and_version_load_no_jax():
    """``import biplan``, ``biplan --help``, ``biplan --version``, a Model, its compiled
    system and the figures of a tube set no JAX state (JAX is not even imported); the set-up
    runs on first use of the JAX kernels and extends XLA_FLAGS."""
    code = (
        "import sys, biplan, biplan.cli.main\n"
        "assert 'jax' not in sys.modules, 'jax imported'\n"
        "from biplan.cli.main import main\n"
        "for argv in (['--help'], ['--version']):\n"
        "    try:\n"
        "        main(argv)\n"
        "    except SystemExit as e:\n"
        "        assert e.code in (0, None), e.code\n"
        "assert 'jax' not in sys.modules, 'jax imported by the CLI'\n"
        "import os\n"
        "model = biplan.Model(biplan.designs.semi_bistable())\n"
        "model.system()\n"
        "assert 'jax' not in sys.modules, 'jax imported by the model or its system'\n"
        "import matplotlib\n"
        "matplotlib.use('agg')\n"
        "from biplan.plot.cylinder import cylinder\n"
        "from biplan.plot.tube import development\n"
        "development(model, model.zeros() + 0.01)\n"
        "cylinder(model, model.zeros() + 0.01)\n"
        "assert 'jax' not in sys.modules, 'jax imported by the figures of a tube'\n"
        "from biplan._compile.setup import jnp\n"
        "assert jnp.ones(1).dtype == jnp.float64\n"
        "flags = os.environ['XLA_FLAGS']\n"
        "assert flags.startswith('--xla_cpu_multi_thread_eigen=true '), flags\n"
        "assert 'multi_thread_eigen=false' not in flags, flags\n"
        "assert '--xla_cpu_experimental_ynn_fusion_type=' in flags, flags\n"
    )
    env = dict(os.environ, XLA_FLAGS="--xla_cpu_multi_thread_eigen=true")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]


_BLAS_PROBE = (
    "import os, sys, numpy, scipy.linalg\n"
    "import biplan.model.assembly\n"
    "from threadpoolctl import threadpool_info\n"
    "def threads():\n"
    "    blas = [i for i in threadpool_info() if i['user_api'] == 'blas']\n"
    "    assert blas, threadpool_info()\n"
    "    return sorted({i['num_threads'] for i in blas})\n"
    "before = threads()\n"
    "assert 'jax' not in sys.modules\n"
    "from biplan._compile.setup import limit_blas_threads\n"
    "limit_blas_threads()\n"
    "print(before, threads(), os.environ.get('OPENBLAS_NUM_THREADS'))\n"
)


def _probe_env(**variables: str) -> dict[str, str]:
    from biplan._compile.setup import BLAS_THREAD_VARIABLES

    env = {k: v for k, v in os.environ.items() if k not in BLAS_THREAD_VARIABLES}
    env.pop("BIPLAN_BLAS_THREADS", None)
    env.update(variables)
    return env


def _probe(**variables: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", _BLAS_PROBE], env=_probe_env(**variables), capture_output=True,
        text=True,
    )  # fmt: skip


def test_blas_threads_are_the_users_until_biplan_runs_its_own_process():
    """Importing the model changes no BLAS setting of the user's process (nor imports JAX);
    the limit the CLI and the JAX set-up apply (limit_blas_threads) runs every loaded BLAS
    (NumPy's and SciPy's OpenBLAS) on one thread, or on BIPLAN_BLAS_THREADS; a user's
    OPENBLAS_NUM_THREADS is kept; a bad value is refused."""
    default = _probe()
    assert default.returncode == 0, default.stderr[-2000:]
    before, after, variable = default.stdout.split()
    assert (after, variable) == ("[1]", "1")
    plain = subprocess.run(  # the same process without biplan: the library's own count
        [sys.executable, "-c", _BLAS_PROBE.replace("import biplan.model.assembly\n", "")],
        env=_probe_env(),
        capture_output=True,
        text=True,
    )
    assert plain.stdout.split()[0] == before, plain.stderr[-2000:]
    two = _probe(BIPLAN_BLAS_THREADS="2")
    assert two.stdout.split()[-2:] == ["[2]", "2"], two.stderr[-2000:]
    user = _probe(OPENBLAS_NUM_THREADS="2", BIPLAN_BLAS_THREADS="1")
    assert user.stdout.split() == ["[2]", "[2]", "2"], user.stderr[-2000:]
    bad = _probe(BIPLAN_BLAS_THREADS="zero")
    assert bad.returncode != 0
    assert "invalid BIPLAN_BLAS_THREADS = 'zero'" in bad.stderr


_OPT_PROBE = (
    "import os, biplan.model.assembly\n"
    "from numba.core import config\n"
    "before = int(config.OPT)\n"
    "from biplan._compile.numba_cache import use_own_opt_level\n"
    "use_own_opt_level()\n"
    "print(before, int(config.OPT), os.environ.get('NUMBA_OPT'))\n"
)


def test_numba_opt_level_is_the_users_until_biplan_runs_its_own_process():
    """Importing the model leaves Numba's optimisation level alone (-O3, Numba's default); the
    CLI's use_own_opt_level compiles at -O1 and says so to child processes (NUMBA_OPT); a
    NUMBA_OPT the user set is kept."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_OPT"}
    out = subprocess.run(
        [sys.executable, "-c", _OPT_PROBE], env=env, capture_output=True, text=True
    )
    assert out.stdout.split() == ["3", "1", "1"], out.stderr[-2000:]
    user = subprocess.run(
        [sys.executable, "-c", _OPT_PROBE], env=dict(env, NUMBA_OPT="2"), capture_output=True,
        text=True,
    )  # fmt: skip
    assert user.stdout.split() == ["2", "2", "2"], user.stderr[-2000:]


def test_jax_cache_follows_xdg_cache_home(tmp_path) -> None:
    """Without BIPLAN_JAX_CACHE the JAX compilation cache lives in $XDG_CACHE_HOME/biplan/jax
    (as the compiled kernels' cache does); BIPLAN_JAX_CACHE overrides it."""
    code = "from biplan._compile import setup\nsetup.jnp.ones(1)\nprint(setup.CACHE_DIR)\n"
    env = {k: v for k, v in os.environ.items() if k != "BIPLAN_JAX_CACHE"}
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.strip() == str(tmp_path / "xdg" / "biplan" / "jax"), out.stderr[-2000:]
    env["BIPLAN_JAX_CACHE"] = str(tmp_path / "own")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.strip() == str(tmp_path / "own"), out.stderr[-2000:]
