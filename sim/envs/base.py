"""Shared machinery of the undersea gymnasium environments.

Every env owns one MuJoCo world (sim.world) with one vehicle, that vehicle's navigation
suite (sim.navigation) and a dead-reckoned nav pose; the agent commands the vehicle's
actuators directly. Actions: ``Box(-1, 1, (n_actuators,), float32)`` = the normalized
commands of ``VehicleHandle.thruster_names`` (propellers, and for torpedo AUVs the fin
pairs), held for one control step. Navigation: the sensors of ``ENV_NAV_CONFIG``; envs
that read only the navigation estimate (not the odometry covariance) run them as
``sim.navigation.NavBatch`` of one vehicle (same readings and dead-reckoned pose as a
NavSuite, without its covariance propagation), the others as a NavSuite. Bad actions: a non-finite entry raises ValueError
(rejected before anything reaches the physics); finite values outside [-1, 1] are
clipped and ``info["action_clipped"]`` says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import cv2
import gymnasium as gym
import numpy as np

from sim.frames import euler_from_wxyz, wxyz_from_euler
from sim.navigation import IMUConfig, NavSuite, NavSuiteConfig
from sim.navigation.batch import NavBatch
from sim.viz.meshes import vehicle_body_mesh
from sim.world.vehicles import VEHICLE_KINDS
from slam.pipeline.lagged import apply_increment

VEHICLE_CHOICES = VEHICLE_KINDS  # the vehicles sim.world defines
# tactical-grade IMU (FOG), as an AUV of this class carries; the consumer-MEMS default
# drifts ~0.3 deg/s in heading
ENV_NAV_CONFIG = NavSuiteConfig(imu=IMUConfig.preset("tactical"))


@dataclass(frozen=True)
class NavEstimate:
    """What the vehicle's own navigation knows (not the truth).

    pose: (3,) dead-reckoned [x, y, yaw] world m, rad; velocity: (3,) DVL body m/s (last
    valid); yaw_rate rad/s (gyro z); depth m (pressure); altitude m (DVL); roll, pitch rad
    (AHRS)."""

    pose: np.ndarray
    velocity: np.ndarray
    yaw_rate: float
    depth: float
    altitude: float
    roll: float
    pitch: float


class UnderseaEnv(gym.Env):
    """Base class; see the concrete envs for the manual."""

    metadata: ClassVar[dict] = {"render_modes": ["rgb_array"], "render_fps": 10}
    # True: the env reads NavSuite.odometry's covariance (``_last_inc``), so it runs a
    # NavSuite; False: NavBatch of one vehicle
    ODOMETRY_COVARIANCE: ClassVar[bool] = False

    def __init__(
        self,
        vehicle: str = "alister9",
        *,
        arena_size: float = 200.0,
        water_depth: float = 30.0,
        control_dt: float = 0.1,
        physics_dt: float = 0.05,
        render_mode: str | None = None,
        record_path: str | None = None,
        objects: tuple = (),
        seabed_kind: str = "flat",
        render_size: int = 480,
        nav_sensors: bool = True,
    ) -> None:
        if vehicle not in VEHICLE_CHOICES:
            raise ValueError(f"vehicle = {vehicle!r}; allowed: {', '.join(VEHICLE_CHOICES)}")
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode = {render_mode!r}; allowed: None, 'rgb_array'")
        n = control_dt / physics_dt
        if physics_dt <= 0 or abs(n - round(n)) > 1e-9 or round(n) < 1:
            raise ValueError(
                f"control_dt = {control_dt!r} must be a whole multiple of physics_dt = {physics_dt!r} (s)"
            )
        from sim.world import SeabedSpec, VehicleSpec, WorldSpec, build_world

        self.vehicle_kind = vehicle
        self.arena_size = float(arena_size)
        self.water_depth = float(water_depth)
        self.control_dt = float(control_dt)
        self.frame_skip = round(n)
        self.render_mode = render_mode
        self.render_size = int(render_size)
        self.nav_sensors = bool(nav_sensors)
        self.record_path = record_path
        res = max(1.0, self.arena_size / 100.0)
        self._world_spec = WorldSpec(
            seabed=SeabedSpec(
                kind=seabed_kind,
                size_xy=(arena_size, arena_size),
                resolution=res,
                depth=water_depth,
            ),
            vehicles=(VehicleSpec(vehicle, position=(0.0, 0.0, -water_depth / 2)),),
            objects=tuple(objects),
            timestep=physics_dt,
        )
        self.world = build_world(self._world_spec)
        self.vehicle = self.world.vehicles[vehicle]
        self.n_actuators = self.vehicle.n_thrusters
        self.action_space = gym.spaces.Box(-1.0, 1.0, (self.n_actuators,), np.float32)
        self._rec = None
        self._closed = False  # set by close(); step/reset then raise
        self._trail: list[np.ndarray] = []
        self._base_image: np.ndarray | None = None
        self._last_u = np.zeros(self.n_actuators)
        self.nav = None
        self._nav_pose = np.zeros(3)

    # ---------------------------------------------------------------- life cycle --------
    def _check_open(self) -> None:
        if getattr(self, "_closed", False):
            raise RuntimeError(
                f"{type(self).__name__} is closed; allowed: step/reset before close(), "
                "or make a new environment with gymnasium.make"
            )

    def _reset_world(self, start_xyz: np.ndarray, yaw: float) -> None:
        self._check_open()
        self.world.reset()
        self.vehicle.set_pose(start_xyz, wxyz_from_euler(0.0, 0.0, yaw))
        self.vehicle.set_thruster_commands(np.zeros(self.n_actuators))
        self._last_u = np.zeros(self.n_actuators)
        st = self.vehicle.state()
        nav_rng = np.random.default_rng(int(self.np_random.integers(2**63)))
        if not self.nav_sensors:
            self.nav = None
        elif self.ODOMETRY_COVARIANCE:
            self.nav = NavSuite(ENV_NAV_CONFIG, nav_rng, t0=st.t)
        else:
            self.nav = NavBatch(ENV_NAV_CONFIG, 1)
            self.nav.reset(0, nav_rng, st.t)
        self._nav_pose = np.array([start_xyz[0], start_xyz[1], yaw], float)
        self._nav_meas = {
            "v": np.zeros(3),
            "r": 0.0,
            "depth": -start_xyz[2],
            "alt": st.altitude,
            "rp": (0.0, 0.0),
        }
        if self.nav is not None:
            self._poll(st)
        self._trail = [st.position[:2].copy()]
        if self.record_path is not None and self._rec is None:
            self._open_recording()

    def _check_action(self, action) -> tuple[np.ndarray, bool]:
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape != (self.n_actuators,):
            raise ValueError(
                f"action must have shape ({self.n_actuators},), got {np.shape(action)}"
            )
        if not np.isfinite(a).all():
            raise ValueError(f"action must be finite (NaN/inf are rejected), got {a.tolist()}")
        c = np.minimum(np.maximum(a, -1.0), 1.0)  # finite: the same as np.clip, cheaper
        return c, bool((c != a).any())

    def _advance(self, u: np.ndarray):
        """Apply commands, step physics one control step, poll nav, update the nav pose."""
        self._check_open()
        self.vehicle.set_thruster_commands(u)
        self._last_u = u
        self.world.step(self.frame_skip)
        st = self.vehicle.state()
        if self.nav is None:  # ideal navigation: the true state
            roll, pitch, yaw = euler_from_wxyz(st.quat_wxyz)
            m = self._nav_meas
            m["v"] = st.velocity_body
            m["r"] = float(st.angular_velocity_body[2])
            m["depth"] = float(-st.position[2])
            m["alt"] = float(st.altitude)
            m["rp"] = (roll, pitch)
            self._nav_pose = np.array([st.position[0], st.position[1], yaw])
            self._trail.append(st.position[:2].copy())
            return st
        if isinstance(self.nav, NavBatch):
            self._advance_nav_batch(st)
            return st
        r = self.nav.poll(st)
        if r.dvl:
            m = r.dvl[-1]
            if m.valid:
                self._nav_meas["v"] = np.asarray(m.velocity_body, float)
            self._nav_meas["alt"] = float(m.altitude)
        if r.imu:
            self._nav_meas["r"] = float(r.imu[-1].gyro[2])
        if r.depth:
            self._nav_meas["depth"] = float(r.depth[-1].depth)
        if r.ahrs:
            self._nav_meas["rp"] = (float(r.ahrs[-1].roll), float(r.ahrs[-1].pitch))
        inc = self.nav.odometry(st.t)
        self._last_inc = inc
        self._nav_pose = apply_increment(self._nav_pose, inc.delta)
        self._trail.append(st.position[:2].copy())
        if len(self._trail) > 5000:
            self._trail = self._trail[-5000:]
        return st

    def _poll(self, st):
        """Poll the navigation (NavSuite or NavBatch) with the true state st."""
        if not isinstance(self.nav, NavBatch):
            return self.nav.poll(st)
        one = np.ones(1, bool)
        self.nav.poll(
            one, np.array([st.t]), st.quat_wxyz[None], st.velocity_body[None],
            st.angular_velocity_body[None], np.array([st.depth]), np.array([st.altitude]),
        )  # fmt: skip
        return None

    def _advance_nav_batch(self, st) -> None:
        """``_advance``'s navigation with a NavBatch of one: the same readings and pose."""
        self._poll(st)
        out, rep, m = self.nav.out[0], self.nav.reported[0], self._nav_meas
        if rep[1]:  # DVL ping
            if rep[2]:
                m["v"] = out[3:6].copy()
            m["alt"] = float(out[6])
        if rep[0]:
            m["r"] = float(out[2])
        if rep[3]:
            m["depth"] = float(out[7])
        if rep[4]:
            m["rp"] = (float(out[8]), float(out[9]))
        delta = self.nav.odometry(np.ones(1, bool), np.array([st.t]))[0]
        self._nav_pose = apply_increment(self._nav_pose, delta)
        self._trail.append(st.position[:2].copy())
        if len(self._trail) > 5000:
            self._trail = self._trail[-5000:]

    def nav_estimate(self) -> NavEstimate:
        m = self._nav_meas
        return NavEstimate(
            self._nav_pose.copy(), m["v"].copy(), m["r"], m["depth"], m["alt"], *m["rp"]
        )

    def true_info(self, st) -> dict:
        """Ground truth for info (never in the observation)."""
        return {
            "true_position": st.position.copy(),
            "true_yaw": euler_from_wxyz(st.quat_wxyz)[2],
            "true_velocity_body": st.velocity_body.copy(),
            "nav_position_error_m": float(np.linalg.norm(self._nav_pose[:2] - st.position[:2])),
            "time_s": st.t,
        }

    def _collided(self, st) -> bool:
        return bool(st.altitude < 0.3 or st.position[2] > -0.2)

    # ---------------------------------------------------------------- rendering ---------
    def _world_to_px(self, xy: np.ndarray) -> np.ndarray:
        s = self.render_size / self.arena_size
        xy = np.asarray(xy, float).reshape(-1, 2)
        return np.column_stack(
            [(xy[:, 0] + self.arena_size / 2) * s, (self.arena_size / 2 - xy[:, 1]) * s]
        ).astype(np.int32)

    def _base(self) -> np.ndarray:
        """Seabed depth shading and objects, drawn once (no OpenGL: numpy + cv2)."""
        if self._base_image is None:
            n = self.render_size
            g = (np.arange(n) + 0.5) / n * self.arena_size - self.arena_size / 2
            X, Y = np.meshgrid(g, -g)
            z = self.world.seabed_height(np.column_stack([X.ravel(), Y.ravel()])).reshape(n, n)
            t = (z - z.min()) / max(float(np.ptp(z)), 1e-6)
            img = np.empty((n, n, 3), np.uint8)
            img[..., 0] = (150 + 60 * t).astype(np.uint8)
            img[..., 1] = (130 + 50 * t).astype(np.uint8)
            img[..., 2] = (80 + 40 * t).astype(np.uint8)
            for o in self.world.objects:
                c, s_ = np.cos(o.yaw), np.sin(o.yaw)
                L, W = o.size[0] / 2, o.size[1] / 2
                corners = np.array([[L, W], [-L, W], [-L, -W], [L, -W]]) @ np.array(
                    [[c, s_], [-s_, c]]
                )
                cv2.fillPoly(img, [self._world_to_px(corners + o.position[:2])], (60, 60, 200))
            self._base_image = img
        return self._base_image.copy()

    def _draw_vehicle(self, img: np.ndarray, st) -> None:
        if len(self._trail) > 1:
            cv2.polylines(
                img, [self._world_to_px(np.array(self._trail))], False, (255, 255, 255), 1
            )
        yaw = euler_from_wxyz(st.quat_wxyz)[2]
        L = max(3.0, self.arena_size / 60)
        tri = np.array([[L, 0], [-L / 2, L / 2], [-L / 2, -L / 2]])
        c, s = np.cos(yaw), np.sin(yaw)
        pts = tri @ np.array([[c, s], [-s, c]]) + st.position[:2]
        cv2.fillPoly(img, [self._world_to_px(pts)], (255, 200, 0))
        cv2.circle(
            img,
            tuple(int(v) for v in self._world_to_px(self._nav_pose[:2])[0]),
            3,
            (0, 160, 255),
            -1,
        )

    def render(self):
        if self.render_mode != "rgb_array":
            return None
        return self._render_rgb()

    def _render_rgb(self) -> np.ndarray:
        img = self._base()
        self._draw_vehicle(img, self.vehicle.state())
        return img

    # ---------------------------------------------------------------- rerun -------------
    def _open_recording(self) -> None:
        from sim.viz import rerun_log as L

        self._rec = L.open_recording(self.record_path, application_id=f"undersea-{self.spec_id()}")
        L.log_annotations(self._rec)
        v, f, _ = self.world.static_mesh()
        L.log_seabed(self._rec, v, f)

        mesh = vehicle_body_mesh(self.world.model, self.world.data, self.vehicle.body_id)
        if mesh is not None:
            L.log_vehicle_mesh(
                self._rec, self.vehicle.name, mesh[0], mesh[1], vertex_colors=mesh[2]
            )
        if self.world.objects:
            L.log_objects(
                self._rec,
                [o.id for o in self.world.objects],
                [o.class_name for o in self.world.objects],
                np.array(
                    [
                        np.asarray(o.position) + np.array([0.0, 0.0, o.size[2] / 2])
                        for o in self.world.objects
                    ]
                ),
                np.array([o.size for o in self.world.objects]),
            )

    def _log_step(self, st, reward: float, extra: dict | None = None) -> None:
        if self._rec is None:
            return
        from sim.viz import rerun_log as L

        L.set_time(self._rec, st.t)
        L.log_vehicle_pose(self._rec, self.vehicle.name, st.position, st.quat_wxyz)
        L.log_scalars(self._rec, self.vehicle.name, {"reward": reward, **(extra or {})})

    def spec_id(self) -> str:
        return type(self).__name__

    def close(self) -> None:
        if self._rec is not None:
            from sim.viz import rerun_log as L

            L.close_recording(self._rec)
            self._rec = None
        self._closed = True
        super().close()
