"""Wall time of a ``biplan`` command in a new process, kernels cached, against a baseline tree.

Run:  .venv/bin/python benchmarks/bench_command.py [--baseline-src DIR] [--runs N]
                                                   [-- COMMAND ...]

COMMAND defaults to ``respond examples/semi_bistable.toml`` (the default response of the
semi-bistable design: the target "≤ 3 s in a new process" of docs/performance.md). Each run
is a new ``python -m biplan COMMAND --out <temporary folder>`` process, timed from its start
to its exit. One unmeasured run per tree first writes the modules' bytecode and fills the
kernel cache if it is empty. With ``--baseline-src DIR`` (a ``git worktree`` of an older
commit) the runs alternate between this tree and ``DIR/src`` (put first on ``PYTHONPATH``),
so both see the same machine load; the script prints each run, the best and median of each
tree and their ratio (baseline / this tree), whether the two trees wrote the same CSV, and
which of the heavy packages (JAX, xarray, pandas, Dask, matplotlib) each tree imported.
"""

from __future__ import annotations

import argparse
import filecmp
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT = ["respond", "examples/semi_bistable.toml"]
HEAVY = ("jax", "xarray", "pandas", "dask", "matplotlib")
PROBE = (
    "import sys, runpy\n"
    "sys.argv = ['biplan', *sys.argv[1:]]\n"
    "try:\n"
    "    runpy.run_module('biplan', run_name='__main__')\n"
    "except SystemExit:\n"
    "    pass\n"
    "names = {m.split('.')[0] for m in sys.modules}\n"
    "print('imported:', ' '.join(p for p in HEAVY if p in names), file=sys.stderr)\n"
)


def _env(src: Path | None, bytecode: bool) -> dict[str, str]:
    env = dict(os.environ)
    if src is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(src), *filter(None, [env.get("PYTHONPATH")])])
    if bytecode:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def _run(command: list[str], src: Path | None, out: Path, bytecode: bool = False) -> float:
    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "biplan", *command, "--out", str(out)],
        cwd=ROOT,
        env=_env(src, bytecode),
        check=True,
        stdout=subprocess.DEVNULL,
    )
    return time.perf_counter() - t0


def _imports(command: list[str], src: Path | None, out: Path) -> str:
    code = PROBE.replace("HEAVY", repr(HEAVY))
    done = subprocess.run(
        [sys.executable, "-c", code, *command, "--out", str(out), "--quiet"],
        cwd=ROOT,
        env=_env(src, False),
        capture_output=True,
        text=True,
        check=True,
    )
    lines = [ln for ln in done.stderr.splitlines() if ln.startswith("imported:")]
    return lines[-1].removeprefix("imported:").strip() or "none of them"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline-src", type=Path, default=None)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("command", nargs="*", default=DEFAULT)
    args = parser.parse_args()
    if args.runs < 1:
        parser.error(f"--runs must be at least 1, got {args.runs}")
    base = None if args.baseline_src is None else args.baseline_src.resolve() / "src"
    if base is not None and not (base / "biplan").is_dir():
        parser.error(f"--baseline-src: no biplan package under {base}")
    trees = {"this tree": None} | ({} if base is None else {"baseline": base})
    with tempfile.TemporaryDirectory() as tmp:
        folder = {name: Path(tmp) / name.replace(" ", "_") for name in trees}
        for name, src in trees.items():  # bytecode and kernel cache
            _run(args.command, src, folder[name], bytecode=True)
        times: dict[str, list[float]] = {name: [] for name in trees}
        for k in range(args.runs):
            for name, src in trees.items():
                times[name].append(_run(args.command, src, folder[name]))
            print(f"run {k + 1}: " + ", ".join(f"{n} {t[-1]:.2f} s" for n, t in times.items()))
        print(f"biplan {' '.join(args.command)}, {args.runs} runs, load {os.getloadavg()[0]:.1f}")
        for name, t in times.items():
            print(f"  {name}: best {min(t):.2f} s, median {statistics.median(t):.2f} s")
        if base is not None:
            ratio = statistics.median(times["baseline"]) / statistics.median(times["this tree"])
            print(f"  baseline / this tree (medians): {ratio:.2f}")
            csvs = [sorted(folder[n].glob("*.csv")) for n in trees]
            same = len(csvs[0]) == len(csvs[1]) and all(
                filecmp.cmp(a, b, shallow=False) for a, b in zip(*csvs, strict=True)
            )
            print(f"  the same CSV files: {same}")
        for name, src in trees.items():
            print(f"  {name} imported: {_imports(args.command, src, folder[name])}")


if __name__ == "__main__":
    main()
