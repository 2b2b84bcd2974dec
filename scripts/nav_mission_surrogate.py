"""Kinematic surrogate of a side-scan survey for mission design (diagnostic, not a result).

Flies a scenario's mission polyline kinematically at its speed, dead-reckons it with the
sensor error constants the scenario's seed draws (the same ``NavSuite`` construction as
``sim.runner.schedule.ScenarioRun``: compass deviation k1-k4, DVL scale factor,
misalignment and offset; its own Gauss–Markov compass drift and white noise), observes
every object once each time it crosses the side-scan beam (range 6-40 m, range-bearing
noise 0.4 m / 2°, known association) and runs the AEKF with the navigation bias states
(``slam.estimators.nav_bias``). Prints SLAM's and dead reckoning's ATE and their ratio.
No sonar, no front end, no physics: it shows what a mission lets the filter observe, not
what the pipeline achieves (the wreck's two-sided centre, missed or spurious detections).

usage: python scripts/nav_mission_surrogate.py SCENARIO SEED [SEED ...]
       [--set dotted.key=json ...] [--noise-seed N]
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from sim.navigation import NavSuite
from sim.runner.build import mission_for, nav_bias_model, nav_suite_config
from sim.scenario import load_scenario
from slam.estimators.aekf import AEKFSlam
from slam.estimators.nav_bias import NavBiasSlam
from slam.types import Odometry, RangeBearing

DT = 0.5  # s, odometry period
SIGMA_V = 0.003  # m/s, DVL white noise per axis
R_OBS = np.diag([0.4**2, math.radians(2.0) ** 2])


def _track(wps: np.ndarray, speed: float):
    seg = np.diff(wps, axis=0)
    length = np.hypot(*seg.T)
    cum = np.concatenate([[0.0], np.cumsum(length)])
    t = np.arange(0.0, cum[-1] / speed, DT)
    i = np.clip(np.searchsorted(cum, t * speed, side="right") - 1, 0, len(length) - 1)
    f = (t * speed - cum[i]) / length[i]
    return t, wps[i] + f[:, None] * seg[i], np.unwrap(np.arctan2(seg[i, 1], seg[i, 0]))


def _basis(p):
    return np.stack([np.sin(p), np.cos(p), np.sin(2 * p), np.cos(2 * p)], -1)


def surrogate(scn, noise_seed: int = 0) -> dict:
    """SLAM and dead-reckoning ATE (m) of one kinematic run of the scenario's vehicle 0."""
    vs = scn.vehicles[0]
    s_nav = (
        np.random.SeedSequence(scn.seed).spawn(len(scn.vehicles))[0].spawn(2 + len(vs.sonars))[0]
    )
    x0 = np.array([*vs.start_position[:2], math.radians(vs.start_yaw_deg)])
    nav = NavSuite(nav_suite_config(vs), np.random.default_rng(s_nav), t0=0.0, initial_pose=x0)
    k, cfg = nav.ahrs.deviation, nav.ahrs.config
    t, p, psi = _track(mission_for(vs, 60.0).waypoints, vs.mission.speed_mps)
    rng = np.random.default_rng(noise_seed)
    a = math.exp(-DT / cfg.drift_tau_s)
    g = np.empty(len(t))
    g[0] = nav.ahrs.drift
    for j in range(1, len(t)):
        g[j] = a * g[j - 1] + rng.normal(0.0, cfg.drift_std * math.sqrt(1 - a * a))
    eps = _basis(psi) @ k + g
    psi_dr = psi + eps - eps[0]
    m = nav.dvl.misalignment
    vb = (1 + nav.dvl.scale_error) * vs.mission.speed_mps * np.array([math.cos(m), math.sin(m)])
    vb = vb + nav.dvl.velocity_bias[:2]
    objs = np.array([np.asarray(o.position)[:2] for o in scn.world.objects])
    x_start = np.array([*p[0], psi[0]])
    est = NavBiasSlam(
        AEKFSlam(preset="consistent", association="known", x0=x_start, P0=np.zeros((3, 3))),
        nav_bias_model(vs),
        t0=0.0,
    )
    Q = np.diag([(SIGMA_V * DT) ** 2, (SIGMA_V * DT) ** 2, math.radians(0.02) ** 2])
    dr, drs, ests, along_prev = x_start.copy(), [p[0]], [p[0]], None
    for j in range(1, len(t)):
        v = vb + rng.normal(0.0, SIGMA_V, 2)
        dphi = psi_dr[j] - psi_dr[j - 1]
        c2, s2 = math.cos(dphi / 2), math.sin(dphi / 2)
        u = np.array([(c2 * v[0] - s2 * v[1]) * DT, (s2 * v[0] + c2 * v[1]) * DT, dphi])
        c, s = math.cos(dr[2]), math.sin(dr[2])
        dr = dr + np.array([c * u[0] - s * u[1], s * u[0] + c * u[1], u[2]])
        est.predict(Odometry(u, Q, t[j]))
        d = objs - p[j]
        r = np.hypot(*d.T)
        b = np.arctan2(d[:, 1], d[:, 0]) - psi[j]
        along = r * np.cos(b)
        if along_prev is not None:
            seen = np.flatnonzero((np.sign(along) != np.sign(along_prev)) & (r > 6) & (r < 40))
            obs = [
                RangeBearing(
                    np.array([r[o], math.atan2(math.sin(b[o]), math.cos(b[o]))])
                    + rng.multivariate_normal([0.0, 0.0], R_OBS),
                    R_OBS,
                    t[j],
                    label=int(o),
                )
                for o in seen
            ]
            if obs:
                est.update(obs)
        along_prev = along
        drs.append(dr[:2].copy())
        ests.append(est.pose()[0][:2].copy())

    def ate(x):
        return float(np.sqrt(np.mean(np.sum((np.array(x) - p) ** 2, axis=1))))

    return {
        "length_m": float(len(t) * DT * vs.mission.speed_mps),
        "slam_ate_m": ate(ests),
        "dead_reckoning_ate_m": ate(drs),
        "k_true_deg": np.degrees(k).round(2).tolist(),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("seeds", type=int, nargs="+")
    ap.add_argument("--set", action="append", default=[], help="dotted.key=json override")
    ap.add_argument("--noise-seeds", type=int, default=5, help="drift/noise draws per seed")
    a = ap.parse_args()
    over = {kv.split("=", 1)[0]: json.loads(kv.split("=", 1)[1]) for kv in a.set}
    for seed in a.seeds:
        scn = load_scenario(a.scenario, over).with_overrides(seed=seed)
        rs = [surrogate(scn, n) for n in range(a.noise_seeds)]
        ratios = [r["slam_ate_m"] / r["dead_reckoning_ate_m"] for r in rs]
        dr = np.median([r["dead_reckoning_ate_m"] for r in rs])
        print(
            f"{a.scenario} seed {seed} {over or ''}: {rs[0]['length_m']:.0f} m, ATE ratio "
            f"SLAM / dead reckoning median {np.median(ratios):.2f} over {len(rs)} drift draws "
            f"({', '.join(f'{x:.2f}' for x in ratios)}); dead reckoning ATE median {dr:.2f} m; "
            f"compass deviation k (deg) {rs[0]['k_true_deg']}",
            flush=True,
        )


if __name__ == "__main__":
    main()
