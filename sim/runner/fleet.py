"""The fleet's one map (SWARMs use case 5): at the end of a run with two or more SLAM
vehicles, every vehicle's map and the GPS fix of each vehicle that is at the surface are
handed to :func:`slam.fleet.fuse_maps`; the fused map is scored against the truth
(``metrics.json``'s ``"fleet"`` section) and returned for the recording.

Each vehicle's map is in the world frame (its navigation starts from its launch pose, and
its covariance holds that start uncertainty), so the map frames are known; a vehicle whose
last GPS fix is at the end of the run (it surfaced and is handing its map over) anchors
the fused map with that fix on its final pose.
"""

from __future__ import annotations

import numpy as np

from sim.runner.metrics import landmark_metrics
from slam.fleet import FusedMap, GpsFix, fuse_maps, vehicle_map_from

#: a fix counts as taken at hand-over when it is this close to the end of the run, s
HANDOVER_FIX_S = 1.0


def _surface_fix(v, i: int, t_end: float) -> GpsFix | None:
    """Vehicle ``v``'s (index ``i``) last GPS fix, if taken at hand-over (end of run)."""
    if not v.gps_fixes:
        return None
    t, xy = v.gps_fixes[-1]
    if t < t_end - HANDOVER_FIX_S:
        return None
    sd = v.nav.config.gps.horizontal_noise_std
    return GpsFix(i, np.asarray(xy, float), np.eye(2) * max(sd, 1e-3) ** 2)


def fleet_map(run) -> tuple[FusedMap | None, dict | None]:
    """``(fused map, metrics)`` of a finished ScenarioRun, or ``(None, None)`` with fewer
    than two vehicles running SLAM."""
    slam_vehicles = [v for v in run.vehicles if v.lagged is not None]
    if len(slam_vehicles) < 2:
        return None, None
    maps, joint, gps = [], [], []
    for i, v in enumerate(slam_vehicles):
        mp, is_joint = vehicle_map_from(v.lagged.estimator, v.spec.name)
        maps.append(mp)
        joint.append(is_joint)
        fix = _surface_fix(v, i, run.world.time)
        if fix is not None:
            gps.append(fix)
    fused = fuse_maps(maps, gps)
    objs = run.world.objects
    seen = sorted({oid for v in slam_vehicles for oid in v.tally.imaged_ids})
    idx = [k for k, o in enumerate(objs) if o.id in seen]
    truth = np.array([np.asarray(objs[k].position)[:2] for k in idx]).reshape(-1, 2)
    lm = landmark_metrics(fused.landmarks, fused.landmark_cov, truth)
    lm["n_objects_imaged"] = len(idx)
    poses, moved = {}, {}
    for k, v in enumerate(slam_vehicles):  # final pose of each vehicle in the fused map
        tp = np.asarray(v.true_pose[-1])
        poses[v.spec.name] = float(np.hypot(*(fused.poses[k, :2] - tp[:2])))
        moved[v.spec.name] = float(np.hypot(*(fused.poses[k, :2] - maps[k].x[:2])))
    members = [[] for _ in range(fused.n_landmarks)]
    for k, a in enumerate(fused.assignment):  # which vehicles mapped each fused landmark
        for j in a:
            members[int(j)].append(slam_vehicles[k].spec.name)
    metrics = {
        "vehicles": [v.spec.name for v in slam_vehicles],
        "gps_anchored": [slam_vehicles[f.vehicle].spec.name for f in gps],
        "approximate_covariance": [
            v.spec.name for v, j in zip(slam_vehicles, joint, strict=True) if not j
        ],
        "n_landmarks_per_vehicle": {m.name: m.n_landmarks for m in maps},
        "n_paired_between_vehicles": fused.n_paired,
        "n_ambiguous": fused.n_ambiguous,
        "chi2": fused.chi2,
        "dof": fused.dof,
        "landmarks": lm,
        "final_pose_error_m": poses,
        "pose_moved_by_fusion_m": moved,
        "landmark_positions_m": np.round(fused.landmarks, 3).tolist(),
        "landmark_vehicles": members,
    }
    return fused, metrics
