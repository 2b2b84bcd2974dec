"""undersea/ActiveSLAM-v0."""

from __future__ import annotations

import cv2
import gymnasium as gym
import numpy as np

from sim.envs.base import UnderseaEnv
from sim.envs.sonar_survey import FAST_SSS
from sim.runner.metrics import match_landmarks
from sim.viz import rerun_log as L
from sim.world import SonarWater
from slam.pipeline import (
    EstimatorSpec,
    FrameTruth,
    PipelineConfig,
    SonarFrame,
    SonarGeometry,
    SonarSlam,
    build_estimator,
    make_frontend,
)
from slam.types import Odometry

K_LANDMARKS = 8
#: the scenario pipeline with 64-ping windows (hop 32): one ping per step, so a window
#: of the scenario default (200) would hold SLAM 20 s behind the agent
PIPELINE = PipelineConfig(window_pings=64, hop_pings=32)


class ActiveSLAMEnv(UnderseaEnv):
    """Move so that sonar SLAM becomes certain and accurate.

    ## Description
    A vehicle (Alister 9 by default) with a side-scan sonar (fast DeepEye 680D settings,
    one ping per step) explores a seabed with ``n_objects`` objects (rocks, tyres, a pipe,
    a branch; layout from ``layout_seed``). The full undersea pipeline runs inside the env:
    ray-cast sonar -> waterfall windows (64 pings, hop 32) -> MIRA normalization ->
    improved Otsu segmentation -> side-scan observation model -> AEKF-SLAM fed in time
    order at the pose of each detection's ping (slam.pipeline.SonarSlam, the pipeline of
    the scenario runner with :data:`PIPELINE`'s windows; the filter lags one window behind, the current pose is its estimate dead-reckoned forward). Odometry comes
    from the vehicle's DVL + gyro dead reckoning (sim.navigation).

    ## Action Space
    ``Box(-1, 1, (n_actuators,), float32)``: normalized actuator commands held for one
    control step (0.1 s). Non-finite actions raise ``ValueError``; out-of-range values are
    clipped (``info["action_clipped"]``).

    ## Observation Space
    ``Dict``:

    * ``"nav"``: ``Box(-inf, inf, (12,), float32)`` - [0-1] SLAM position estimate now
      (m, world); [2-3] sin, cos of its heading; [4-6] 1-sigma of the lagged SLAM pose
      (x m, y m, heading rad); [7] number of mapped landmarks; [8-10] DVL velocity (m/s,
      body); [11] altitude (m, DVL).
    * ``"landmarks"``: ``Box(-inf, inf, (8, 4), float32)`` - the 8 nearest estimated
      landmarks: (forward m, port m) in the estimated body frame, 1-sigma of the major
      axis (m), 1 if the row holds a landmark else 0 (rows zero-padded).

    ## Rewards
    ``uncertainty``: decrease of U = sqrt(trace P_xy) of the pose plus the mean
    sqrt(trace) of the landmark covariances (m); ``error``: decrease of the landmark RMSE
    against the true objects (m, Hungarian matching within 5 m); ``+2`` per true object
    newly mapped; ``-1`` per spurious landmark created; ``-0.01 * |u|²``; ``-0.5`` per step
    below 3 m altitude; ``-50`` on collision. Each term and the truth are in ``info``.

    ## Starting State
    Vehicle 10 m above the seabed at a random point within 40 m of the centre with a
    random heading (reset seed); empty map.

    ## Episode End
    Terminated on collision; truncated at ``max_episode_steps`` (registered: 2000 = 200 s).

    ## Arguments
    ``gymnasium.make("undersea/ActiveSLAM-v0", vehicle="alister9", n_objects=8,
    layout_seed=0, estimator="aekf", sonar_overrides=None, arena_size=160.0,
    water_depth=25.0, render_mode=None, record_path=None)``. The layout is fixed per env
    instance; ``reset(options={"layout_seed": k})`` rebuilds the world with another one.

    ## Version History
    v0: first version.
    """

    ODOMETRY_COVARIANCE = True  # its SLAM predict reads NavSuite.odometry(t).cov

    def __init__(
        self,
        vehicle: str = "alister9",
        n_objects: int = 8,
        layout_seed: int = 0,
        estimator: str = "aekf",
        sonar_overrides: dict | None = None,
        arena_size: float = 160.0,
        water_depth: float = 25.0,
        control_dt: float = 0.1,
        physics_dt: float = 0.05,
        render_mode: str | None = None,
        record_path: str | None = None,
    ) -> None:
        if not 1 <= int(n_objects) <= 40:
            raise ValueError(f"n_objects = {n_objects!r}; allowed: an integer in [1, 40]")
        self._ctor = dict(
            vehicle=vehicle,
            arena_size=arena_size,
            water_depth=water_depth,
            control_dt=control_dt,
            physics_dt=physics_dt,
            render_mode=render_mode,
            record_path=record_path,
        )
        self.n_objects = int(n_objects)
        self.estimator_name = estimator
        self._sonar_overrides = dict(FAST_SSS, **(sonar_overrides or {}))
        self._build(int(layout_seed))
        self.observation_space = gym.spaces.Dict(
            {
                "nav": gym.spaces.Box(-np.inf, np.inf, (12,), np.float32),
                "landmarks": gym.spaces.Box(-np.inf, np.inf, (K_LANDMARKS, 4), np.float32),
            }
        )

    def _build(self, layout_seed: int) -> None:
        from sim.sonar import SideScanSonar, preset
        from sim.world import ObjectSpec

        self.layout_seed = layout_seed
        rng = np.random.default_rng(layout_seed)
        kinds = ["rock", "rock", "tyre", "rock", "pipe", "tree_branch", "rock", "tyre"]
        objs = []
        for i in range(self.n_objects):
            xy = rng.uniform(-50.0, 50.0, 2)
            objs.append(
                ObjectSpec(
                    kind=kinds[i % len(kinds)],
                    position_xy=tuple(xy),
                    yaw_deg=float(rng.uniform(-180, 180)),
                    seed=layout_seed * 100 + i,
                )
            )
        if getattr(self, "world", None) is not None:
            self.close()
        UnderseaEnv.__init__(self, **self._ctor, objects=tuple(objs), nav_sensors=True)
        cfg = preset("deepeye680d", **self._sonar_overrides)
        self._sss_cfg = cfg
        w, h = self.world, self.vehicle
        self.sonar = SideScanSonar(
            cfg,
            w.model,
            w.data,
            (h.site_ids["sss_port"], h.site_ids["sss_starboard"]),
            w.geom_object_id,
            w.geom_reflectivity,
            SonarWater(w.water),
            static_mesh=w.static_mesh(),
        )
        self.truth_xy = np.array([np.asarray(o.position)[:2] for o in w.objects]).reshape(-1, 2)

    def _new_slam(self, pose0: np.ndarray) -> None:
        c = self._sss_cfg
        self._geometry = SonarGeometry(
            "sss",
            self.sonar.ranges,
            along_track_beamwidth_deg=c.along_track_beamwidth_deg,
            log_compressed=c.acoustic.log_compression,
            dynamic_range_db=c.acoustic.dynamic_range_db,
        )
        rng = np.random.default_rng(int(self.np_random.integers(2**63)))
        est = build_estimator(EstimatorSpec(self.estimator_name), pose0, PIPELINE, rng)
        frontend = make_frontend(self._geometry, PIPELINE)
        self.slam = SonarSlam({"sss": frontend}, est, PIPELINE, t0=self.world.time)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if options and "layout_seed" in options and int(options["layout_seed"]) != self.layout_seed:
            self._build(int(options["layout_seed"]))
        rng = self.np_random
        xy = rng.uniform(-40.0, 40.0, 2)
        yaw = float(rng.uniform(-np.pi, np.pi))
        z = float(self.world.seabed_height(xy[None])[0]) + 10.0
        self._reset_world(np.array([xy[0], xy[1], z]), yaw)
        self._sonar_rng = np.random.default_rng(int(rng.integers(2**63)))
        self.sonar.clear_cache()
        self._new_slam(np.array([xy[0], xy[1], yaw]))
        self._U, self._E, self._mapped, self._n_spurious = self._uncertainty(), 0.0, 0, 0
        self.n_detections = 0
        st = self.vehicle.state()
        return self._get_obs(), {**self.true_info(st), "n_landmarks": 0}

    def _uncertainty(self) -> float:
        _, P = self.slam.estimator.pose()
        u = float(np.sqrt(max(P[0, 0] + P[1, 1], 0.0)))
        _, covs = self.slam.estimator.landmarks()
        if len(covs):
            u += float(np.mean(np.sqrt(np.clip(np.trace(covs, axis1=1, axis2=2), 0.0, None))))
        return u

    def _map_score(self) -> tuple[float, int, int]:
        means, _ = self.slam.estimator.landmarks()
        ei, _, d = match_landmarks(means, self.truth_xy, 5.0)
        rmse = float(np.sqrt(np.mean(d**2))) if len(d) else 0.0
        return rmse, len(ei), len(means) - len(ei)

    def _get_obs(self) -> dict:
        nav = self.nav_estimate()
        _, pose = self.slam.current_pose()
        _, P = self.slam.estimator.pose()
        o = np.zeros(12, np.float32)
        o[0:2] = pose[:2]
        o[2], o[3] = np.sin(pose[2]), np.cos(pose[2])
        o[4:7] = np.sqrt(np.clip(np.diag(P), 0.0, None))
        means, covs = self.slam.estimator.landmarks()
        o[7] = len(means)
        o[8:11] = nav.velocity
        o[11] = nav.altitude if np.isfinite(nav.altitude) else 0.0
        lm = np.zeros((K_LANDMARKS, 4), np.float32)
        if len(means):
            d = np.asarray(means) - pose[:2]
            order = np.argsort(np.hypot(d[:, 0], d[:, 1]))[:K_LANDMARKS]
            c, s = np.cos(pose[2]), np.sin(pose[2])
            lm[: len(order), 0] = c * d[order, 0] + s * d[order, 1]
            lm[: len(order), 1] = -s * d[order, 0] + c * d[order, 1]
            lm[: len(order), 2] = np.sqrt(
                np.linalg.eigvalsh(np.asarray(covs)[order])[:, -1].clip(0)
            )
            lm[: len(order), 3] = 1.0
        return {"nav": o, "landmarks": lm}

    def step(self, action):
        u, clipped = self._check_action(action)
        st = self._advance(u)
        inc = self._last_inc
        self.slam.add_odometry(Odometry(inc.delta, inc.cov, inc.t))
        ping = self.sonar.ping(self.world.data, self._sonar_rng)
        pose_true = np.array(
            [st.position[0], st.position[1], float(self.true_info(st)["true_yaw"])]
        )
        frame = SonarFrame(
            "sss",
            ping.intensity,
            self._geometry,
            ping.time,
            altitude=ping.altitude,
            speed=float(np.linalg.norm(self._nav_meas["v"][:2])),
            truth=FrameTruth(ping.labels, pose_true),
        )
        out = self.slam.add_frame(frame)
        if out.window is not None:
            self.n_detections += len(out.window.detections)
            if self._rec is not None:
                L.log_sonar_image(
                    self._rec, self.vehicle.name, "sss", out.window.image, out.window.overlay
                )
        self.slam.release(st.t)
        collided = self._collided(st)
        U = self._uncertainty()
        E, mapped, spurious = self._map_score()
        terms = {
            "reward_uncertainty": self._U - U,
            "reward_error": self._E - E,
            "reward_mapped": 2.0 * (mapped - self._mapped),
            "reward_spurious": -1.0 * max(0, spurious - self._n_spurious),
            "reward_effort": -0.01 * float(np.sum(u**2)),
            "reward_low_altitude": -0.5 if st.altitude < 3.0 else 0.0,
            "reward_collision": -50.0 if collided else 0.0,
        }
        self._U, self._E, self._mapped, self._n_spurious = U, E, mapped, spurious
        reward = float(sum(terms.values()))
        info = {
            **self.true_info(st),
            **terms,
            "landmark_rmse_m": E,
            "objects_mapped": mapped,
            "spurious_landmarks": spurious,
            "n_detections": self.n_detections,
            "slam_lag_s": st.t - self.slam.lagged.t_done,
            "action_clipped": clipped,
            "collided": collided,
        }
        self._log_step(st, reward, {"uncertainty_m": U, "landmark_rmse_m": E})
        if self._rec is not None:
            means, covs = self.slam.estimator.landmarks()
            if len(means):
                L.log_landmarks(
                    self._rec,
                    self.vehicle.name,
                    means,
                    covs,
                    self.world.seabed_height(np.asarray(means).reshape(-1, 2)) + 0.5,
                )
        return self._get_obs(), reward, bool(collided), False, info

    def _render_rgb(self) -> np.ndarray:
        from sim.viz.rerun_log import ellipse_axes

        img = self._base()
        means, covs = self.slam.estimator.landmarks()
        if len(means):
            half, ang = ellipse_axes(covs)
            s = self.render_size / self.arena_size
            for p, h, a in zip(self._world_to_px(means), half, ang):
                axes = (max(1, int(h[0] * s)), max(1, int(h[1] * s)))
                cv2.ellipse(
                    img, (int(p[0]), int(p[1])), axes, -np.degrees(a), 0, 360, (255, 140, 0), 1
                )
                cv2.drawMarker(img, (int(p[0]), int(p[1])), (255, 140, 0), cv2.MARKER_CROSS, 6)
        _, pose = self.slam.current_pose()
        q = self._world_to_px(pose[:2])[0]
        cv2.circle(img, (int(q[0]), int(q[1])), 4, (255, 140, 0), 1)
        self._draw_vehicle(img, self.vehicle.state())
        return img
