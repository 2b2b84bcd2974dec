"""undersea/SonarSurvey-v0."""

from __future__ import annotations

import cv2
import gymnasium as gym
import numpy as np

from sim.envs.base import UnderseaEnv
from sim.world import SonarWater

#: fast side-scan settings for learning: 128 samples per side over 30 m, one ray along track
FAST_SSS = {
    "max_range": 30.0,
    "samples_per_side": 128,
    "rays_along_track": 1,
    "ray_oversampling": 1.0,
}


def survey_sonar_config(sonar: str, sonar_overrides: dict | None):
    """The side-scan configuration of a survey env: preset ``sonar`` with ``FAST_SSS`` and
    then ``sonar_overrides`` applied; ValueError naming ``sonar`` if not a side-scan."""
    from sim.sonar import preset
    from sim.sonar.config import SSSConfig

    ov = dict(FAST_SSS)
    ov.update(sonar_overrides or {})
    cfg = preset(sonar, **ov)
    if not isinstance(cfg, SSSConfig):
        raise ValueError(
            f"sonar = {sonar!r}; allowed: a side-scan preset (deepeye340d, deepeye680d, klein3500)"
        )
    return cfg


def check_survey_args(area_size: float, target_coverage: float, arena_size: float) -> None:
    if not 0 < target_coverage <= 1:
        raise ValueError(f"target_coverage = {target_coverage!r}; allowed: (0, 1]")
    if not 0 < area_size < arena_size - 20:
        raise ValueError(f"area_size = {area_size!r}; allowed: (0, arena_size - 20) m")


def survey_start(
    rng: np.random.Generator, area_size: float, water_depth: float
) -> tuple[np.ndarray, float]:
    """Start position (3,) world m and heading rad of a survey: a random point on the
    area's boundary at 10 m altitude, heading into the area +/- 45 deg (drawn from rng:
    the side, the point along it, the heading offset)."""
    half = area_size / 2
    side = int(rng.integers(4))
    t = float(rng.uniform(-half, half))
    p, into = [
        (np.array([-half, t]), 0.0),
        (np.array([half, t]), np.pi),
        (np.array([t, -half]), np.pi / 2),
        (np.array([t, half]), -np.pi / 2),
    ][side]
    yaw = into + float(rng.uniform(-np.pi / 4, np.pi / 4))
    return np.array([p[0], p[1], -(water_depth - 10.0)]), yaw


