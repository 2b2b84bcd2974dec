"""``undersea uwsn``: UWSN-DT demo reproducing the thesis's setup (Ch. 4.3, Table 4.5)."""

from __future__ import annotations

import argparse

from sim.cli.common import finite_float, print_json, writable_file


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--nodes", type=int, default=1000)
    parser.add_argument(
        "--sigma", type=finite_float, default=0.5, help="node position noise in a sonar map, m"
    )
    parser.add_argument(
        "--altitude", type=finite_float, default=0.0, help="AUV altitude H, m (eq. 4.19)"
    )
    parser.add_argument(
        "--heading-b", type=finite_float, default=0.0, help="heading of the second scan, deg"
    )
    parser.add_argument(
        "--plot", default=None, help="write the figure (nodes, scans, Delaunay mesh)"
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from slam.frontend.uwsn import UWSNConfig, plot_demo, thesis_demo

    writable_file(args.plot, "--plot")
    cfg = UWSNConfig(n_nodes=args.nodes, position_sigma_m=args.sigma, altitude_m=args.altitude)
    d = thesis_demo(
        np.random.default_rng(args.seed),
        config=cfg,
        heading_b_rad=float(np.radians(args.heading_b)),
    )
    out = {
        "seed": args.seed,
        "comm_range_m": cfg.comm_range_m,
        "scan_m": [cfg.scan_length_m, cfg.scan_width_m],
        "nodes_scan_a": int(d.scan_a.ids.size),
        "nodes_scan_b": int(d.scan_b.ids.size),
        "awake_a": d.scan_a.n_awake,
        "awake_b": d.scan_b.n_awake,
        "shared_nodes": d.fusion.common_ids.tolist(),
        "triangles": int(d.fusion.triangles.shape[0]),
        "shared_triangle_fraction": d.fusion.shared_triangle_fraction,
        "matched": d.fusion.matched,
        "translation_error_m": d.translation_error_m,
        "rotation_error_deg": d.rotation_error_deg,
        "rms_residual_m": d.fusion.rms_residual_m,
    }
    if args.plot:
        plot_demo(d, args.plot)
        out["plot"] = args.plot
    if args.json:
        print_json(out)
    else:
        print(
            f"R = {cfg.comm_range_m:.1f} m; scan {cfg.scan_length_m:.0f} m x {cfg.scan_width_m:.0f} m"
        )
        print(f"AUV (500, 500): {out['nodes_scan_a']} nodes reply ({out['awake_a']} woke up)")
        print(f"AUV (600, 600): {out['nodes_scan_b']} nodes reply ({out['awake_b']} woke up)")
        print(
            f"shared nodes: {len(out['shared_nodes'])}, Delaunay triangles: {out['triangles']}, "
            f"matched: {out['matched']}"
        )
        print(
            f"recovered transform error: {out['translation_error_m']:.3f} m, "
            f"{out['rotation_error_deg']:.4f} deg (rms residual {out['rms_residual_m']:.3f} m)"
        )
    return 0
