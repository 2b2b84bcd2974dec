"""``undersea slam-experiment {dense-loop,line,segmentation-loop} --filter {aekf,fastslam2,isam2}``

Runs the reference's simulated SLAM experiments (thesis ch. 6) on Tim Bailey's simulator:
N seeded Monte Carlo runs, landmark RMSE and per-landmark errors, ATE, compute time, the
average NEES with its 95 % χ² bounds, NIS; writes figures and a JSON file to ``--out``.
"""

from __future__ import annotations

import argparse
import json

from sim.cli.common import CliError, print_json

_EXPERIMENTS = ("dense-loop", "line", "segmentation-loop")
_FILTERS = ("aekf", "fastslam2", "isam2", "aekf-submap", "aekf-robocentric")


def _param(text: str) -> tuple[str, object]:
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"--param expects KEY=VALUE, got {text!r}")
    key, val = text.split("=", 1)
    try:
        value = json.loads(val)
    except json.JSONDecodeError:
        value = val
    return key, value


def _dt(text: str) -> float:
    v = float(text)
    if v not in (0.025, 0.0125):
        raise argparse.ArgumentTypeError(f"--dt must be 0.025 or 0.0125 s, got {text}")
    return v


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("experiment", choices=_EXPERIMENTS, help="which experiment")
    parser.add_argument(
        "--filter", choices=_FILTERS, default="aekf", help="estimator (default aekf)"
    )
    parser.add_argument("--runs", type=int, default=1, help="Monte Carlo runs (default 1)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first run (default 0)")
    parser.add_argument(
        "--dt",
        type=_dt,
        default=0.025,
        help="control interval s: 0.025 (Bailey) or 0.0125 (thesis)",
    )
    parser.add_argument("--loops", type=int, default=None, help="override the number of loops")
    parser.add_argument(
        "--unbiased-odometry",
        action="store_true",
        help="correct the simulator's odometry bias exp(-σ_G²/2) (Bailey's is biased)",
    )
    parser.add_argument("--out", default=None, help="directory for figures and results JSON")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    parser.add_argument(
        "--param",
        type=_param,
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="estimator parameter, repeatable (e.g. jacobians=fej, association=known, n_particles=100)",
    )


def run(args: argparse.Namespace) -> int:
    from slam.experiments import get_experiment, run_monte_carlo, save_results

    if args.runs < 1:
        raise CliError(f"--runs must be >= 1, got {args.runs}")
    if args.loops is not None and args.loops < 1:
        raise CliError(f"--loops must be >= 1, got {args.loops}")
    spec = get_experiment(
        args.experiment, dt=args.dt, n_loops=args.loops, unbiased_odometry=args.unbiased_odometry
    )
    params = dict(args.param)
    try:
        mc = run_monte_carlo(
            spec, args.filter, runs=args.runs, seed=args.seed, estimator_params=params
        )
    except ImportError as exc:
        raise CliError(f"{exc}") from exc
    except (TypeError, ValueError) as exc:
        raise CliError(
            f"bad estimator parameters {params}: {exc}"
        ) from exc
    if args.out:
        summary = save_results(mc, spec, args.out)
    else:
        summary = mc.summary()
        summary["dt_s"] = spec.sim.dt_s
        summary["n_loops"] = spec.sim.n_loops
    summary["unbiased_odometry"] = spec.sim.unbiased_odometry
    if args.json:
        summary = dict(summary)
        if args.runs > 1:
            summary["runs"] = [
                {
                    k: v
                    for k, v in r.items()
                    if k in ("seed", "landmark_rmse", "ate", "time_s", "mean_nees")
                }
                for r in summary["runs"]
            ]
        print_json(summary)
        return 0
    s = summary
    print(
        f"{spec.name} ({s['n_runs']} run(s), dt {spec.sim.dt_s} s, {spec.sim.n_loops} loop(s)), filter {args.filter}"
    )
    print(
        f"  landmark RMSE median {s['landmark_rmse_median_m']:.3f} m, mean {s['landmark_rmse_mean_m']:.3f} m"
    )
    named = ", ".join(f"{k} {v:.3f}" for k, v in s["named_errors_median_m"].items())
    print(f"  named landmark errors (median, m): {named}")
    print(
        f"  ATE median {s['ate_median_m']:.3f} m; estimator time {s['time_s_mean']:.3f} s per run"
    )
    print(
        f"  landmarks inside their 3σ ellipse: {100 * s['frac_in_3sigma']:.1f} %; "
        f"runs with duplicate/spurious landmarks: {s['runs_with_duplicates']}"
    )
    lo, hi = s["nees_bounds"]
    print(
        f"  average NEES (time mean) {s['avg_nees_time_mean']:.2f}; 95 % bounds [{lo:.2f}, {hi:.2f}]; "
        f"{100 * s['nees_frac_inside']:.1f} % of scans inside"
    )
    print(f"  mean NIS of associated observations {s['mean_nis']:.3f}")
    if args.out:
        print(f"  wrote {', '.join(s['files'].values())}")
    return 0
