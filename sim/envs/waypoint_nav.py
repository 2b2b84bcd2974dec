"""undersea/WaypointNav-v0."""

from __future__ import annotations

import cv2
import gymnasium as gym
import numpy as np

from sim.envs.base import UnderseaEnv


def sample_waypoints(
    rng: np.random.Generator, n: int, arena_size: float, water_depth: float
) -> np.ndarray:
    """(n, 3) waypoints, world m: each 20-60 m horizontally from the previous one (the
    first from the origin), inside the arena less a 10 m margin, depth in
    [5, water_depth - 8] m (at least 5.5 m of range), drawn from rng in a fixed order."""
    half = arena_size / 2 - 10.0
    wps = []
    p = np.zeros(2)
    for _ in range(n):
        for _ in range(100):
            ang = rng.uniform(-np.pi, np.pi)
            d = rng.uniform(20.0, 60.0)
            q = p + d * np.array([np.cos(ang), np.sin(ang)])
            if np.all(np.abs(q) < half):
                break
        p = np.clip(q, -half, half)
        z = -rng.uniform(5.0, max(5.5, water_depth - 8.0))
        wps.append([p[0], p[1], z])
    return np.array(wps)


class WaypointNavEnv(UnderseaEnv):
    """Reach a sequence of 3-D waypoints with one SWARMs vehicle, from navigation sensors.

    ## Description
    A vehicle (Alister 9 torpedo AUV by default; IXN, Naiad, SAGA or RexROV) starts at
    mid-water over a flat seabed and must pass within ``acceptance_radius`` of
    ``n_waypoints`` waypoints in order. Physics: MuJoCo with the Fossen-style
    hydrodynamics of sim.world (buoyancy, added mass, damping, currents), actuator lag.
    The agent sees only what the vehicle's own navigation knows: a DVL + gyro dead-
    reckoned position (which drifts), DVL velocity, AHRS attitude, pressure depth and DVL
    altitude (sim.navigation: tactical-grade IMU, default presets for the other sensors).

    ## Action Space
    ``Box(-1, 1, (n_actuators,), float32)``: normalized commands of the vehicle's actuators
    in ``env.unwrapped.vehicle.thruster_names`` order (Alister 9: stern thruster, rudder fin
    pair, elevator fin pair; ROVs: their vectored thrusters), held for one control step
    (``control_dt`` = 0.1 s). Non-finite actions raise ``ValueError``; finite values
    outside [-1, 1] are clipped (``info["action_clipped"]``).

    ## Observation Space
    ``Box(-inf, inf, (17,), float32)``:

    | idx | observation | unit |
    | --- | --- | --- |
    | 0-2 | current waypoint in the vehicle's heading frame from the nav pose (forward, port, up) | m |
    | 3 | horizontal distance to the waypoint | m |
    | 4-5 | sin, cos of the bearing to the waypoint relative to the heading | - |
    | 6-8 | DVL velocity over ground, body frame (surge, sway, heave) | m/s |
    | 9 | yaw rate (gyro z) | rad/s |
    | 10 | depth (pressure sensor) | m |
    | 11 | altitude above the seabed (DVL) | m |
    | 12-13 | roll, pitch (AHRS) | rad |
    | 14-15 | sin, cos of the nav heading (yaw, counter-clockwise from east) | - |
    | 16 | waypoints remaining | count |

    ## Rewards
    ``progress`` (decrease of the true 3-D distance to the current waypoint, m) +
    ``10`` per waypoint reached - ``0.01 * |u|²`` (effort) - ``1`` per step below 2 m
    altitude - ``50`` on collision. ``info`` holds each term and the true state.

    ## Starting State
    Vehicle at (0, 0) at half the water depth with a uniformly random heading; waypoints
    uniformly random at 20-60 m horizontal distance from the previous one, depth in
    [5 m, water_depth - 8 m], inside the arena; all from the reset seed.

    ## Episode End
    Terminated when every waypoint is reached or on collision (altitude < 0.3 m or
    broaching, z > -0.2 m). Truncated by the TimeLimit wrapper at ``max_episode_steps``
    (registered: 3000 steps = 300 s).

    ## Arguments
    ``gymnasium.make("undersea/WaypointNav-v0", vehicle="alister9", n_waypoints=3,
    acceptance_radius=4.0, arena_size=200.0, water_depth=30.0, control_dt=0.1,
    physics_dt=0.05, render_mode=None, record_path=None, nav_sensors=True)``.
    ``nav_sensors=False`` replaces the sensor suite by ideal navigation (the true state):
    faster, for curriculum or debugging. ``render_mode="rgb_array"``
    gives a top-down map (numpy + OpenCV, no OpenGL). ``record_path`` writes a rerun
    recording (.rrd) of every step. ``physics_dt`` 0.05 s is validated against 0.01 s
    in tests/sim/envs (same trajectory to 0.5 m over 20 s).

    ## Version History
    v0: first version.
    """

    def __init__(
        self,
        vehicle: str = "alister9",
        n_waypoints: int = 3,
        acceptance_radius: float = 4.0,
        arena_size: float = 200.0,
        water_depth: float = 30.0,
        control_dt: float = 0.1,
        physics_dt: float = 0.05,
        render_mode: str | None = None,
        record_path: str | None = None,
        nav_sensors: bool = True,
    ) -> None:
        if int(n_waypoints) < 1:
            raise ValueError(f"n_waypoints = {n_waypoints!r}; allowed: an integer >= 1")
        if not acceptance_radius > 0:
            raise ValueError(f"acceptance_radius = {acceptance_radius!r}; allowed: > 0 m")
        super().__init__(
            vehicle,
            arena_size=arena_size,
            water_depth=water_depth,
            control_dt=control_dt,
            physics_dt=physics_dt,
            render_mode=render_mode,
            record_path=record_path,
            nav_sensors=nav_sensors,
        )
        self.n_waypoints = int(n_waypoints)
        self.acceptance_radius = float(acceptance_radius)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (17,), np.float32)
        self.waypoints = np.zeros((self.n_waypoints, 3))
        self._k = 0
        self._prev_dist = 0.0

    def _sample_waypoints(self) -> np.ndarray:
        return sample_waypoints(self.np_random, self.n_waypoints, self.arena_size, self.water_depth)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        yaw = float(self.np_random.uniform(-np.pi, np.pi))
        self._reset_world(np.array([0.0, 0.0, -self.water_depth / 2]), yaw)
        self.waypoints = self._sample_waypoints()
        self._k = 0
        st = self.vehicle.state()
        self._prev_dist = float(np.linalg.norm(self.waypoints[0] - st.position))
        info = {**self.true_info(st), "waypoint_index": 0, "waypoints": self.waypoints.copy()}
        return self._get_obs(), info

    def _get_obs(self) -> np.ndarray:
        """The observation table above, in scalars (the batch: ``vector_kernel.observe``)."""
        nav = self.nav_estimate()
        o = np.zeros(17, np.float32)
        x, y, yaw = nav.pose
        wp = self.waypoints[min(self._k, self.n_waypoints - 1)]
        dx, dy = wp[0] - x, wp[1] - y
        c, s = np.cos(yaw), np.sin(yaw)
        o[0] = c * dx + s * dy
        o[1] = -s * dx + c * dy
        o[2] = wp[2] - (-nav.depth)
        o[3] = np.hypot(dx, dy)
        rel = np.arctan2(o[1], o[0])
        o[4], o[5] = np.sin(rel), np.cos(rel)
        o[6:9] = nav.velocity
        o[9] = nav.yaw_rate
        o[10] = nav.depth
        o[11] = nav.altitude if np.isfinite(nav.altitude) else 0.0
        o[12], o[13] = nav.roll, nav.pitch
        o[14], o[15] = s, c
        o[16] = self.n_waypoints - self._k
        return o

    def _get_rew(self, st, collided: bool) -> tuple[float, dict]:
        wp = self.waypoints[min(self._k, self.n_waypoints - 1)]
        dist = float(np.linalg.norm(wp - st.position))
        progress = self._prev_dist - dist
        reached = dist < self.acceptance_radius
        effort = 0.01 * float(np.sum(self._last_u**2))
        low = 1.0 if st.altitude < 2.0 else 0.0
        terms = {
            "reward_progress": progress,
            "reward_waypoint": 10.0 if reached else 0.0,
            "reward_effort": -effort,
            "reward_low_altitude": -low,
            "reward_collision": -50.0 if collided else 0.0,
        }
        if reached:
            self._k += 1
            if self._k < self.n_waypoints:
                dist = float(np.linalg.norm(self.waypoints[self._k] - st.position))
        self._prev_dist = dist
        return float(sum(terms.values())), terms

    def step(self, action):
        u, clipped = self._check_action(action)
        st = self._advance(u)
        collided = self._collided(st)
        reward, terms = self._get_rew(st, collided)
        terminated = collided or self._k >= self.n_waypoints
        info = {
            **self.true_info(st),
            **terms,
            "action_clipped": clipped,
            "waypoint_index": self._k,
            "collided": collided,
        }
        self._log_step(st, reward, {"distance_m": self._prev_dist})
        return self._get_obs(), reward, terminated, False, info

    def _render_rgb(self) -> np.ndarray:
        img = self._base()
        for i, wp in enumerate(self.waypoints):
            col = (0, 255, 0) if i >= self._k else (90, 90, 90)
            p = self._world_to_px(wp[:2])[0]
            r = max(2, int(self.acceptance_radius * self.render_size / self.arena_size))
            cv2.circle(img, (int(p[0]), int(p[1])), r, col, 2)
        self._draw_vehicle(img, self.vehicle.state())
        return img
