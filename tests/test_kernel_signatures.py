"""One compiled specialisation per kernel and argument types (biplan._compile.numba_cache).

Every specialisation re-optimises all the code below it, so a kernel compiled once for a
read-only array or once per constant value multiplies the one-time compile, and a user whose
arrays are read-only (a JAX array seen through NumPy) would wait minutes for a compile. A new
process runs the workloads of ``biplan compile`` (which call every compiled entry point) and,
through the public ``System``, a tube whose law rows and start are read-only arrays. Every
kernel of biplan that it loaded from the cache or compiled (the compiles of the functions below
an entry point, when the cache is cold) must be typed without read-only arrays and literal
values, and the entry points called from Python must have one specialisation each.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

_AUDIT = r"""
import json, sys
import numpy as np
from numba.core import event, types
from numba.core.registry import CPUDispatcher

compiled = []


class Compiles(event.Listener):
    def on_start(self, ev):
        f = ev.data["dispatcher"].py_func
        if f.__module__.startswith("biplan."):
            compiled.append((f"{f.__module__}.{f.__name__}", ev.data["args"]))

    def on_end(self, ev):
        pass


event.register("numba:compile", Compiles())

from biplan.cli.compile import WORKLOADS
from biplan import designs
from biplan.model.system import System
from biplan.solvers.iteration import newton_settings, solve_system

for name in sys.argv[1:]:
    WORKLOADS[name]()

tube = designs.semi_bistable()
dev = tube.development
helical = np.array([law.coefficients for law in tube.helical_laws], dtype=float)
circular = np.array([law.coefficients for law in tube.circular_laws], dtype=float)
for a in (helical, circular):
    a.flags.writeable = False
system = System.of_numbers(tube.layout, dev.radius, dev.pitch, dev.beta, helical, circular)
z0 = np.zeros(system.n_unknowns)
z0.flags.writeable = False
solve_system(system.at(force=0.5), z0, newton_settings(1e-9, 30, 20, 1e-4, 0))
system.residual(z0), system.jacobian(z0), system.endpoint(z0[: system.sizes[0]])


def flaws(t):
    if isinstance(t, types.Literal):
        yield f"literal {t}"
    elif isinstance(t, types.Array) and not t.mutable:
        yield f"read-only {t}"
    elif isinstance(t, types.BaseTuple):
        for inner in t.types:
            yield from flaws(inner)


out = {}
for module_name, module in list(sys.modules.items()):
    if not module_name.startswith("biplan."):
        continue
    for attr, obj in vars(module).items():
        if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == module_name:
            sigs = obj.signatures
            out[f"{module_name}.{attr}"] = {
                "count": len(sigs),
                "flaws": sorted({f for sig in sigs for t in sig for f in flaws(t)}),
            }
for name, args in compiled:
    out.setdefault(name, {"count": 0, "flaws": []})
    out[name]["flaws"] = sorted(set(out[name]["flaws"]) | {f for t in args for f in flaws(t)})
print(json.dumps(out))
"""

#: Entry points called from Python, each with the whole assembly below it: one each.
_ONCE = (
    "biplan.solvers.iteration.solve",
    "biplan.model.system.assemble.evaluate_into",
    "biplan.model.system.assemble.residual",
    "biplan.model.system.endpoint.endpoint",
    "biplan.model.system.chainterm.reference_height",
    "biplan.solvers.path_loop.path_loop",
    "biplan.solvers.step_loop.trajectory",
    # compiled beside the first workload from Python, called by the one Newton
    "biplan.model.system.inertia.add_inertia",
    # the kinematics of figures (biplan.model.system.kinematics), called from Python
    "biplan.model.system.elements.module_rows",
    "biplan.model.system.elements.connector_points",
    "biplan.model.system.inertia_chain.terms",
)


@pytest.fixture(scope="module")
def kernels() -> dict[str, dict]:  # type: ignore[type-arg]
    proc = subprocess.run(
        [sys.executable, "-c", _AUDIT, "inertia", "equilibrium", "path", "dynamics"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])  # type: ignore[no-any-return]


def test_the_workloads_reach_the_kernels(kernels: dict[str, dict]) -> None:  # type: ignore[type-arg]
    assert all(kernels[name]["count"] >= 1 for name in _ONCE)
    assert sum(k["count"] for k in kernels.values()) >= 10


def test_no_kernel_is_typed_by_a_read_only_array_or_a_literal(kernels: dict[str, dict]) -> None:  # type: ignore[type-arg]
    flawed = {name: k["flaws"] for name, k in kernels.items() if k["flaws"]}
    assert not flawed


def test_the_newton_and_the_assembly_compile_once(kernels: dict[str, dict]) -> None:  # type: ignore[type-arg]
    assert {name: kernels[name]["count"] for name in _ONCE} == dict.fromkeys(_ONCE, 1)
