"""Measurement: two AEKF vehicles (independent noise, the same path and map) fused by
:func:`slam.fleet.fuse_maps`, scored against the truth. Where the 3-D fleet's fused map is
overconfident, this separates what the fusion does from what the scenario's sensors do:
both maps start at the same known pose (the scenario's known frames), so the fusion's
model (independent Gaussian maps) is exact except for how well each filter's covariance
describes its own errors.

    python -m slam.experiments.fleet_pairs [--pairs 6] [--loops 1] [--dt 0.025] [--seed 1000]
        [--cross-correlation independent|unknown]

Prints per pair: landmarks paired, χ²/dof of the fusion, each map's landmark RMSE (m) and
landmark NEES, the fused map's, and the correlation of the two maps' landmark errors; at
the end the means and the vehicles' final-pose error (m) and NEES, own against fused.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from slam.estimators import make_estimator
from slam.experiments.runner import EXPERIMENT_AEKF_DEFAULTS, get_experiment
from slam.fleet import FleetFusionConfig, fuse_maps, vehicle_map_from
from slam.sim2d import simulate_run


def _vehicle(spec, seed: int):
    """One AEKF run (the experiment runner's default AEKF) on run ``seed``'s data."""
    sim_seed, est_seed = np.random.SeedSequence(seed).spawn(2)
    run = simulate_run(
        spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(sim_seed)
    )
    est = make_estimator("aekf", **EXPERIMENT_AEKF_DEFAULTS, rng=np.random.default_rng(est_seed))
    for i in range(run.n_scans):  # the filter's sequence of scans
        est.predict(run.odometry(i))
        est.update(run.observations(i))
    return est, run


def _nees(x, C, t) -> np.ndarray:
    e = x - t
    return np.einsum("ni,nij,nj->n", e, np.linalg.inv(C), e)


def _pose_nees(x, P, t) -> tuple[float, float]:
    d = np.asarray(x, float) - t
    d[2] = (d[2] + np.pi) % (2 * np.pi) - np.pi
    return float(np.hypot(*d[:2])), float(d @ np.linalg.solve(P, d))


def fleet_pair(spec, seeds: tuple[int, int], cross_correlation: str = "independent") -> dict:
    """Fuse the maps of runs ``seeds``; errors and NEES against the truth."""
    vs = [_vehicle(spec, s) for s in seeds]
    maps = [vehicle_map_from(e, f"v{k}")[0] for k, (e, _) in enumerate(vs)]
    f = fuse_maps(maps, config=FleetFusionConfig(cross_correlation=cross_correlation))
    truth = np.full((f.n_landmarks, 2), np.nan)
    out = {"paired": f.n_paired, "chi2": f.chi2, "dof": f.dof, "own": [], "pose": []}
    errs = []
    for k, (e, run) in enumerate(vs):
        lab = np.asarray(e.labels)
        m, C = e.landmarks()
        ok = lab >= 0
        t = run.landmarks[lab[ok]]
        truth[f.assignment[k][ok]] = t
        out["own"].append(
            (
                float(np.sqrt(np.mean(np.sum((m[ok] - t) ** 2, 1)))),
                float(_nees(m[ok], C[ok], t).mean()),
            )
        )
        errs.append(dict(zip(lab[ok].tolist(), m[ok] - t, strict=True)))
        tp = run.true_poses[-1]
        out["pose"].append(
            (
                _pose_nees(maps[k].x[:3], maps[k].P[:3, :3], tp),
                _pose_nees(f.poses[k], f.pose_cov[k], tp),
            )
        )
    ok = np.isfinite(truth[:, 0])
    d = f.landmarks[ok] - truth[ok]
    out["fused"] = (
        float(np.sqrt(np.mean(np.sum(d**2, 1)))),
        float(_nees(f.landmarks[ok], f.landmark_cov[ok], truth[ok]).mean()),
    )
    common = sorted(set(errs[0]) & set(errs[1]))
    e0 = np.array([errs[0][c] for c in common])
    e1 = np.array([errs[1][c] for c in common])
    out["error_correlation"] = float(np.sum(e0 * e1) / np.sqrt(np.sum(e0**2) * np.sum(e1**2)))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m slam.experiments.fleet_pairs")
    ap.add_argument("--pairs", type=int, default=6)
    ap.add_argument("--loops", type=int, default=1)
    ap.add_argument("--dt", type=float, default=0.025)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument(
        "--cross-correlation", choices=("independent", "unknown"), default="independent"
    )
    a = ap.parse_args(argv)
    if a.pairs < 1 or a.loops < 1:
        print("fleet_pairs: --pairs and --loops must be >= 1", file=sys.stderr)
        return 2
    spec = get_experiment("dense-loop", dt=a.dt, n_loops=a.loops)
    rows = []
    for p in range(a.pairs):  # one pair of full runs each (seconds)
        r = fleet_pair(spec, (a.seed + 2 * p, a.seed + 2 * p + 1), a.cross_correlation)
        rows.append(r)
        print(
            f"pair {p}: paired {r['paired']}, chi2/dof {r['chi2']:.1f}/{r['dof']}, own RMSE/NEES "
            + ", ".join(f"{x:.2f} m/{n:.2f}" for x, n in r["own"])
            + f", fused {r['fused'][0]:.2f} m/{r['fused'][1]:.2f}, "
            f"error correlation {r['error_correlation']:+.2f}",
            flush=True,
        )
    own = np.array([o for r in rows for o in r["own"]])
    fus = np.array([r["fused"] for r in rows])
    pose = np.array([p for r in rows for p in r["pose"]])  # (2 pairs, own/fused, err/nees)
    print(
        f"mean over {a.pairs} pairs: landmark RMSE own {own[:, 0].mean():.2f} m, fused "
        f"{fus[:, 0].mean():.2f} m; landmark NEES own {own[:, 1].mean():.2f}, fused "
        f"{fus[:, 1].mean():.2f}; final pose error own {pose[:, 0, 0].mean():.2f} m, fused "
        f"{pose[:, 1, 0].mean():.2f} m; pose NEES own {pose[:, 0, 1].mean():.2f}, fused "
        f"{pose[:, 1, 1].mean():.2f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
