"""undersea/WaypointNav-v0 batched: N vehicles in one MuJoCo model (``sim.envs.vector_base``
is the machinery and its docstring the why), one compiled physics call per control step
for all of them.

    venv = gymnasium.make_vec("undersea/WaypointNav-v0", num_envs=64,
                              vectorization_mode="vector_entry_point")

Each sub-environment draws its reset as ``WaypointNavEnv.reset`` does (yaw, navigation
seed, waypoints, in that order) and keeps its own waypoints and reward state. State,
altitudes, rewards, episode ends and the observation are compiled loops over all N
(``sim.envs.vector_kernel``); the observation is ``WaypointNavEnv._get_obs`` over N rows.
Each vehicle follows the same trajectory and sees the same observations as a
``WaypointNavEnv`` with the same seed and actions (tests/sim/envs/test_vector_nav.py).
Truncation at ``max_episode_steps`` (registered 3000).

Observation (N, 17), action (N, n_actuators), rewards and ``info`` terms: as
``WaypointNavEnv`` (its docstring is the manual); ``info`` holds arrays over the N envs.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from sim.envs import vector_kernel as VK
from sim.envs.vector_base import VehicleBatchEnv
from sim.envs.waypoint_nav import sample_waypoints

_REWARD_TERMS = (
    "reward_progress",
    "reward_waypoint",
    "reward_effort",
    "reward_low_altitude",
    "reward_collision",
)


class WaypointNavVectorEnv(VehicleBatchEnv):
    """N ``WaypointNavEnv`` in one world; see the module docstring and WaypointNavEnv."""

    def __init__(
        self,
        num_envs: int = 1,
        vehicle: str = "alister9",
        n_waypoints: int = 3,
        acceptance_radius: float = 4.0,
        arena_size: float = 200.0,
        water_depth: float = 30.0,
        control_dt: float = 0.1,
        physics_dt: float = 0.05,
        nav_sensors: bool = True,
        max_episode_steps: int | None = 3000,
        render_mode: str | None = None,
    ) -> None:
        if int(n_waypoints) < 1:
            raise ValueError(f"n_waypoints = {n_waypoints!r}; allowed: an integer >= 1")
        if not acceptance_radius > 0:
            raise ValueError(f"acceptance_radius = {acceptance_radius!r}; allowed: > 0 m")
        super().__init__(
            num_envs, vehicle, arena_size, water_depth, control_dt, physics_dt,
            nav_sensors, max_episode_steps, render_mode,
        )  # fmt: skip
        n = self.num_envs
        self.n_waypoints = int(n_waypoints)
        self.acceptance_radius = float(acceptance_radius)
        self._start = np.array([0.0, 0.0, -self.water_depth / 2])
        self.single_observation_space = gym.spaces.Box(-np.inf, np.inf, (17,), np.float32)
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, n)
        self.waypoints = np.zeros((n, self.n_waypoints, 3))
        self._k = np.zeros(n, dtype=np.int64)
        self._prev_dist = np.zeros(n)

    # ------------------------------------------------------------------ reset ---------
    def _reset_one(self, i: int, seed: int | None) -> None:
        """The draws and the state of ``WaypointNavEnv.reset`` for env i."""
        rng = self._seed_rng(i, seed)
        yaw = float(rng.uniform(-np.pi, np.pi))
        self._reset_vehicle(i, self._start, yaw)
        self.waypoints[i] = sample_waypoints(
            rng, self.n_waypoints, self.arena_size, self.water_depth
        )
        self._k[i] = 0
        pos = self.world.data.qpos[self._qadr[i, :3]]
        self._prev_dist[i] = float(np.linalg.norm(self.waypoints[i, 0] - pos))

    def reset(self, *, seed=None, options=None):
        """Reset all sub-envs; seed: an int (env i gets seed + i), a list of N ints or
        Nones, or None."""
        self._reset_all(seed)
        pos, _, vb, _, _, rpy = self._true()
        info = self._info(pos, rpy[:, 2], vb, np.zeros(self.num_envs, bool))
        info["waypoint_index"] = self._k.copy()
        return self._obs(), info

    # ------------------------------------------------------------------ step ----------
    def step(self, actions):
        n = self.num_envs
        u, clipped, resetting, pos, _, vb, _, alt, rpy = self._advance(actions)
        terms, reward, collided = np.empty((n, 5)), np.empty(n), np.empty(n, bool)
        VK.rewards(
            pos, alt, u, self.waypoints, self._k, self._prev_dist, self.acceptance_radius,
            terms, reward, collided,
        )  # fmt: skip
        terminated, truncated, nav_err = np.empty(n, bool), np.empty(n, bool), np.empty(n)
        max_steps = -1 if self.max_episode_steps is None else self.max_episode_steps
        VK.ends(
            collided, self._k, self.n_waypoints, self._elapsed, max_steps, pos,
            self._nav_pose, terminated, truncated, nav_err,
        )  # fmt: skip
        info = self._info(pos, rpy[:, 2], vb, collided, nav_err)
        info["waypoint_index"] = self._k.copy()
        info.update(zip(_REWARD_TERMS, terms.T))
        info["action_clipped"] = clipped
        self._autoreset(resetting, reward, terminated, truncated, terms)
        return self._obs(), reward, terminated, truncated, info

    def _obs(self) -> np.ndarray:
        o = np.empty((self.num_envs, 17), np.float32)
        VK.observe(self._nav_pose, self.waypoints, self._k, self._meas, o)
        rel = np.arctan2(o[:, 1], o[:, 0])
        np.sin(rel, out=o[:, 4])
        np.cos(rel, out=o[:, 5])
        return o
