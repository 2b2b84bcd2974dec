"""``undersea sss-slam FILE.xtf``: the front end and SLAM on a real side-scan recording."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

HELP = "run the segmentation front end and SLAM on a recorded side-scan XTF file (needs its navigation)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="side-scan recording (.xtf) with per-ping position and heading")
    parser.add_argument("--method", default="improved-otsu",
                        help="segmentation: improved-otsu | otsu | local | isodata | kapur")
    parser.add_argument("--preset", default="auto", help="segmentation preset (default: from image size)")
    parser.add_argument("--normalization", default="column-median", choices=("column-median", "mira"))
    parser.add_argument("--estimator", default="aekf", help="aekf | fastslam2 | isam2 | aekf-robocentric")
    parser.add_argument("--window", type=int, default=200, help="pings per segmented window")
    parser.add_argument("--hop", type=int, default=100, help="pings between windows")
    parser.add_argument("--altitude", default="first_return", choices=("first_return", "nav"))
    parser.add_argument("--nav-units", default="auto", choices=("auto", "degrees", "metres"),
                        help="position units (auto: the XTF header's NavUnits)")
    parser.add_argument("--odometry-sigma-frac", type=float, default=0.02,
                        help="1-sigma odometry error per metre travelled (fraction)")
    parser.add_argument("--out", default=None, help="directory for result.json and sss_slam.png")
    parser.add_argument("--json", action="store_true", help="print the result summary as JSON")


def run(args: argparse.Namespace) -> int:
    from slam.io.xtf import read_xtf
    from slam.sidescan_slam import SidescanSlamConfig, plot_sidescan_slam, run_sidescan_slam

    try:
        cfg = SidescanSlamConfig(
            method=args.method, preset=args.preset, normalization=args.normalization,
            estimator=args.estimator, window_pings=args.window, hop_pings=args.hop,
            altitude=args.altitude, nav_units=args.nav_units, odometry_sigma_frac=args.odometry_sigma_frac,
        )
        wf = read_xtf(args.file)
        result = run_sidescan_slam(wf, cfg)
    except (ValueError, FileNotFoundError) as exc:
        print(f"undersea sss-slam: {exc}", file=sys.stderr)
        return 2
    summary = {"file": str(args.file), **result.summary()}
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "result.json").write_text(json.dumps(summary, indent=1))
        plot_sidescan_slam(wf, result, out / "sss_slam.png")
        summary["figure"] = str(out / "sss_slam.png")
    if args.json:
        print(json.dumps(summary, indent=1))
    else:
        print(f"{args.file}: {summary['pings_used']} pings, {summary['windows']} windows, "
              f"{len(result.detections)} detections, {len(result.landmarks)} landmarks "
              f"({result.timing_s['total']:.2f} s)")
        for d in summary["detections"]:
            print(f"  ping {d['ping']:>5} {d['side']:<9} ground range {d['ground_range_m']:6.2f} m "
                  f"-> ({d['world_xy_nav_m'][0]:.1f}, {d['world_xy_nav_m'][1]:.1f}) m")
        if args.out:
            print(f"  figure: {summary['figure']}")
    return 0
