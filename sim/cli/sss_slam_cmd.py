"""``undersea sss-slam FILE``: the front end and SLAM on a real sonar recording: a side-scan
XTF file, or FLS polar frames ``FILE.npy`` with their JSON sidecar (docs/pipeline.md)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from sim.cli.common import finite_float, print_json
from sim.jsonsafe import dumps
from slam.estimators import ESTIMATORS


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help="side-scan recording (.xtf .jsf .DAT .sl2 .sl3 .rsd) with per-ping "
                        "position and heading, or FLS frames (.npy, with FILE.json beside it)")
    parser.add_argument("--method", default="improved-otsu",
                        help="segmentation: improved-otsu | otsu | local | isodata | kapur")
    parser.add_argument("--preset", default="auto", help="segmentation preset (default: from image size)")
    parser.add_argument("--normalization", default="column-median", choices=("column-median", "mira"))
    parser.add_argument("--estimator", default="aekf", choices=tuple(ESTIMATORS),
                        help="SLAM estimator (slam.estimators)")
    parser.add_argument("--window", type=int, default=200, help="pings per segmented window")
    parser.add_argument("--hop", type=int, default=100, help="pings between windows")
    parser.add_argument("--altitude", default="first_return", choices=("first_return", "nav"))
    parser.add_argument("--nav-units", default="auto", choices=("auto", "degrees", "metres"),
                        help="position units (auto: the XTF header's NavUnits)")
    parser.add_argument("--odometry-sigma-frac", type=finite_float, default=0.02,
                        help="1-sigma odometry error per metre travelled (fraction)")
    parser.add_argument("--out", default=None, help="directory for result.json, sss_slam.png and the "
                        "GIS outputs (mosaic.tif, landmarks.geojson, detections.geojson)")
    parser.add_argument("--json", action="store_true", help="print the result summary as JSON")


def _write_result(out: Path, summary: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "result.json").write_text(dumps(summary, indent=1))


def run_fls(args: argparse.Namespace) -> int:
    """FLS frames (.npy + .json sidecar) through the same pipeline."""
    from dataclasses import replace

    from slam.fls_slam import FlsSlamConfig, load_fls_recording, run_fls_slam
    from slam.pipeline import EstimatorSpec, PipelineConfig

    try:
        pipe = replace(PipelineConfig(), method=args.method, preset=args.preset)
        cfg = FlsSlamConfig(
            pipeline=pipe, estimator=EstimatorSpec(args.estimator), nav_units=args.nav_units,
            odometry_sigma_frac=args.odometry_sigma_frac,
        )
        result = run_fls_slam(load_fls_recording(args.file), cfg)
    except (ValueError, FileNotFoundError) as exc:
        print(f"undersea sss-slam: {exc}", file=sys.stderr)
        return 2
    summary = {"file": str(args.file), **result.summary()}
    if args.out:
        _write_result(Path(args.out), summary)
    if args.json:
        print_json(summary, indent=1)
    else:
        print(f"{args.file}: {summary['frames']} frames, {len(result.detections)} confirmed "
              f"detections, {result.n_observations} observations, {len(result.landmarks)} "
              f"landmarks ({result.timing_s['total']:.2f} s)")
    return 0


def run(args: argparse.Namespace) -> int:
    if str(args.file).lower().endswith(".npy"):
        return run_fls(args)
    from dataclasses import replace

    from slam.io.geo import write_slam_geo_outputs
    from slam.io.sidescan import read_sidescan
    from slam.pipeline import REAL_SIDESCAN, EstimatorSpec
    from slam.sidescan_slam import SidescanSlamConfig, plot_sidescan_slam, run_sidescan_slam

    try:
        pipe = replace(
            REAL_SIDESCAN, method=args.method, preset=args.preset,
            normalization=args.normalization, window_pings=args.window, hop_pings=args.hop,
        )
        cfg = SidescanSlamConfig(
            pipeline=pipe, estimator=EstimatorSpec(args.estimator), altitude=args.altitude,
            nav_units=args.nav_units, odometry_sigma_frac=args.odometry_sigma_frac,
        )
        rec = read_sidescan(args.file)
        wf = rec.waterfall
        result = run_sidescan_slam(wf, cfg)
    except (ValueError, FileNotFoundError) as exc:
        print(f"undersea sss-slam: {exc}", file=sys.stderr)
        return 2
    summary = {"file": str(args.file), **result.summary()}
    if args.out:
        out = Path(args.out)
        _write_result(out, summary)
        plot_sidescan_slam(wf, result, out / "sss_slam.png")
        summary["figure"] = str(out / "sss_slam.png")
        if result.origin is not None:  # GeoTIFF mosaic + GeoJSON (WGS84) for a GIS
            try:
                summary["gis"] = write_slam_geo_outputs(
                    out, rec, result.origin, result.landmarks, result.landmark_cov,
                    [d.world_xy_true_pose for d in result.detections], summary["detections"])
            except ValueError as exc:
                print(f"undersea sss-slam: no GIS outputs: {exc}", file=sys.stderr)
    if args.json:
        print_json(summary, indent=1)
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
