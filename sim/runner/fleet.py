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

from sim.runner.metrics import landmark_metrics, match_landmarks
from slam.fleet import FleetFusionConfig, FusedMap, GpsFix, VehicleMap, fuse_maps, vehicle_map_from

#: a fix counts as taken at hand-over when it is this close to the end of the run, s
HANDOVER_FIX_S = 1.0

#: the vehicles' maps are fused by covariance intersection: fused as independent, AEKF
#: maps of one area come out overconfident (docs/fleet_map.md, "Overconfidence")
FUSION = FleetFusionConfig(cross_correlation="unknown")


def _surface_fix(v, i: int, t_end: float) -> GpsFix | None:
    """Vehicle ``v``'s (index ``i``) last GPS fix, if taken at hand-over (end of run)."""
    if not v.gps_fixes:
        return None
    t, xy = v.gps_fixes[-1]
    if t < t_end - HANDOVER_FIX_S:
        return None
    sd = v.nav.config.gps.horizontal_noise_std
    return GpsFix(i, np.asarray(xy, float), np.eye(2) * max(sd, 1e-3) ** 2)


def fleet_map(run, inputs_to=None) -> tuple[FusedMap | None, dict | None]:
    """``(fused map, metrics)`` of a finished ScenarioRun, or ``(None, None)`` with fewer
    than two vehicles running SLAM. ``inputs_to``: a path where the fusion's inputs (every
    vehicle's map, the GPS fixes, the true final poses and the imaged objects) are saved
    (:func:`save_fleet_inputs`), to re-run the fusion offline."""
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
    objs = run.world.objects
    seen = sorted({oid for v in slam_vehicles for oid in v.tally.imaged_ids})
    idx = [k for k, o in enumerate(objs) if o.id in seen]
    truth = np.array([np.asarray(objs[k].position)[:2] for k in idx]).reshape(-1, 2)
    true_poses = np.array([np.asarray(v.true_pose[-1])[[0, 1, 3]] for v in slam_vehicles])
    if inputs_to is not None:
        save_fleet_inputs(inputs_to, maps, gps, true_poses, truth)
    fused = fuse_maps(maps, gps, FUSION)
    lm = landmark_metrics(fused.landmarks, fused.landmark_cov, truth)
    lm["n_objects_imaged"] = len(idx)
    poses, own, moved, nees = {}, {}, {}, {}
    for k, v in enumerate(slam_vehicles):  # final pose of each vehicle in the fused map
        tp = true_poses[k]
        poses[v.spec.name] = float(np.hypot(*(fused.poses[k, :2] - tp[:2])))
        own[v.spec.name] = float(np.hypot(*(maps[k].x[:2] - tp[:2])))
        moved[v.spec.name] = float(np.hypot(*(fused.poses[k, :2] - maps[k].x[:2])))
        nees[v.spec.name] = {
            "own": _pose_nees(maps[k].x[:3], maps[k].P[:3, :3], tp),
            "fused": _pose_nees(fused.poses[k], fused.pose_cov[k], tp),
        }
    members = [[] for _ in range(fused.n_landmarks)]
    for k, a in enumerate(fused.assignment):  # which vehicles mapped each fused landmark
        for j in a:
            members[int(j)].append(slam_vehicles[k].spec.name)
    per_object = _per_object(fused, truth, [objs[k] for k in idx], members)
    metrics = {
        "vehicles": [v.spec.name for v in slam_vehicles],
        "cross_correlation": FUSION.cross_correlation,
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
        "own_final_pose_error_m": own,
        "final_pose_nees": nees,
        "pose_moved_by_fusion_m": moved,
        "per_object": per_object,
        "landmark_positions_m": np.round(fused.landmarks, 3).tolist(),
        "landmark_vehicles": members,
    }
    return fused, metrics


def _pose_nees(x, P, truth) -> float:
    """NEES of pose ``x`` [x, y, φ] (covariance ``P``) against ``truth``."""
    e = np.asarray(x, float) - truth
    e[2] = (e[2] + np.pi) % (2 * np.pi) - np.pi
    return float(e @ np.linalg.solve(P + np.eye(3) * 1e-12, e))


def _per_object(fused, truth, objects, members) -> list[dict]:
    """Each imaged object matched by a fused landmark: its error (m), its NEES and the
    vehicles whose maps hold it (where an overconfident landmark comes from)."""
    ei, ti, d = match_landmarks(fused.landmarks, truth)
    out = []
    for e, t, dist in zip(ei, ti, d, strict=True):  # matched objects (few)
        err = fused.landmarks[e] - truth[t]
        out.append(
            {
                "object": f"{objects[t].class_name}#{objects[t].id}",
                "error_m": round(float(dist), 3),
                "nees": round(float(err @ np.linalg.solve(fused.landmark_cov[e], err)), 2),
                "vehicles": members[e],
            }
        )
    return out


def save_fleet_inputs(path, maps, gps, true_poses, truth) -> None:
    """The fusion's inputs as one ``.npz``: ``x_k``/``P_k``/``name_k`` per vehicle map (world
    frame), ``gps_vehicle``/``gps_xy``/``gps_cov``, ``true_poses (K, 3)`` at hand-over and
    ``truth (n, 2)`` the imaged objects' centres (m, rad). :func:`load_fleet_inputs` reads it."""
    arrays = {"true_poses": true_poses, "truth": truth, "n_maps": np.array(len(maps))}
    for k, mp in enumerate(maps):
        arrays.update({f"x_{k}": mp.x, f"P_{k}": mp.P, f"name_{k}": np.array(mp.name)})
    arrays["gps_vehicle"] = np.array([f.vehicle for f in gps], dtype=int)
    arrays["gps_xy"] = np.array([f.xy for f in gps]).reshape(-1, 2)
    arrays["gps_cov"] = np.array([f.cov for f in gps]).reshape(-1, 2, 2)
    np.savez(path, **arrays)


def load_fleet_inputs(path) -> tuple[list[VehicleMap], list[GpsFix], np.ndarray, np.ndarray]:
    """``(maps, gps fixes, true poses (K, 3), truth (n, 2))`` saved by :func:`save_fleet_inputs`."""
    d = np.load(path)
    maps = [
        VehicleMap(d[f"x_{k}"], d[f"P_{k}"], str(d[f"name_{k}"])) for k in range(int(d["n_maps"]))
    ]
    gps = [
        GpsFix(int(v), xy, c)
        for v, xy, c in zip(d["gps_vehicle"], d["gps_xy"], d["gps_cov"], strict=True)
    ]
    return maps, gps, d["true_poses"], d["truth"]
