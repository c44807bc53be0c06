"""One-time compile of biplan's Numba kernels: wall time and where it goes, per function.

Run:  .venv/bin/python benchmarks/bench_compile.py [--baseline-src DIR] [--opt K]
      [--baseline-opt K] [--warm] [--workloads NAME … [--drop MODULE …]] [-- biplan args]

Runs a biplan command (default ``respond examples/semi_bistable.toml``) in a new process with
an empty kernel cache (``BIPLAN_NUMBA_CACHE`` in a temporary folder), so every kernel the
command needs compiles, and prints the wall time and the compile time of each compiled
function, exclusive of the functions it compiled on the way (Numba's ``numba:compile``
events). Numba links every callee's optimised code into its caller and optimises the whole
again, so a function's own time grows with everything below it (docs/performance.md,
"One-time compile").

``--baseline-src DIR`` runs the same command at the same time on another source tree (e.g. a
``git worktree`` of an older commit: ``DIR/src`` goes first on ``PYTHONPATH``), so both see
the same machine load, and prints the ratio of the wall times. ``--opt K`` sets ``NUMBA_OPT``
(the CLI compiles at -O1 unless it is set); ``--baseline-opt K`` runs the baseline on this tree
at another level (at the same time). ``--warm`` then runs the command again in a new process on
each warm cache (the wall time a user sees from the second run on).

``--workloads NAME … [--drop MODULE …]`` times workloads of ``biplan compile`` (e.g.
``states dynamics``) instead of a command, on a cache that holds every kernel but those of the
modules ``--drop`` names (e.g. ``solvers/relax_loop solvers/step_loop``; each tree's cache is
filled by ``biplan compile --jobs 2`` first): the compile of those modules alone
(docs/performance.md, "One-time compile").
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: The child: times every compile, runs the CLI, prints the table on stderr.
CHILD = r"""
import collections, sys, time
from numba.core import event
times = collections.Counter()
class Listener(event.Listener):
    def __init__(self):
        self.stack = []
    def on_start(self, ev):
        f = ev.data["dispatcher"].py_func
        self.stack.append((f.__module__ + "." + f.__qualname__, time.perf_counter()))
    def on_end(self, ev):
        name, t0 = self.stack.pop()
        dt = time.perf_counter() - t0
        times[name] += dt
        if self.stack:
            times[self.stack[-1][0]] -= dt
event.register("numba:compile", Listener())
t0 = time.perf_counter()
if sys.argv[1] == "--workloads":  # workloads of `biplan compile`, in this process
    from biplan._compile.numba_cache import use_own_opt_level
    use_own_opt_level()
    from biplan.cli.compile import WORKLOADS
    for name in sys.argv[2:]:
        WORKLOADS[name]()
else:
    from biplan.cli.main import app
    try:
        app(sys.argv[1:], standalone_mode=False)
    except SystemExit:
        pass
total = time.perf_counter() - t0
own = {k: v for k, v in times.items() if k.startswith("biplan.")}
print(f"WALL {total:.1f} s; compile {sum(times.values()):.1f} s "
      f"({sum(own.values()):.1f} s in {len(own)} biplan functions)", file=sys.stderr)
for name, dt in sorted(own.items(), key=lambda kv: -kv[1])[:15]:
    print(f"  {dt:7.2f} s  {name}", file=sys.stderr)
"""


def _start(
    src: Path | None, args: list[str], cache: Path, out: Path, opt: int | None
) -> subprocess.Popen[str]:
    env = dict(os.environ, BIPLAN_NUMBA_CACHE=str(cache))
    env.pop("NUMBA_OPT", None)
    if opt is not None:
        env["NUMBA_OPT"] = str(opt)
    if src is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(src / "src"), env.get("PYTHONPATH", "")])
    cwd = src if src is not None else Path.cwd()
    workloads = args[:1] == ["--workloads"]
    argv = [*args, "--out", str(out)] if not workloads and "--out" not in args else args
    return subprocess.Popen(
        [sys.executable, "-c", CHILD, *argv],
        env=env,
        cwd=cwd,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def _summary(proc: subprocess.Popen[str]) -> tuple[float, str]:
    _, err = proc.communicate()
    lines = [line for line in err.splitlines() if line.startswith(("WALL", "  "))]
    wall = float(lines[0].split()[1]) if lines else float("nan")
    return wall, "\n".join(lines) if lines else err[-2000:]


def _fill(src: Path | None, cache: Path, drop: list[str]) -> None:
    """Compile every kernel of a tree into ``cache`` (``biplan compile --jobs 2``), then delete
    the entries of the modules ``drop`` (``solvers/relax_loop``: paths in the cache folder)."""
    env = dict(os.environ, BIPLAN_NUMBA_CACHE=str(cache))
    env.pop("NUMBA_OPT", None)
    if src is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(src / "src"), env.get("PYTHONPATH", "")])
    subprocess.run(
        [sys.executable, "-m", "biplan", "compile", "--jobs", "2"],
        env=env,
        cwd=src if src is not None else Path.cwd(),
        check=True,
        capture_output=True,
    )
    for module in drop:
        for entry in cache.glob(f"*/{module}.*"):
            entry.unlink()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline-src", type=Path, default=None)
    parser.add_argument("--opt", type=int, choices=range(4), default=None)
    parser.add_argument("--baseline-opt", type=int, choices=range(4), default=None)
    parser.add_argument("--warm", action="store_true")
    parser.add_argument("--workloads", nargs="+", default=None)
    parser.add_argument("--drop", nargs="+", default=[])
    parser.add_argument("command", nargs="*", default=["respond", "examples/semi_bistable.toml"])
    args = parser.parse_args()
    if args.workloads:
        args.command = ["--workloads", *args.workloads]
    with tempfile.TemporaryDirectory(prefix="biplan-compile-") as tmp:
        root = Path(tmp)
        if args.workloads:  # every kernel cached but those of the dropped modules
            _fill(None, root / "cache", args.drop)
            if args.baseline_src is not None:
                _fill(args.baseline_src.resolve(), root / "base", args.drop)
        load = os.getloadavg()[0]
        start = time.perf_counter()
        this = _start(None, args.command, root / "cache", root / "out", args.opt)
        base = None
        if args.baseline_src is not None or args.baseline_opt is not None:
            src = None if args.baseline_src is None else args.baseline_src.resolve()
            opt = args.baseline_opt if args.baseline_opt is not None else args.opt
            base = _start(src, args.command, root / "base", root / "bout", opt)
        wall, table = _summary(this)
        print(f"this tree ({Path.cwd()}, NUMBA_OPT {args.opt}), load {load:.1f} at start:\n{table}")
        if base is not None:
            base_wall, base_table = _summary(base)
            print(f"baseline ({args.baseline_src or 'this tree'}, NUMBA_OPT {opt}):\n{base_table}")
            print(f"ratio this/baseline (wall): {wall / base_wall:.2f}")
        print(f"elapsed {time.perf_counter() - start:.1f} s")
        if args.warm:
            again = _summary(_start(None, args.command, root / "cache", root / "out", args.opt))
            print(f"warm, new process: this {again[0]:.1f} s", end="")
            if base is not None:
                src = None if args.baseline_src is None else args.baseline_src.resolve()
                bagain = _summary(_start(src, args.command, root / "base", root / "bout", opt))
                print(f", baseline {bagain[0]:.1f} s", end="")
            print()


if __name__ == "__main__":
    main()