def ping_footprint(
    ping, log_compression: bool, area_size: float, cell_size: float, n_cells: int
) -> tuple[np.ndarray, np.ndarray]:
    """A ping's waterfall row (64,) float32 in [0, 1] (the display intensity downsampled
    to 64 columns) and the (row, col) indices (k, 2) of the area's cells its samples land
    on outside the nadir band (ground range >= half the altitude)."""
    x = np.clip(ping.intensity.astype(np.float32), 0.0, None)
    if not log_compression:
        x = x / max(float(x.max()), 1e-30)
    row = np.clip(x[: (x.size // 64) * 64].reshape(64, -1).mean(axis=1), 0.0, 1.0)
    ok = ping.labels >= 0
    if not np.any(ok):
        return row, np.zeros((0, 2), np.int64)
    hp = ping.hit_position[ok]
    sr = ping.slant_range[ok]
    alt = ping.altitude if np.isfinite(ping.altitude) else 0.0
    g2 = sr**2 - alt**2
    hp = hp[g2 >= (0.5 * alt) ** 2]
    half = area_size / 2
    ij = np.floor((hp[:, :2] + half) / cell_size).astype(np.int64)
    ij = ij[np.all((ij >= 0) & (ij < n_cells), axis=1)]
    return row, ij[:, ::-1]


class SonarSurveyEnv(UnderseaEnv):
    """Cover a rectangular survey area with the side-scan sonar.

    ## Description
    A vehicle (Alister 9 by default) carries a side-scan sonar (DeepEye 680D preset with
    the fast settings ``FAST_SSS``: 128 samples per side over 30 m; any preset and override
    via ``sonar`` / ``sonar_overrides``) that pings once per control step (ray-cast
    physics-based echoes, sim.sonar). Seabed cells of the survey area count as covered
    when a sample of a ping lands on them outside the nadir band (ground range >= half the
    altitude). The agent must cover the area while holding a useful altitude.

    ## Action Space
    ``Box(-1, 1, (n_actuators,), float32)``: normalized actuator commands (see
    ``env.unwrapped.vehicle.thruster_names``), held for one control step (0.1 s).
    Non-finite actions raise ``ValueError``; out-of-range values are clipped
    (``info["action_clipped"]``).

    ## Observation Space
    ``Dict``:

    * ``"nav"``: ``Box(-inf, inf, (13,), float32)`` - [0-1] nav position relative to the
      area centre (m, dead-reckoned); [2-3] sin, cos of the nav heading; [4-6] DVL
      velocity (m/s, body); [7] yaw rate (rad/s); [8] depth (m); [9] altitude (m);
      [10-11] roll, pitch (rad); [12] covered fraction of the area (0-1).
    * ``"waterfall"``: ``Box(0, 1, (32, 64), float32)`` - the last 32 pings (row 0 the
      oldest), each downsampled to 64 columns (port left, nadir centre, starboard
      right), the sonar's log-compressed display intensity.

    ## Rewards
    ``coverage``: newly covered area / 100 m² + ``10`` once ``target_coverage`` is
    reached - ``0.01 * |u|²`` - ``0.5`` per step below 3 m altitude - ``50`` on collision.
    Terms in ``info``.

    ## Starting State
    Vehicle at a random point on the area's boundary at 10 m altitude, heading into the
    area +/- 45 deg (from the reset seed).

    ## Episode End
    Terminated when ``target_coverage`` (0.9) of the area is covered or on collision;
    truncated at ``max_episode_steps`` (registered: 3000 = 300 s).

    ## Arguments
    ``gymnasium.make("undersea/SonarSurvey-v0", vehicle="alister9", area_size=60.0,
    target_coverage=0.9, sonar="deepeye680d", sonar_overrides=None, cell_size=2.0,
    arena_size=160.0, water_depth=25.0, render_mode=None, record_path=None,
    nav_sensors=True)``. ``render_mode="rgb_array"``: top-down map with coverage and the
    waterfall inset (numpy + OpenCV). ``record_path``: rerun recording with the waterfall.

    ## Version History
    v0: first version.
    """

    def __init__(
        self,
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
        render_mode: str | None = None,
        record_path: str | None = None,
        nav_sensors: bool = True,
    ) -> None:
        from sim.sonar import SideScanSonar

        check_survey_args(area_size, target_coverage, arena_size)
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
        cfg = survey_sonar_config(sonar, sonar_overrides)
        w = self.world
        h = self.vehicle
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
        self.area_size = float(area_size)
        self.cell_size = float(cell_size)
        self.target_coverage = float(target_coverage)
        n = max(1, round(self.area_size / self.cell_size))
        self._n_cells = n
        self.covered = np.zeros((n, n), bool)
        self.observation_space = gym.spaces.Dict(
            {
                "nav": gym.spaces.Box(-np.inf, np.inf, (13,), np.float32),
                "waterfall": gym.spaces.Box(0.0, 1.0, (32, 64), np.float32),
            }
        )
        self._wf = np.zeros((32, 64), np.float32)
        self._sonar_rng = np.random.default_rng(0)
        self._done_bonus = False

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        rng = self.np_random
        start, yaw = survey_start(rng, self.area_size, self.water_depth)
        self._reset_world(start, yaw)
        self._sonar_rng = np.random.default_rng(int(rng.integers(2**63)))
        self.sonar.clear_cache()
        self.covered[:] = False
        self._wf[:] = 0.0
        self._done_bonus = False
        st = self.vehicle.state()
        return self._get_obs(), {**self.true_info(st), "coverage": 0.0}

    def _ping(self) -> int:
        """Ping, push the downsampled row into the waterfall, mark coverage; new cells."""
        ping = self.sonar.ping(self.world.data, self._sonar_rng)
        row, ij = ping_footprint(
            ping, self.sonar.config.acoustic.log_compression, self.area_size, self.cell_size,
            self._n_cells,
        )  # fmt: skip
        self._wf = np.roll(self._wf, -1, axis=0)
        self._wf[-1] = row
        self._last_ping = ping
        if ij.size == 0:
            return 0
        before = int(self.covered.sum())
        self.covered[ij[:, 0], ij[:, 1]] = True
        return int(self.covered.sum()) - before

    @property
    def coverage(self) -> float:
        return float(self.covered.mean())

    def _get_obs(self) -> dict:
        nav = self.nav_estimate()
        o = np.zeros(13, np.float32)
        o[0:2] = nav.pose[:2]
        o[2], o[3] = np.sin(nav.pose[2]), np.cos(nav.pose[2])
        o[4:7] = nav.velocity
        o[7] = nav.yaw_rate
        o[8] = nav.depth
        o[9] = nav.altitude if np.isfinite(nav.altitude) else 0.0
        o[10], o[11] = nav.roll, nav.pitch
        o[12] = self.coverage
        return {"nav": o, "waterfall": self._wf.copy()}

    def step(self, action):
        u, clipped = self._check_action(action)
        st = self._advance(u)
        new = self._ping()
        collided = self._collided(st)
        cov = self.coverage
        reached = cov >= self.target_coverage
        terms = {
            "reward_coverage": new * self.cell_size**2 / 100.0,
            "reward_complete": 10.0 if reached and not self._done_bonus else 0.0,
            "reward_effort": -0.01 * float(np.sum(u**2)),
            "reward_low_altitude": -0.5 if st.altitude < 3.0 else 0.0,
            "reward_collision": -50.0 if collided else 0.0,
        }
        self._done_bonus = self._done_bonus or reached
        reward = float(sum(terms.values()))
        info = {
            **self.true_info(st),
            **terms,
            "coverage": cov,
            "action_clipped": clipped,
            "collided": collided,
        }
        if self._rec is not None:
            from sim.viz import rerun_log as L

            self._log_step(st, reward, {"coverage": cov})
            L.log_sonar_image(self._rec, self.vehicle.name, "sss", self._wf, already_display=False)
        return self._get_obs(), reward, bool(collided or reached), False, info

    def _render_rgb(self) -> np.ndarray:
        img = self._base()
        half = self.area_size / 2
        n = self._n_cells
        # coverage overlay: cells drawn as green tint inside the area rectangle
        p0 = self._world_to_px(np.array([-half, half]))[0]
        p1 = self._world_to_px(np.array([half, -half]))[0]
        w, h = max(1, p1[0] - p0[0]), max(1, p1[1] - p0[1])
        cov = cv2.resize(
            self.covered[::-1].astype(np.uint8) * 255, (w, h), interpolation=cv2.INTER_NEAREST
        )
        x0, y0 = max(p0[0], 0), max(p0[1], 0)
        sub = img[y0 : y0 + h, x0 : x0 + w]
        cm = cov[: sub.shape[0], : sub.shape[1]] > 0
        sub[cm] = (0.5 * sub[cm] + 0.5 * np.array([60, 200, 60])).astype(np.uint8)
        cv2.rectangle(img, tuple(int(v) for v in p0), tuple(int(v) for v in p1), (255, 255, 255), 1)
        del n
        self._draw_vehicle(img, self.vehicle.state())
        wf = (np.clip(self._wf, 0, 1) * 255).astype(np.uint8)
        wf = cv2.resize(wf, (128, 64), interpolation=cv2.INTER_NEAREST)
        img[4:68, -132:-4] = np.repeat(wf[..., None], 3, axis=2)
        return img


__all__ = ["FAST_SSS", "SonarSurveyEnv", "ping_footprint", "survey_sonar_config", "survey_start"]
