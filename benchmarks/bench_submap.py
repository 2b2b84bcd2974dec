"""Sub-mapping AEKF with map joining: update rate against the full AEKF, join time, RMSE.

A straight survey line (default 5 km, a landmark every 5 m on alternating sides, the same
generator and seed as ``bench_slam.py``'s sub-map part: 996 landmarks), one pass,
simulated once. Side by side in one run: the sub-mapping AEKF (local maps of ``--size``
landmarks) and the full single-map AEKF (``--skip-full`` to leave it out), both with
first-estimates Jacobians; per-update wall time (mean over all scans and over the last
10 %), the time of one map join with fusion of the landmarks shared across local maps,
and the landmark RMSE of the joined map, of the unfused chain and of the full AEKF; also
the sub-maps with ``join_at_switch`` (each frozen map joined at once: the slowest update
pays a fusion solve, the final join only the live map).

    python benchmarks/bench_submap.py [--json] [--length 5000] [--spacing 5] [--size 100]
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def _line_map(length_m: float, spacing_m: float, rng):
    """Landmarks every ``spacing_m`` along y = 0 on alternating sides at |y| in [5, 20] m."""
    xs = np.arange(10.0, length_m - 10.0, spacing_m)
    side = np.where(np.arange(xs.size) % 2 == 0, 1.0, -1.0)
    lm = np.stack([xs, side * rng.uniform(5.0, 20.0, xs.size)], axis=1)
    wp = np.stack([np.linspace(length_m / 4, length_m, 4), np.zeros(4)], axis=1)
    return lm, wp


def _drive(f, run) -> np.ndarray:
    times = np.empty(run.n_scans)
    for i in range(run.n_scans):  # the filter's scan loop (timed per scan)
        z, lab = run.scan(i)
        t0 = time.perf_counter()
        f.predict_arrays(run.odom_u[i], run.odom_Q[i])
        f.update_arrays(z, run.R, lab)
        times[i] = time.perf_counter() - t0
    return times


def _rates(times: np.ndarray) -> dict:
    tail = times[-max(1, times.size // 10) :]
    return {
        "total_s": float(times.sum()),
        "updates_per_s": float(1.0 / times.mean()),
        "last10pct_updates_per_s": float(1.0 / tail.mean()),
        "max_update_ms": float(1e3 * times.max()),
    }


def measure(length_m: float, spacing_m: float, size: int, full: bool) -> dict:
    from slam.estimators.aekf import AEKFSlam
    from slam.estimators.aekf_submap import SubmapAEKFSlam
    from slam.metrics import landmark_errors, landmark_mahalanobis
    from slam.sim2d import Sim2DConfig, simulate_run

    rng = np.random.default_rng(0)
    lm, wp = _line_map(length_m, spacing_m, rng)
    run = simulate_run(lm, wp, Sim2DConfig(n_loops=1), rng)
    out = {"length_m": length_m, "n_true_landmarks": int(lm.shape[0]), "n_scans": run.n_scans}

    def quality(est, cov, labels) -> dict:
        le = landmark_errors(est, lm, est_labels=labels, max_distance=50.0)
        md = landmark_mahalanobis(est[le.est_index], cov[le.est_index], lm[le.true_index])
        return {
            "n_landmarks": int(est.shape[0]),
            "n_duplicates": int(le.n_unmatched_est),
            "landmark_rmse_m": le.rmse,
            "frac_in_3sigma": float(np.mean(md <= 3.0)),
        }

    f = SubmapAEKFSlam(max_landmarks=size, jacobians="fej")
    sub = _rates(_drive(f, run))
    t0 = time.perf_counter()
    gm = f.join()
    sub["join_s"] = time.perf_counter() - t0
    sub["n_submaps"] = f.n_submaps
    sub["max_landmarks"] = size
    sub["n_fused"] = gm.n_fused
    sub["joined_state_dim"] = int(gm.x.size)
    sub["joined"] = quality(*gm.landmarks(), gm.labels)
    sub["chain"] = quality(*f.chain_landmarks(), f.chain_labels)
    out["submap"] = sub
    # join_at_switch: each frozen map joined at once (O(N²) at the switching update)
    h = SubmapAEKFSlam(max_landmarks=size, jacobians="fej", join_at_switch=True)
    out["submap_join_at_switch"] = _rates(_drive(h, run))
    t0 = time.perf_counter()
    h.join()
    out["submap_join_at_switch"]["join_s"] = time.perf_counter() - t0
    if full:
        g = AEKFSlam(jacobians="fej")
        out["full"] = _rates(_drive(g, run))
        out["full"].update(quality(*g.landmarks(), g.labels))
        out["ratio_updates_submap_over_full"] = sub["updates_per_s"] / out["full"]["updates_per_s"]
        out["ratio_last10pct_submap_over_full"] = (
            sub["last10pct_updates_per_s"] / out["full"]["last10pct_updates_per_s"]
        )
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="bench_submap", description=__doc__.split("\n")[0])
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--length", type=float, default=5000.0, help="m of survey line")
    p.add_argument("--spacing", type=float, default=5.0, help="m between landmarks")
    p.add_argument("--size", type=int, default=100, help="landmarks per local map")
    p.add_argument("--skip-full", action="store_true", help="leave out the full AEKF")
    p.add_argument("--blas-threads", type=int, default=1)
    args = p.parse_args(argv)
    if args.size < 1 or args.length <= 40 or args.spacing <= 0:
        p.error(
            f"need --size >= 1, --length > 40 m, --spacing > 0 m; got {args.size}, "
            f"{args.length}, {args.spacing}"
        )
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=args.blas_threads, user_api="blas"):
        r = measure(args.length, args.spacing, args.size, not args.skip_full)
    r["blas_threads"] = args.blas_threads
    if args.json:
        print(json.dumps(r))
        return 0
    s = r["submap"]
    print(
        f"{r['length_m']:.0f} m line, {r['n_true_landmarks']} landmarks, {r['n_scans']} scans, "
        f"BLAS threads {args.blas_threads}"
    )
    print(
        f"  sub-maps ({s['n_submaps']} of <= {s['max_landmarks']}): {s['updates_per_s']:.0f} "
        f"updates/s ({s['last10pct_updates_per_s']:.0f} over the last 10 %), {s['total_s']:.2f} s, "
        f"slowest update {s['max_update_ms']:.1f} ms"
    )
    w = r["submap_join_at_switch"]
    print(
        f"  sub-maps, join at every switch: {w['updates_per_s']:.0f} updates/s, {w['total_s']:.2f} s, "
        f"slowest update {w['max_update_ms']:.1f} ms; final join then {w['join_s']:.3f} s"
    )
    if "full" in r:
        f = r["full"]
        print(
            f"  full AEKF: {f['updates_per_s']:.0f} updates/s ({f['last10pct_updates_per_s']:.0f} "
            f"over the last 10 %), {f['total_s']:.2f} s, slowest {f['max_update_ms']:.1f} ms; sub-maps / full = "
            f"{r['ratio_updates_submap_over_full']:.1f}x ({r['ratio_last10pct_submap_over_full']:.1f}x "
            "over the last 10 %)"
        )
    print(
        f"  one join: {s['join_s']:.3f} s, state {s['joined_state_dim']}, {s['n_fused']} duplicates fused"
    )
    rows = [("joined", s["joined"]), ("chain (unfused)", s["chain"])]
    if "full" in r:
        rows.append(("full AEKF", r["full"]))
    for name, q in rows:
        print(
            f"  {name:16s} RMSE {q['landmark_rmse_m']:7.2f} m, {q['n_landmarks']} landmarks, "
            f"{q['n_duplicates']} duplicates, {100 * q['frac_in_3sigma']:.0f} % inside 3σ"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
