"""Tim Bailey's 2-D SLAM simulator (ACFR "ekfslam_v1"/"fastslam" toolbox), reimplemented.

A bicycle (Ackermann) vehicle drives at constant speed and steers towards waypoints
(``compute_steering``: rate- and angle-limited), a range-bearing sensor sees landmarks in
its forward half-disc. The true path is noise-free (the same every run); the filters get
noisy controls. Hand-written: this *is* the reference's simulator, no library has it.

Parameters and units: :class:`Sim2DConfig`. World frame x east, y north, heading phi
counter-clockwise from x, radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

__all__ = ["Sim2DConfig", "TruePath", "compute_steering", "true_path", "vehicle_step"]


@dataclass(frozen=True)
class Sim2DConfig:
    """Simulator parameters (Bailey's ``configfile.m``; thesis ch. 6).

    speed_mps : V, 3 m/s.  wheelbase_m : 4 m.
    max_steer_rad : 30°.  steer_rate_radps : 20°/s.
    sigma_v_mps : 0.3 m/s, sigma_steer_rad : 3° (control noise, also the filter's Q).
    max_range_m : 30 m (forward half-disc).  sigma_r_m : 0.1 m, sigma_b_rad : 1°.
    dt_s : control interval, 0.025 s (the thesis used 0.0125 s).
    dt_observe_s : observation interval, default ``8 * dt_s``; a scan happens when the
        accumulated ``dtsum >= dt_observe_s`` (floating point makes that every 9 steps).
    at_waypoint_m : 1 m switching distance.  n_loops : passes through the waypoint list.
    unbiased_odometry : scale the odometry increments by ``exp(σ_G² / 2)`` (and their
        covariance by its square). Bailey's simulator (default False) integrates
        ``V dt cos(G + ε)`` whose mean is ``V dt cos(G) exp(-σ_G² / 2)``: its odometry is
        0.14 % short per step, a bias of the size of the along-track σ after a few hundred
        metres (measured: along-track normalized error 1.5 instead of 1 in pure dead
        reckoning), which no estimator can see. True makes it an unbiased sensor.
    """

    speed_mps: float = 3.0
    wheelbase_m: float = 4.0
    max_steer_rad: float = math.radians(30.0)
    steer_rate_radps: float = math.radians(20.0)
    sigma_v_mps: float = 0.3
    sigma_steer_rad: float = math.radians(3.0)
    max_range_m: float = 30.0
    sigma_r_m: float = 0.1
    sigma_b_rad: float = math.radians(1.0)
    dt_s: float = 0.025
    dt_observe_s: float | None = None
    at_waypoint_m: float = 1.0
    n_loops: int = 2
    unbiased_odometry: bool = False
    _dt_obs: float = field(init=False, repr=False, compare=False, default=0.0)

    def __post_init__(self) -> None:
        for name in (
            "speed_mps",
            "wheelbase_m",
            "max_steer_rad",
            "steer_rate_radps",
            "max_range_m",
            "dt_s",
            "at_waypoint_m",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"Sim2DConfig.{name} must be finite and > 0, got {v}")
        for name in ("sigma_v_mps", "sigma_steer_rad", "sigma_r_m", "sigma_b_rad"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"Sim2DConfig.{name} must be finite and >= 0, got {v}")
        if self.n_loops < 1:
            raise ValueError(f"Sim2DConfig.n_loops must be >= 1, got {self.n_loops}")
        dto = 8 * self.dt_s if self.dt_observe_s is None else self.dt_observe_s
        if not (math.isfinite(dto) and dto > 0):
            raise ValueError(f"Sim2DConfig.dt_observe_s must be > 0, got {dto}")
        object.__setattr__(self, "_dt_obs", float(dto))

    @property
    def dt_observe(self) -> float:
        return self._dt_obs

    @property
    def Q(self) -> np.ndarray:
        """Control noise covariance diag(σ_v², σ_steer²)."""
        return np.diag([self.sigma_v_mps**2, self.sigma_steer_rad**2])

    @property
    def R(self) -> np.ndarray:
        """Observation noise covariance diag(σ_r², σ_b²)."""
        return np.diag([self.sigma_r_m**2, self.sigma_b_rad**2])


def _pi_to_pi(a: float) -> float:
    a = math.fmod(a, 2.0 * math.pi)
    if a > math.pi:
        a -= 2.0 * math.pi
    elif a < -math.pi:
        a += 2.0 * math.pi
    return a


def vehicle_step(x, V, G, wheelbase: float, dt: float) -> np.ndarray:
    """Bicycle model, vectorized over leading dims: ``x (..., 3)``, speed ``V`` m/s and
    steer ``G`` rad broadcast against ``x[..., 0]``. Returns the pose after ``dt``."""
    x = np.asarray(x, dtype=float)
    out = np.empty(np.broadcast_shapes(x.shape, (*np.shape(V), 1), (*np.shape(G), 1)))
    out[..., 0] = x[..., 0] + V * dt * np.cos(G + x[..., 2])
    out[..., 1] = x[..., 1] + V * dt * np.sin(G + x[..., 2])
    h = x[..., 2] + V * dt * np.sin(G) / wheelbase
    out[..., 2] = np.mod(h + np.pi, 2 * np.pi) - np.pi
    return out


def compute_steering(
    x: tuple[float, float, float],
    waypoints: np.ndarray,
    iwp: int,
    G: float,
    cfg: Sim2DConfig,
) -> tuple[float, int]:
    """Bailey's ``compute_steering`` (0-based waypoint index; -1 = final waypoint reached).

    Switch to the next waypoint within ``at_waypoint_m``; turn the steer angle towards the
    current waypoint by at most ``steer_rate * dt``, limited to ``±max_steer``. When the
    final waypoint is reached the steer angle is left unchanged.
    """
    cx, cy = waypoints[iwp]
    if (cx - x[0]) ** 2 + (cy - x[1]) ** 2 < cfg.at_waypoint_m**2:
        iwp += 1
        if iwp >= len(waypoints):
            return G, -1
        cx, cy = waypoints[iwp]
    dG = _pi_to_pi(math.atan2(cy - x[1], cx - x[0]) - x[2] - G)
    max_d = cfg.steer_rate_radps * cfg.dt_s
    if abs(dG) > max_d:
        dG = math.copysign(max_d, dG)
    G = G + dG
    if abs(G) > cfg.max_steer_rad:
        G = math.copysign(cfg.max_steer_rad, G)
    return G, iwp


@dataclass(frozen=True)
class TruePath:
    """The noise-free path: ``poses (T + 1, 3)`` (pose 0 is the start), ``steer (T,)``
    true steer angle of each control step, ``scan_steps (S,)`` index t of the steps after
    which a scan is taken (the scan sees ``poses[t + 1]``)."""

    poses: np.ndarray
    steer: np.ndarray
    scan_steps: np.ndarray

    @property
    def n_steps(self) -> int:
        return self.steer.size


def true_path(waypoints, cfg: Sim2DConfig, x0=(0.0, 0.0, 0.0)) -> TruePath:
    """Drive the noise-free vehicle through the waypoints ``cfg.n_loops`` times (Bailey's
    main loop: steer, move; a scan when ``dtsum >= dt_observe``). Deterministic."""
    wp = np.asarray(waypoints, dtype=float)
    if wp.ndim != 2 or wp.shape[1] != 2 or len(wp) == 0:
        raise ValueError(f"waypoints must have shape (m >= 1, 2), got {wp.shape}")
    return _true_path_cached(tuple(map(tuple, wp.tolist())), cfg, tuple(float(v) for v in x0))


@lru_cache(maxsize=16)
def _true_path_cached(wp_t, cfg: Sim2DConfig, x0) -> TruePath:
    wp = np.asarray(wp_t)
    x, y, phi = x0
    G = 0.0
    iwp = 0
    loops = cfg.n_loops
    V, dt, WB = cfg.speed_mps, cfg.dt_s, cfg.wheelbase_m
    dto = cfg.dt_observe
    poses = [(x, y, phi)]
    steer: list[float] = []
    scans: list[int] = []
    dtsum = 0.0
    t = 0
    max_steps = 50_000_000
    while iwp != -1:  # one control step per iteration, as Bailey's `while iwp ~= 0`
        G, iwp = compute_steering((x, y, phi), wp, iwp, G, cfg)
        if iwp == -1 and loops > 1:
            iwp = 0
            loops -= 1
        x, y, phi = (
            x + V * dt * math.cos(G + phi),
            y + V * dt * math.sin(G + phi),
            _pi_to_pi(phi + V * dt * math.sin(G) / WB),
        )
        poses.append((x, y, phi))
        steer.append(G)
        dtsum += dt
        if dtsum >= dto:
            dtsum = 0.0
            scans.append(t)
        t += 1
        if t > max_steps:
            raise ValueError("the vehicle never reaches its waypoints (check waypoints/config)")
    arrs = (np.array(poses), np.array(steer), np.array(scans, dtype=np.intp))
    for a in arrs:
        a.setflags(write=False)
    return TruePath(*arrs)
