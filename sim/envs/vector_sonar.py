"""undersea/SonarSurvey-v0 batched: N vehicles in one MuJoCo model, each with its own
side-scan sonar (``sim.envs.vector_base`` is the machinery and its docstring the why).

    venv = gymnasium.make_vec("undersea/SonarSurvey-v0", num_envs=16,
                              vectorization_mode="vector_entry_point")

Physics, truth and navigation of all N are one compiled call each (as the batched
WaypointNav); each vehicle then pings its sonar once per control step, as
``SonarSurveyEnv`` does. The N sonars share one Embree scene of the static world (the
seabed: one copy in memory instead of N) and cast against it only: the vehicles are
invisible to each other's sonar as to each other's physics, so each ping is the single
env's ping (the single env's sonar, alone in its world, has no moving body to test
either). Each ping is cast on its own: the side-scan's ray fan depends on its altitude
probe (``SideScanSonar._cast_ping``), and one Embree call for N fans would need the
sonar's internals split. Waterfall, coverage and rewards: per env, as ``SonarSurveyEnv``
(``sonar_survey.ping_footprint``).

Each sub-environment draws its reset as ``SonarSurveyEnv.reset`` does (start side,
point, heading, navigation seed, sonar seed, in that order), so with the same seeds and
actions every sub-env gives the observations, rewards and ends of a single
``SonarSurveyEnv`` (tests/sim/envs/test_vector_sonar.py). Autoreset: NEXT_STEP, as
``vector_base``. Truncation at ``max_episode_steps`` (registered 3000).

Observation: ``Dict(nav=(N, 13) float32, waterfall=(N, 32, 64) float32)``; action
(N, n_actuators); rewards and ``info`` terms: as ``SonarSurveyEnv`` (its docstring is the
manual); ``info`` holds arrays over the N envs.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from sim.envs.sonar_survey import (
    check_survey_args,
    ping_footprint,
    survey_sonar_config,
    survey_start,
)
from sim.envs.vector_base import VehicleBatchEnv
from sim.world import SonarWater

_REWARD_TERMS = (
    "reward_coverage",
    "reward_complete",
    "reward_effort",
    "reward_low_altitude",
    "reward_collision",
)


class SonarSurveyVectorEnv(VehicleBatchEnv):
    """N ``SonarSurveyEnv`` in one world; see the module docstring and SonarSurveyEnv."""

    def __init__(
        self,
        num_envs: int = 1,
        vehicle: str = "alister9",
        area_size: float = 60.0,
        target_coverage: float = 0.9,
        sonar: str = "deepeye680d",
        sonar_overrides: dict | None = None,
        cell_size: float = 2.0,
        arena_size: float = 160.0,
        water_depth: float = 25.0,
        control_dt: float = 0.1,
        physics_dt: float = 0.05,
        nav_sensors: bool = True,
        max_episode_steps: int | None = 3000,
        render_mode: str | None = None,
    ) -> None:
        from sim.sonar import SideScanSonar
        from sim.sonar.rays import EmbreeRays

        check_survey_args(area_size, target_coverage, arena_size)
        cfg = survey_sonar_config(sonar, sonar_overrides)
        super().__init__(
            num_envs, vehicle, arena_size, water_depth, control_dt, physics_dt,
            nav_sensors, max_episode_steps, render_mode,
        )  # fmt: skip
        n, w = self.num_envs, self.world
        self.area_size = float(area_size)
        self.cell_size = float(cell_size)
        self.target_coverage = float(target_coverage)
        self._n_cells = c = max(1, round(self.area_size / self.cell_size))
        rays = EmbreeRays(w.model, w.data, static_mesh=w.static_mesh())
        rays.mujoco = None  # the static scene only: no vehicle sees another
        water = SonarWater(w.water)
        self.sonars = []
        for h in self.vehicles:
            sites = (h.site_ids["sss_port"], h.site_ids["sss_starboard"])
            self.sonars.append(
                SideScanSonar(
                    cfg,
                    w.model,
                    w.data,
                    sites,
                    w.geom_object_id,
                    w.geom_reflectivity,
                    water,
                    backend=rays,
                )
            )
        self._log = cfg.acoustic.log_compression
        self._sonar_rngs = [np.random.default_rng(0) for _ in range(n)]
        self.covered = np.zeros((n, c, c), bool)
        self._n_covered = np.zeros(n, np.int64)
        self._wf = np.zeros((n, 32, 64), np.float32)
        self._done_bonus = np.zeros(n, bool)
        self.single_observation_space = gym.spaces.Dict(
            {
                "nav": gym.spaces.Box(-np.inf, np.inf, (13,), np.float32),
                "waterfall": gym.spaces.Box(0.0, 1.0, (32, 64), np.float32),
            }
        )
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, n)

    # ------------------------------------------------------------------ reset ---------
    def _reset_one(self, i: int, seed: int | None) -> None:
        """The draws and the state of ``SonarSurveyEnv.reset`` for env i."""
        rng = self._seed_rng(i, seed)
        start, yaw = survey_start(rng, self.area_size, self.water_depth)
        self._reset_vehicle(i, start, yaw)
        self._sonar_rngs[i] = np.random.default_rng(int(rng.integers(2**63)))
        self.sonars[i].clear_cache()
        self.covered[i] = False
        self._n_covered[i] = 0
        self._wf[i] = 0.0
        self._done_bonus[i] = False

    def reset(self, *, seed=None, options=None):
        """Reset all sub-envs; seed: an int (env i gets seed + i), a list of N ints or
        Nones, or None."""
        self._reset_all(seed)
        pos, _, vb, _, _, rpy = self._true()
        info = self._info(pos, rpy[:, 2], vb, np.zeros(self.num_envs, bool))
        info["coverage"] = self._coverage()
        return self._obs(), info

    # ------------------------------------------------------------------ step ----------
    def _ping(self, active: np.ndarray) -> np.ndarray:
        """Ping the sonars of the active envs: waterfall rows, coverage; new cells (N,)."""
        new = np.zeros(self.num_envs, np.int64)
        idx = np.flatnonzero(active)
        self._wf[idx, :-1] = self._wf[idx, 1:]
        d = self.world.data
        for i in idx:
            ping = self.sonars[i].ping(d, self._sonar_rngs[i])
            row, ij = ping_footprint(ping, self._log, self.area_size, self.cell_size, self._n_cells)
            self._wf[i, -1] = row
            if ij.size:
                cov = self.covered[i]
                cov[ij[:, 0], ij[:, 1]] = True
                c = int(np.count_nonzero(cov))
                new[i] = c - self._n_covered[i]
                self._n_covered[i] = c
        return new

    def _coverage(self) -> np.ndarray:
        return self._n_covered / self.covered[0].size

    def step(self, actions):
        u, clipped, resetting, pos, _, vb, _, alt, rpy = self._advance(actions)
        new = self._ping(~resetting)
        collided = (alt < 0.3) | (pos[:, 2] > -0.2)
        cov = self._coverage()
        reached = cov >= self.target_coverage
        terms = np.zeros((self.num_envs, 5))
        terms[:, 0] = new * self.cell_size**2 / 100.0
        terms[:, 1] = np.where(reached & ~self._done_bonus, 10.0, 0.0)
        terms[:, 2] = -0.01 * np.sum(u**2, axis=1)
        terms[:, 3] = np.where(alt < 3.0, -0.5, 0.0)
        terms[:, 4] = np.where(collided, -50.0, 0.0)
        self._done_bonus |= reached
        reward = (((terms[:, 0] + terms[:, 1]) + terms[:, 2]) + terms[:, 3]) + terms[:, 4]
        terminated = collided | reached
        truncated = self._truncated()
        info = self._info(pos, rpy[:, 2], vb, collided)
        info.update(zip(_REWARD_TERMS, terms.T))
        info["coverage"] = cov
        info["action_clipped"] = clipped
        self._autoreset(resetting, reward, terminated, truncated, terms)
        return self._obs(), reward, terminated, truncated, info

    def _obs(self) -> dict:
        m, p = self._meas, self._nav_pose
        o = np.zeros((self.num_envs, 13), np.float32)
        o[:, 0:2] = p[:, :2]
        o[:, 2], o[:, 3] = np.sin(p[:, 2]), np.cos(p[:, 2])
        o[:, 4:9] = m[:, 0:5]  # velocity, yaw rate, depth
        o[:, 9] = np.where(np.isfinite(m[:, 5]), m[:, 5], 0.0)
        o[:, 10:12] = m[:, 6:8]
        o[:, 12] = self._coverage()
        return {"nav": o, "waterfall": self._wf.copy()}
