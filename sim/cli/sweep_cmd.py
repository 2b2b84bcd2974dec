"""``undersea sweep TARGET --runs N [--vary key=v1,v2 ...] [--workers K] [--ray ADDRESS]``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sim.cli.common import print_json
from sim.jsonsafe import dumps


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "target",
        help="scenario name or .toml path, or slam:dense-loop | slam:line | slam:segmentation-loop",
    )
    parser.add_argument("--runs", type=int, default=10, help="seeds per variant (default 10)")
    parser.add_argument("--seed", type=int, default=1, help="first seed (default 1)")
    parser.add_argument(
        "--vary", action="append", metavar="KEY=V1,V2",
        help="vary a parameter (repeatable); scenario: dotted keys like slam.estimator; "
        "slam:*: filter, dt, loops, est.<name>",
    )
    parser.add_argument("--workers", type=int, default=1, help="parallel workers (default 1: serial)")
    parser.add_argument("--ray", dest="ray_address", nargs="?", const="local", default=None,
                        metavar="ADDRESS", help="run on Ray: a cluster address, or no value for a local Ray")
    parser.add_argument("--out", default="runs/sweep",
                        help="output directory (resumes if it holds the same plan)")
    parser.add_argument(
        "--force",
        action="store_true",
        help="--out holds a sweep of another plan: delete its results and start over",
    )
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")


def run(args: argparse.Namespace) -> int:
    from sim.sweep import SweepPlan, aggregate_runs, nees_consistency, parse_vary, run_sweep

    try:
        plan = SweepPlan(target=args.target, runs=args.runs, vary=parse_vary(args.vary),
                         base_seed=args.seed)
        use_ray = args.ray_address is not None
        address = None if args.ray_address in (None, "local") else args.ray_address
        result = run_sweep(plan, args.out, workers=args.workers, use_ray=use_ray,
                           ray_address=address)
    except (ValueError, RuntimeError) as exc:
        print(f"undersea sweep: {exc}", file=sys.stderr)
        return 2
    records = result.records
    table = aggregate_runs(records)
    out = Path(args.out)
    table.to_csv(out / "summary.csv")
    parquet = table.to_parquet(out / "summary.parquet")
    nees = nees_consistency(records)
    (out / "nees_consistency.json").write_text(dumps(nees, indent=1))
    summary = {
        "out": str(out),
        "finished_now": len(result.finished),
        "resumed": len(result.skipped),
        "failed": result.failed,
        "wall_s": result.wall_s,
        "runs_per_s": len(result.finished) / result.wall_s if result.wall_s > 0 else None,
        "table": str(out / "summary.csv"),
        "parquet": str(parquet) if parquet else None,
        "nees_consistency": nees,
    }
    if args.json:
        print_json(summary, indent=1)
    else:
        print(f"sweep {plan.target}: {len(result.finished)} run(s) now, {len(result.skipped)} resumed, "
              f"{len(result.failed)} failed, {result.wall_s:.1f} s -> {out}")
        for run_id, err in sorted(result.failed.items()):
            print(f"  FAILED {run_id}: {err}")
        wanted = ("landmark_rmse", "ate", "mean_nees", "time_s")
        for row in table.rows:
            if row["metric"] in wanted or row["metric"].endswith(("landmark_rmse", ".ate", "mean_nees")):
                print(f"  {row['variant']:<28} {row['metric']:<24} n={row['n']:<3} "
                      f"mean={row['mean']:.4g} ±95% [{row['ci95_low']:.4g}, {row['ci95_high']:.4g}]")
        for variant, c in nees.items():
            print(f"  NEES {variant}: mean {c['mean_nees']:.3g} vs 95% bounds "
                  f"[{c['bounds'][0]:.3g}, {c['bounds'][1]:.3g}] over {c['n_runs']} runs; "
                  f"{100 * c['fraction_inside']:.0f}% of steps inside")
    return 1 if result.failed else 0
