"""Fully bistable laws for Fig. 4 by search, under one TPC-sign reading (issue 48).

Run:  .venv/bin/python benchmarks/fig4_law_search.py [--tpc-sign as_printed]
      [--out out/fig4_law_search] [--resume] [--workers N]
      [--samples 4096] [--rounds 4] [--parents 8] [--per-parent 32] [--slice-points 24]
      [--spread 0.6] [--circular-w2-max 6.93] [--claims 12] [--confirm]

1. :func:`biplan.calibration.fig4_search.search_laws` over the helical and circular trilinear
   laws of ``designs.fully_bistable`` (SI Table geometry, R3 ``EDGE_FIT``, the given TPC
   sign): a scrambled Sobol design over the box, then rounds of local refinement around the
   Pareto front (``biplan.analysis.states.law_front``), then a count slice through the best set
   over the two most influential coefficients. Every chunk of law sets is streamed to
   ``OUT/stage-*/`` (``--resume`` continues a killed run); a Rich progress bar per stage;
   failed law sets are counted.
2. Box: every coefficient of the provisional laws ± ``--spread`` (60 %), except the circular
   spinodal end w2, sampled log-uniformly from 0.4 × the provisional 1.3 mm to
   ``--circular-w2-max`` (default 1.6 × the 4.331 mm that the geometric-sign fit needed for
   u_z/l0 = 0.9; docs/fidelity.md): the paper's elongation of 66 and 1B needs that wide a
   circular well, and no other coefficient moves it as much.
3. Prints the evidence (how many sets make 66 stable, what the seed of 66 reaches where it is
   not, the counts with 00, 2A, 1B, 66 all stable), the Pareto front, and the reproduction's
   Fig. 4 / SI claims (the states claims of :data:`biplan.reproduction.claims.CLAIMS`) of the
   first ``--claims`` sets of the front: each enumerated again and written as ``biplan
   states`` writes it (``OUT/claims/<row>/``), then assessed. ``--confirm`` runs the best of
   them through a ``biplan states`` child process as well (as
   ``benchmarks/fidelity_fully_bistable.py`` does).
4. Writes ``OUT/records.csv``, ``OUT/front.csv``, ``OUT/slice.csv``, ``OUT/claims.csv`` and the figure
   ``OUT/fig4_law_count.png``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

import biplan
from biplan.analysis.states.law_front import OBJECTIVES
from biplan.analysis.states.law_records import PAIR, PAPER_STATES, LawStatus
from biplan.analysis.states.law_search import PARAMETERS, LawBox, with_laws
from biplan.calibration.fig4_search import SearchPlan, SearchResult, search_laws

#: The spinodal end of the circular law that the geometric-sign fit needed (INFERRED_FIG4).
INFERRED_CIRCULAR_W2 = 4.33087


def _box(spread: float, w2_max: float) -> LawBox:
    base = biplan.designs.fully_bistable()
    box = LawBox.around(base.helical_laws[0], base.circular_laws[0], spread)
    lo = (1 - spread) * base.circular_laws[0].transitions[1]
    if not w2_max > lo:
        raise biplan.ConfigError("--circular-w2-max", w2_max, f"> {lo:.3g} mm (the box's low end)")
    return box.with_bounds("circular.w2", lo, w2_max, log=True)


def claims_of(tube: biplan.Tube, folder: Path) -> dict[str, tuple[str, str]]:
    """claim id → (verdict, finding) of the states claims: the tube's states enumerated and
    written as ``biplan states`` writes them (figures aside), then assessed."""
    from biplan.analysis.states.search import enumerate_states
    from biplan.analysis.states.transitions import transition_graph
    from biplan.io.states import write_state_files
    from biplan.reproduction.claims import CLAIMS
    from biplan.reproduction.facts import Results, state_facts
    from biplan.reproduction.report import assess

    catalogue = enumerate_states(biplan.Model(tube))
    write_state_files(catalogue, transition_graph(catalogue), folder)
    found = assess(Results(states=state_facts(folder)), [c for c in CLAIMS if "states" in c.needs])
    return {a.claim.id: (a.finding.verdict.value, a.finding.value) for a in found}


def _fmt(values: np.ndarray) -> str:
    return ", ".join(f"{x:.4g}" for x in values)


def evidence(result: SearchResult) -> None:
    """What the search says about 66 and the count (printed)."""
    r = result.records
    ok = r.ok
    print(f"\n{len(r)} law sets: {int(ok.sum())} searched, "
          f"{int((r.status == LawStatus.INVALID.value).sum())} not a bistable pair, "
          f"{int((r.status == LawStatus.FAILED.value).sum())} failed")  # fmt: skip
    for s, label in enumerate(PAPER_STATES):
        print(f"  {label} stable in {int(r.named[ok, s].sum())} of {int(ok.sum())}")
    all4 = ok & (r.named.sum(axis=1) == 4)
    lost = ok & (r.named[:, PAPER_STATES.index("66")] == 0)
    reached, n = np.unique(r.seed_66_reached[lost], return_counts=True)
    top = sorted(zip(n, reached, strict=True), reverse=True)[:5]
    print("  seed of 66 where 66 is not stable reaches: "
          + ", ".join(f"{f'{b:02X}' if b >= 0 else 'failed'} ({c})" for c, b in top))  # fmt: skip
    for name, mask in (("all four stable", all4), ("66 not stable", lost)):
        counts, k = np.unique(r.n_states[mask], return_counts=True)
        print(
            f"  counts, {name}: " + ", ".join(f"{c} ({m})" for c, m in zip(counts, k, strict=True))
        )
    if result.slice is not None:
        s = result.slice
        (xn, _), (yn, _) = result.slice_axes
        for name, mask in (
            ("66 stable", s.ok & (s.named[:, 3] == 1)),
            ("66 not", s.ok & (s.named[:, 3] == 0)),
        ):
            counts, k = np.unique(s.n_states[mask], return_counts=True)
            print(
                f"  slice over {xn}, {yn}, {name}: "
                + ", ".join(f"{c} ({m})" for c, m in zip(counts, k, strict=True))
            )
    print("  most influential on the count (η², global stage): "
          + ", ".join(f"{PARAMETERS[i]} {result.influence[i]:.2f}"
                      for i in np.argsort(-result.influence)[:4]))  # fmt: skip


def front_table(result: SearchResult, rows: np.ndarray) -> None:
    """The Pareto front (printed, markdown)."""
    r = result.records
    print("\n| row | helical k1, k2, k3, w1, w2 | circular k1, k2, k3, w1, w2 | 00 2A 1B 66 | count "
          "| levels (max open helical, thirds error) | slope peak | u_z/l0, Θ of 66 | of 1B "
          "| u_z peaks | helical well [mm] |\n|" + "---|" * 11)  # fmt: skip
    for i in rows:
        pair = " | ".join(
            f"{r.u_z_rel[i, j]:.3f}, {r.Theta[i, j]:.2f}" if np.isfinite(r.u_z_rel[i, j]) else "—"
            for j in range(len(PAIR))
        )
        print(f"| {i} | {_fmt(r.values[i, :5])} | {_fmt(r.values[i, 5:])} | "
              f"{' '.join('y' if b else 'n' for b in r.named[i])} | {r.n_states[i]} | "
              f"{r.max_open_helical[i]}, {r.thirds_error[i]:.3f} | {r.slope_peak[i]:.2f} | {pair} | "
              f"{r.n_u_z_peaks[i]} | {r.helical_well[i]:.3f} |")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/fig4_law_search"))
    parser.add_argument("--tpc-sign", default="as_printed", help="geometric or as_printed")
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--workers", type=int, default=1, help="Dask workers (1: this process)")
    parser.add_argument("--samples", type=int, default=4096)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--parents", type=int, default=8)
    parser.add_argument("--per-parent", type=int, default=32)
    parser.add_argument("--slice-points", type=int, default=24)
    parser.add_argument("--spread", type=float, default=0.6)
    parser.add_argument("--circular-w2-max", type=float, default=1.6 * INFERRED_CIRCULAR_W2)
    parser.add_argument("--seed", type=int, default=20261206)
    parser.add_argument(
        "--claims", type=int, default=12, help="front sets whose claims are assessed"
    )
    parser.add_argument("--confirm", action="store_true", help="best set through `biplan states`")
    args = parser.parse_args()

    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from biplan._errors import check_integer
    from biplan.cli._checks import output_directory
    from biplan.options import ChainAttachment, TpcSign
    from biplan.plot.law_search import write_count_figure

    try:
        sign = TpcSign(args.tpc_sign)
    except ValueError:
        sys.exit(
            f"--tpc-sign: {args.tpc_sign!r} is not one of {', '.join(s.value for s in TpcSign)}"
        )
    try:
        output_directory(args.out)
        check_integer("--workers", args.workers, low=1)
        check_integer("--claims", args.claims, low=0)
        plan = SearchPlan(samples=args.samples, rounds=args.rounds, parents=args.parents,
                          per_parent=args.per_parent, slice_points=args.slice_points, seed=args.seed)  # fmt: skip
        box = _box(args.spread, args.circular_w2_max)
    except biplan.ConfigError as err:
        sys.exit(str(err))
    options = biplan.ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT, tpc_sign=sign)
    base = biplan.designs.fully_bistable(options)
    runner = None
    if args.workers > 1:
        from biplan.analysis.scaleout import dask_runner

        runner = dask_runner(n_workers=args.workers)
    print(f"TPC sign {sign.value}: up to {plan.size} law sets; box:")
    for name, (lo, hi, scale) in box.describe().items():
        print(f"  {name}: [{lo:.4g}, {hi:.4g}] {scale}")
    start = time.perf_counter()
    columns = ("[progress.description]{task.description}", BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn(), TimeRemainingColumn())  # fmt: skip
    with Progress(*columns) as bar:
        tasks: dict[str, object] = {}

        def progress(stage: str, done: int, total: int) -> None:
            if stage not in tasks:
                tasks[stage] = bar.add_task(f"stage {stage}", total=total)
            bar.update(tasks[stage], completed=done, total=total)  # type: ignore[arg-type]

        try:
            result = search_laws(
                base, box, plan, args.out, resume=args.resume, runner=runner, progress=progress
            )
        except biplan.ConfigError as err:
            sys.exit(str(err))
        except KeyboardInterrupt:
            sys.exit(
                f"interrupted: finished chunks kept in {args.out}/stage-*; rerun with --resume"
            )
    searched = time.perf_counter() - start
    failed = int((result.records.status == LawStatus.FAILED.value).sum())
    print(f"search: {searched:.0f} s, {len(result.records)} law sets (+ {plan.slice_points**2} in the slice), "
          f"{failed} failed")  # fmt: skip
    evidence(result)
    front = result.front
    print(f"\nPareto front over {', '.join(OBJECTIVES)}: {front.size} sets (lexicographic order)")
    front_table(result, front[:25])
    figure = write_count_figure(result, args.out / "fig4_law_count.png")
    print(f"wrote {figure}")

    rows = []
    for i in front[: args.claims]:
        tube = with_laws(base, result.records.values[i])
        assert tube is not None
        claims = claims_of(tube, args.out / "claims" / str(i))
        n = sum(v == "reproduced" for v, _ in claims.values())
        rows.append((int(i), n, claims))
    if rows:
        ids = list(rows[0][2])
        with (args.out / "claims.csv").open("w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(["row", "reproduced", *ids])
            w.writerows([i, n, *(c[k][0] for k in ids)] for i, n, c in rows)
        print("\nstates claims of the front (reproduced of", len(ids), ")")
        for i, n, c in rows:
            print(f"  row {i}: {n} — " + ", ".join(f"{k} {v[0]}" for k, v in c.items()))
        best = max(rows, key=lambda t: t[1])  # first of the most reproduced, lexicographic order
        print(f"\nmost claims: row {best[0]} ({best[1]}): {_fmt(result.records.values[best[0]])}")
        for k, (v, f) in best[2].items():
            print(f"| {k} | {v}: {f} |")
        if args.confirm:
            sys.path.insert(0, str(Path(__file__).parent))
            from fidelity_fully_bistable import _claims

            tube = with_laws(base, result.records.values[best[0]])
            child = _claims(args.out / "confirm", tube)
            same = all(child[k][0] == best[2][k][0] for k in child)
            print(f"`biplan states` child process: verdicts {'identical' if same else 'DIFFER'}")
    print(f"total {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
