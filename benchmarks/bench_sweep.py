"""Sweep throughput: runs/s serial vs 2 local worker processes vs local Ray with 2 workers,
measured side by side on the same plan. Default plan: 4 seeds of a 150 s shipwreck-survey
scenario run (physics, sonar, front end, SLAM; ~8 s each on an idle core), long enough that the workers'
start-up (a fresh interpreter importing numpy, mujoco, ...) does not dominate.

    undersea bench sweep [--runs 4] [--target shipwreck-survey] [--json]
    undersea bench sweep --target slam:dense-loop --runs 40   # many short SLAM runs

Target (issue 7): >= 1.8x with 2 workers.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="undersea bench sweep")
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--target", default="shipwreck-survey")
    ap.add_argument("--duration", type=float, default=150.0, help="scenario duration_s override")
    ap.add_argument("--no-ray", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    from sim.sweep import SweepPlan, run_sweep

    if args.target.startswith("slam:"):
        vary = {"loops": [1]}
    else:  # no recording: the benchmark measures the runs, not rerun's file writing
        vary = {"duration_s": [args.duration], "outputs.recording": [False], "outputs.figures": [False]}
    plan = SweepPlan(args.target, runs=args.runs, vary=vary)
    modes = [("serial", {"workers": 1}), ("local-2", {"workers": 2})]
    if not args.no_ray:
        try:
            import ray

            modes.append(("ray-local-2", {"workers": 2, "use_ray": True}))
        except ImportError:
            print("ray not installed: skipping the Ray mode (pip install 'undersea[cluster]')",
                  file=sys.stderr)
    import os

    figures = {"runs": args.runs, "target": args.target, "vary": vary,
               "load_avg_1min_at_start": os.getloadavg()[0]}
    with tempfile.TemporaryDirectory() as tmp:
        for name, kw in modes:
            if kw.get("use_ray"):
                # as on a running cluster: Ray's own start-up is timed apart, not per sweep
                import time

                import ray

                t0 = time.perf_counter()
                ray.init(num_cpus=kw["workers"], include_dashboard=False, log_to_driver=False)
                figures["ray_start_s"] = time.perf_counter() - t0
            try:
                res = run_sweep(plan, Path(tmp) / name, progress=False, **kw)
            finally:
                if kw.get("use_ray"):
                    ray.shutdown()
            if res.failed:
                raise SystemExit(f"bench sweep: {name} had failures: {res.failed}")
            figures[f"{name}_wall_s"] = res.wall_s
            figures[f"{name}_runs_per_s"] = args.runs / res.wall_s
    base = figures["serial_runs_per_s"]
    for name, _ in modes[1:]:
        figures[f"{name}_speedup"] = figures[f"{name}_runs_per_s"] / base
    if args.json:
        print(json.dumps(figures, indent=1))
    else:
        for k, v in figures.items():
            print(f"{k:>24}: {v:.3f}" if isinstance(v, float) else f"{k:>24}: {v}")
        print("target: speedup >= 1.8 with 2 workers")
    return 0


if __name__ == "__main__":
    sys.exit(main())
