"""``undersea bench slam [--json] [--runs N] [--sizes 100,500,2000] [--skip-fastslam]``

1. Wall time of one full dense-loop run (example_webmap, two loops, dt 0.025 s: 17,382
   control steps, 1,931 scans) per estimator, same seed and data, in the same process;
   the ratio FastSLAM 2.0 / AEKF (the reference's MATLAB: 525.5 s / 137.9 s = 3.81).
   Target: AEKF <= 1 s per run. Estimator time = its predict/update/landmarks calls only;
   the simulation is reported separately.
2. AEKF update time versus number of landmarks (100, 500, 2,000): one scan = predict +
   gated ML association against all landmarks + batch update with 2 observations; the
   log-log slope shows the O(n²) growth. Goal: 2,000 landmarks at >= 50 updates/s.

BLAS is limited to one thread (the filters' small matrices only lose from threads on a
shared 2-core machine); ``--blas-threads`` changes that for the scaling part.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def _dense_loop_times(runs: int, skip_fastslam: bool, skip_isam2: bool) -> dict:
    from slam.experiments import get_experiment, run_once
    from slam.sim2d import simulate_run

    spec = get_experiment("dense-loop")
    names = ["aekf", "aekf-fej"]
    if not skip_fastslam:
        names.append("fastslam2")
    if not skip_isam2:
        names.append("isam2")
    out: dict = {"experiment": "dense-loop", "runs": runs, "n_scans": None, "estimators": {}}
    sim_t = []
    for r in range(runs):
        ss = np.random.SeedSequence(r)
        t0 = time.perf_counter()
        run = simulate_run(
            spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(ss.spawn(2)[0])
        )
        sim_t.append(time.perf_counter() - t0)
        out["n_scans"] = run.n_scans
        for name in names:
            est, params = ("aekf", {"jacobians": "fej"}) if name == "aekf-fej" else (name, {})
            try:
                res = run_once(spec, est, r, params, sim_run=run)
            except ImportError as exc:
                out["estimators"][name] = {"error": str(exc)}
                continue
            d = out["estimators"].setdefault(name, {"time_s": [], "landmark_rmse_m": []})
            d["time_s"].append(res.time_s)
            d["landmark_rmse_m"].append(res.landmark_rmse)
    out["simulation_s_mean"] = float(np.mean(sim_t))
    for d in out["estimators"].values():
        if "time_s" in d:
            d["time_s_mean"] = float(np.mean(d["time_s"]))
            d["landmark_rmse_median_m"] = float(np.median(d["landmark_rmse_m"]))
    est = out["estimators"]
    if "fastslam2" in est and "time_s_mean" in est.get("fastslam2", {}):
        out["ratio_fastslam2_over_aekf"] = (
            est["fastslam2"]["time_s_mean"] / est["aekf"]["time_s_mean"]
        )
    out["reference_matlab_s"] = {
        "aekf": 137.937051,
        "fastslam2": 525.526820,
        "ratio": 525.526820 / 137.937051,
    }
    out["target_aekf_s"] = 1.0
    return out


def _scaling(sizes, n_steps: int, seed: int = 0) -> dict:
    """Time of one scan cycle of AEKFSlam with n landmarks already in the map."""
    from slam.estimators.aekf import AEKFSlam

    rng = np.random.default_rng(seed)
    R = np.diag([0.1**2, np.radians(1.0) ** 2])
    Q = np.diag([0.02**2, 0.005**2, np.radians(0.3) ** 2])
    rows = []
    for n in sizes:
        # n landmarks on a grid with 3 m spacing around the origin; covariance PSD by
        # construction (diagonal + low rank), as a filter after many updates would have
        side = int(np.ceil(np.sqrt(n)))
        g = np.stack(np.meshgrid(np.arange(side), np.arange(side)), -1).reshape(-1, 2)[:n] * 3.0
        lm = g - g.mean(axis=0)
        N = 3 + 2 * n
        U = rng.standard_normal((N, 8)) * 0.05
        P = U @ U.T + np.diag(np.full(N, 0.01))
        f = AEKFSlam(x0=np.zeros(3))
        f.x = np.concatenate([np.zeros(3), lm.reshape(-1)])
        f.P = P
        f._lm_first = lm.copy()
        f.labels = np.full(n, -1, np.int64)
        f.ids = np.arange(n)
        f.misses = np.zeros(n, np.int64)
        f.hits = np.ones(n, np.int64)
        f._next_id = n
        near = np.argsort(np.hypot(*lm.T))[1:3]  # two landmarks near the vehicle
        times = []
        for _ in range(n_steps):
            d = lm[near] - f.x[:2]
            z = np.stack([np.hypot(*d.T), np.arctan2(d[:, 1], d[:, 0]) - f.x[2]], 1)
            z += rng.standard_normal(z.shape) * [0.1, np.radians(1.0)]
            t0 = time.perf_counter()
            f.predict_arrays([0.0, 0.0, 0.0], Q)
            res = f.update_arrays(z, R)
            times.append(time.perf_counter() - t0)
        assoc_ok = bool(np.all(res.associations == near))
        t = float(np.median(times))
        rows.append(
            {
                "n_landmarks": int(n),
                "state_dim": int(N),
                "scan_update_ms": 1e3 * t,
                "updates_per_s": 1.0 / t,
                "last_association_correct": assoc_ok,
            }
        )
    ns = np.array([r["n_landmarks"] for r in rows], float)
    ts = np.array([r["scan_update_ms"] for r in rows])
    slope = float(np.polyfit(np.log(ns), np.log(ts), 1)[0]) if len(rows) > 1 else float("nan")
    return {"rows": rows, "loglog_slope": slope, "goal": "2000 landmarks at >= 50 updates/s"}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="undersea bench slam", description=__doc__.split("\n")[0])
    p.add_argument("--json", action="store_true")
    p.add_argument("--runs", type=int, default=1, help="dense-loop runs per estimator (default 1)")
    p.add_argument("--sizes", default="100,500,2000", help="landmark counts for the scaling part")
    p.add_argument("--steps", type=int, default=20, help="timed scans per size (median reported)")
    p.add_argument("--skip-fastslam", action="store_true")
    p.add_argument("--skip-isam2", action="store_true")
    p.add_argument("--blas-threads", type=int, default=1)
    args = p.parse_args(argv)
    from threadpoolctl import threadpool_limits

    sizes = [int(s) for s in args.sizes.split(",") if s]
    result = {"dense_loop": _dense_loop_times(args.runs, args.skip_fastslam, args.skip_isam2)}
    with threadpool_limits(limits=args.blas_threads, user_api="blas"):
        result["scaling"] = _scaling(sizes, args.steps)
    result["scaling"]["blas_threads"] = args.blas_threads
    if args.json:
        print(json.dumps(result))
        return 0
    d = result["dense_loop"]
    print(
        f"dense loop, 2 loops, {d['n_scans']} scans, {d['runs']} run(s); simulation {d['simulation_s_mean']:.3f} s"
    )
    for name, e in d["estimators"].items():
        if "error" in e:
            print(f"  {name:10s} unavailable: {e['error']}")
        else:
            print(
                f"  {name:10s} {e['time_s_mean']:8.3f} s per run   landmark RMSE median {e['landmark_rmse_median_m']:.2f} m"
            )
    if "ratio_fastslam2_over_aekf" in d:
        print(
            f"  FastSLAM 2.0 / AEKF time ratio {d['ratio_fastslam2_over_aekf']:.1f} "
            f"(reference MATLAB {d['reference_matlab_s']['ratio']:.2f}); AEKF target <= 1 s"
        )
    s = result["scaling"]
    print(
        f"AEKF scan update (predict + association over all landmarks + batch update of 2), BLAS threads {args.blas_threads}:"
    )
    for r in s["rows"]:
        print(
            f"  n = {r['n_landmarks']:5d} (state {r['state_dim']:5d}): {r['scan_update_ms']:8.3f} ms "
            f"= {r['updates_per_s']:8.1f} updates/s"
        )
    print(f"  log-log slope {s['loglog_slope']:.2f} (2 = O(n²)); goal {s['goal']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
