"""The rerun recording of a scenario run, as a run observer (sim.runner.schedule).

The loop never calls rerun itself: it tells :class:`RerunObserver` that a run started,
that a sonar frame went through the pipeline and that a tick ended; this module decides
what to log and how often (sim.viz.rerun_log holds the entity tree).
"""

from __future__ import annotations

import math

import numpy as np

from sim.runner.schedule import RunObserver
from sim.viz import rerun_log as L
from sim.viz.meshes import box_mesh, vehicle_body_mesh
from slam.frontend.sidescan_prepare import PREPARED_DB


class RerunObserver(RunObserver):
    """Logs a run to the recording ``rec`` (sim.viz.rerun_log.open_recording)."""

    def __init__(self, rec) -> None:
        self.rec = rec

    def on_start(self, run) -> None:
        """Static data: annotations, seabed, objects, vehicle meshes."""
        rec = self.rec
        L.log_annotations(rec)
        vtx, f, _ = run.world.static_mesh()
        L.log_seabed(rec, vtx, f)
        objs = run.world.objects
        if objs:
            L.log_objects(
                rec,
                [o.id for o in objs],
                [o.class_name for o in objs],
                np.array(
                    [np.asarray(o.position) + np.array([0.0, 0.0, o.size[2] / 2]) for o in objs]
                ),
                np.array([o.size for o in objs]),
            )
        for v in run.vehicles:
            mesh = vehicle_body_mesh(run.world.model, run.world.data, v.handle.body_id)
            if mesh is None:
                L.log_vehicle_mesh(rec, v.spec.name, *box_mesh(*v.handle.model.envelope))
            else:
                L.log_vehicle_mesh(rec, v.spec.name, mesh[0], mesh[1], vertex_colors=mesh[2])

    def on_frame(self, run, v, s, out) -> None:
        """Sonar images (side-scan windows every ``log_sonar_every`` pings, in dB by one
        fixed mapping; FLS frames
        every 5x that, every MSIS scan) and side-scan detections."""
        every = run.scn.outputs.log_sonar_every
        rec = self.rec
        if out.window is not None:
            if s.frames % every != 0:
                return
            res = out.window
            L.set_time(rec, run.world.time)
            # the front end's window (dB re the normalized seabed, PREPARED_DB): one
            # display mapping for the whole run, so no brightness step between windows
            L.log_sonar_image(
                rec, v.spec.name, s.spec.name, res.image, res.overlay, db_span=PREPARED_DB
            )
            if res.detections:
                xy = np.array([d.world_xy_true_pose for d in res.detections])
                z = run.world.seabed_height(xy.reshape(-1, 2))
                L.log_detections(
                    rec,
                    v.spec.name,
                    s.spec.name,
                    np.column_stack([xy, z]),
                    [f"obj {d.object_id}" if d.object_id else "?" for d in res.detections],
                )
        elif out.kind == "fls" and out.polar is not None:
            if s.frames % max(1, every * 5) != 0:
                return
            frame = out.frames[0]
            L.set_time(rec, run.world.time)
            lab = frame.truth.labels
            overlay = np.where(out.polar.groups > 0, np.where(lab > 0, 2, 255), 0).astype(np.uint16)
            L.log_sonar_image(rec, v.spec.name, s.spec.name, frame.image, overlay)
        elif out.kind == "msis" and out.frames:
            L.set_time(rec, run.world.time)
            L.log_sonar_image(
                rec, v.spec.name, s.spec.name, np.stack([f.image for f in out.frames])
            )

    def on_tick(self, run) -> None:
        """Vehicle poses every 0.5 s; trajectories, map and SLAM scalars every 5 s."""
        dt = run.scn.control_dt
        k = round(run.world.time / dt)
        if k % max(1, round(0.5 / dt)) != 0:
            return
        L.set_time(self.rec, run.world.time)
        for v in run.vehicles:
            st = v.handle.state()
            L.log_vehicle_pose(self.rec, v.spec.name, st.position, st.quat_wxyz)
            if k % max(1, round(5.0 / dt)) == 0:
                self._log_map(run, v)

    def _log_map(self, run, v) -> None:
        rec = self.rec
        tp = np.array(v.true_pose)
        L.log_trajectory(rec, v.spec.name, "true", tp[::5, :3])
        lag = v.lagged
        if lag is not None and lag.history:
            h = np.array([r.x for r in lag.history])
            z = np.interp([r.t for r in lag.history], v.true_t, tp[:, 2])
            L.log_trajectory(rec, v.spec.name, "estimated", np.column_stack([h[::5, :2], z[::5]]))
            means, covs = lag.estimator.landmarks()
            if len(means):
                zs = run.world.seabed_height(np.asarray(means, float).reshape(-1, 2)) + 0.5
                L.log_landmarks(rec, v.spec.name, means, covs, zs)
            x, P = lag.estimator.pose()
            true_xy = [np.interp(lag.t_done, v.true_t, tp[:, i]) for i in (0, 1)]
            L.log_scalars(
                rec,
                v.spec.name,
                {
                    "slam/sigma_x_m": math.sqrt(max(P[0, 0], 0.0)),
                    "slam/sigma_yaw_deg": math.degrees(math.sqrt(max(P[2, 2], 0.0))),
                    "slam/n_landmarks": float(len(means)),
                    "slam/lag_s": run.world.time - lag.t_done,
                    "slam/position_error_m": float(np.hypot(true_xy[0] - x[0], true_xy[1] - x[1])),
                },
            )
        L.log_scalars(rec, v.spec.name, {"detections": float(len(v.tally.detections))})
