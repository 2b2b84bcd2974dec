"""A finished run scored against the simulator's truth: each vehicle's section of
metrics.json (sim.runner.metrics holds the measures themselves)."""

from __future__ import annotations

import numpy as np

from sim.runner.build import VehicleRuntime
from sim.runner.metrics import detection_metrics, landmark_metrics, pose_metrics
from slam.estimators.nav_bias import BIAS_STATES


def interp_angle(t, tt, a) -> np.ndarray:
    """Angles ``a`` at times ``tt`` interpolated to ``t`` (unwrapped, then wrapped)."""
    u = np.unwrap(a)
    r = np.interp(t, tt, u)
    return (r + np.pi) % (2 * np.pi) - np.pi


def vehicle_metrics(run) -> dict:
    """{vehicle name: its metrics} of a ScenarioRun (sim.runner.schedule)."""
    objs = run.world.objects
    truth_xy = np.array([np.asarray(o.position)[:2] for o in objs]).reshape(-1, 2)
    return {v.spec.name: _one_vehicle(v, objs, truth_xy) for v in run.vehicles}


def _detections(v: VehicleRuntime, objs) -> dict:
    tally = v.tally
    dets = [x for _, x in tally.detections]
    tp_n = sum(1 for x in dets if x.true_positive)
    out = detection_metrics(
        tp_n,
        len(dets) - tp_n,
        tally.fp_pixels,
        tally.bg_pixels,
        [x.object_id for x in dets if x.true_positive],
        sorted(tally.imaged_ids),
    )
    if objs and dets:
        wxy = np.array([x.world_xy_true_pose for x in dets])
        out["nearest_detection_m"] = {
            f"{o.class_name}_{o.id}": float(
                np.linalg.norm(wxy - np.asarray(o.position)[:2], axis=1).min()
            )
            for o in objs
        }
    if v.slam.counts:
        out["pipeline_counts"] = dict(sorted(v.slam.counts.items()))
    return out


def _pose(v: VehicleRuntime, tt: np.ndarray, tp: np.ndarray) -> dict | None:
    hist = v.lagged.history
    if not hist:
        return None
    ht = np.array([r.t for r in hist])
    est = np.array([r.x for r in hist])
    cov = np.array([r.P for r in hist])
    truth = np.column_stack(
        [np.interp(ht, tt, tp[:, 0]), np.interp(ht, tt, tp[:, 1]), interp_angle(ht, tt, tp[:, 3])]
    )
    out = pose_metrics(ht, est, cov, truth)
    # dead reckoning alone: the same odometry without any sonar update, at the same times
    dr = np.array(v.slam.dr_pose)
    drt = np.array(v.slam.dr_t)
    e = np.column_stack([np.interp(ht, drt, dr[:, 0]), np.interp(ht, drt, dr[:, 1])]) - truth[:, :2]
    out["dead_reckoning_ate_m"] = float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
    return out


def _one_vehicle(v: VehicleRuntime, objs, truth_xy) -> dict:
    tt = np.array(v.true_t)
    tp = np.array(v.true_pose)
    d: dict = {
        "kind": v.spec.kind,
        "distance_travelled_m": float(np.sum(np.hypot(*np.diff(tp[:, :2], axis=0).T))),
        "detections": _detections(v, objs),
        "navigation": v.nav.summary(),
    }
    if v.lagged is None:
        return d
    pose = _pose(v, tt, tp)
    if pose is not None:
        d["pose"] = pose
    means, covs = v.lagged.estimator.landmarks()
    seen = [i for i, o in enumerate(objs) if o.id in v.tally.imaged_ids]
    d["landmarks"] = landmark_metrics(means, covs, truth_xy[seen] if seen else np.zeros((0, 2)))
    d["landmarks"]["n_objects_imaged"] = len(seen)
    d["slam"] = {
        "estimator": v.spec.slam.estimator,
        "timing": v.spec.slam.timing,
        "n_predicts": v.lagged.n_predicts,
        "n_updates": v.lagged.n_updates,
    }
    if callable(getattr(v.lagged.estimator, "bias", None)):
        d["slam"]["nav_bias"] = _nav_bias(v)
    return d


def _nav_bias(v: VehicleRuntime) -> dict:
    """SLAM's navigation bias states (slam.estimators.nav_bias) at the end of the run:
    estimate and standard deviation of each, beside the sensors' true values (the
    compass drift's at the end of the run)."""
    b, P = v.lagged.estimator.bias()
    nav = v.nav
    true = [*nav.ahrs.deviation, nav.ahrs.drift, nav.dvl.scale_error, nav.dvl.misalignment]
    true += list(nav.dvl.velocity_bias[:2])
    return {
        n: {
            "estimate": float(b[i]),
            "sd": float(np.sqrt(max(P[i, i], 0.0))),
            "true": float(true[i]),
        }
        for i, n in enumerate(BIAS_STATES)
    }
