"""Navigation sensors: IMU, DVL, pressure depth, compass/AHRS, GPS.

Each sensor follows the dm_control observable pattern: a frozen config with an update
rate (Hz), a delivery delay (s) and a noise model, and a stateful sensor object that is
``poll``-ed once per control tick with the true :class:`sim.state.VehicleState`. The sensor
samples the true state when its update interval has elapsed and releases each
measurement ``delay_s`` after its acquisition time. Every random draw comes from the
``numpy.random.Generator`` passed to the sensor.

Frames (ARCHITECTURE.md): world x east, y north, z up; body x forward, y port, z up.
Angles in rad; yaw counter-clockwise from east (not a compass bearing from north).

Simplifications, stated: sensors sit at the body origin (no lever arm: the IMU does not
see centripetal terms of an offset mounting, the DVL does not see ``omega x r``); a sample
is taken from the state at the control tick on which it falls due, so a sensor rate
above the control rate is clipped to the control rate.

The configs (rates, delays, error magnitudes, presets) live in sim.navigation.sensor_config
and are re-exported here. The noise models are the standard ones of inertial-navigation
practice (white noise given as a spectral density plus a bias random walk for the IMU,
IEEE Std 952 style); no library provides them for a simulated state, so they are written
here.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np

from sim.frames import matrix_from_rotvec, rotvec_from_matrix
from sim.navigation.sensor_config import (
    AHRSConfig,
    DepthConfig,
    DVLConfig,
    GPSConfig,
    IMUConfig,
)
from sim.state import VehicleState

__all__ = [
    "AHRS",
    "DVL",
    "GPS",
    "IMU",
    "AHRSConfig",
    "AHRSMeasurement",
    "DVLConfig",
    "DVLMeasurement",
    "DepthConfig",
    "DepthMeasurement",
    "DepthSensor",
    "GPSConfig",
    "GPSMeasurement",
    "IMUConfig",
    "IMUMeasurement",
    "NavSensor",
]


# --------------------------------------------------------------------------- measurements


@dataclass(frozen=True)
class IMUMeasurement:
    """t: acquisition time, s. gyro (3,) rad/s and specific force (3,) m/s², body frame.
    The specific force includes gravity: a level vehicle at rest reads (0, 0, +g)."""

    t: float
    gyro: np.ndarray
    specific_force: np.ndarray


@dataclass(frozen=True)
class DVLMeasurement:
    """t: acquisition time, s. ``velocity_body`` (3,) m/s over ground, body frame, or None
    without bottom lock (``valid`` False). ``altitude`` is the true altitude at the ping.
    ``t_start``: start of the averaging window of an averaged velocity (the previous
    ping), s; None for an instantaneous sample."""

    t: float
    velocity_body: np.ndarray | None
    valid: bool
    altitude: float
    t_start: float | None = None


@dataclass(frozen=True)
class DepthMeasurement:
    """t: acquisition time, s. depth: m, positive down."""

    t: float
    depth: float


@dataclass(frozen=True)
class AHRSMeasurement:
    """t: acquisition time, s. roll, pitch, yaw in rad (yaw CCW from east, wrapped)."""

    t: float
    roll: float
    pitch: float
    yaw: float


@dataclass(frozen=True)
class GPSMeasurement:
    """t: acquisition time, s. position_xy (2,) world m, or None when submerged."""

    t: float
    position_xy: np.ndarray | None
    valid: bool


# --------------------------------------------------------------------------- sensors

C = TypeVar("C")
M = TypeVar("M")


class NavSensor(Generic[C, M]):
    """Base: schedule samples at ``config.rate_hz``, deliver them ``config.delay_s`` later.

    Subclasses implement ``_sample(state) -> M``. ``poll(state)`` is called every control
    tick with the true state and returns the (possibly empty) list of measurements that
    have become available by ``state.t``, oldest first. ``measure(state)`` samples at
    once, ignoring rate and delay.
    """

    def __init__(self, config: C, rng: np.random.Generator) -> None:
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        self.config = config
        self.rng = rng
        self.period = 1.0 / config.rate_hz  # type: ignore[attr-defined]
        self._next_t: float | None = None
        self._last_t: float | None = None
        self._queue: deque[tuple[float, M]] = deque()

    def measure(self, state: VehicleState) -> M:
        """One sample of the true ``state`` now (advances internal noise processes)."""
        m = self._sample(state)
        self._last_t = state.t
        return m

    def poll(self, state: VehicleState) -> list[M]:
        t = float(state.t)
        eps = 1e-9 * max(1.0, abs(t))
        if self._next_t is None:
            self._next_t = t
        if t + eps >= self._next_t:
            self._queue.append((t + self.config.delay_s, self.measure(state)))  # type: ignore[attr-defined]
            # Next due time on the fixed grid; if the caller skipped ticks, catch up.
            self._next_t += self.period
            if self._next_t <= t + eps:
                self._next_t = t + self.period
        out: list[M] = []
        while self._queue and self._queue[0][0] <= t + eps:
            out.append(self._queue.popleft()[1])
        return out

    def _dt_since_last(self, t: float) -> float:
        return 0.0 if self._last_t is None else max(0.0, t - self._last_t)

    def _sample(self, state: VehicleState) -> M:  # pragma: no cover - abstract
        raise NotImplementedError


class IMU(NavSensor[IMUConfig, IMUMeasurement]):
    """Gyro and accelerometer with white noise and random-walk biases.

    gyro  = omega_body + b_g + g_g + n_g,    n_g ~ N(0, (N_g² rate) I)
    (g_g: Gauss–Markov bias instability, std ``gyro_bias_instability``, time ``gyro_bias_tau_s``)
    f     = a_body - R_bwᵀ g_world + b_a + n_a, g_world = (0, 0, -g)
    b(k+1) = b(k) + N(0, B² Δt I) between samples.

    With ``gyro_averaged`` (default) ``omega_body`` is the mean rate over the Δt since the
    previous sample, ``log(R_prevᵀ R) / Δt``, and n_g ~ N(0, N_g²/Δt I): consistent with
    the simulated orientation whatever the integrator (MuJoCo's semi-implicit Euler moves
    the orientation with the post-step velocity, so the instantaneous rate at a tick is
    half a physics step out of step with the pose — ~0.1° per turn for the alister9).
    """

    def __init__(self, config: IMUConfig, rng: np.random.Generator) -> None:
        super().__init__(config, rng)
        self.gyro_bias = rng.normal(0.0, config.gyro_bias_init_std, 3)
        self.accel_bias = rng.normal(0.0, config.accel_bias_init_std, 3)
        # Gauss–Markov in-run component, started in its stationary distribution
        self.gyro_bias_gm = rng.normal(0.0, config.gyro_bias_instability, 3)
        self._R_prev: np.ndarray | None = None

    def _sample(self, state: VehicleState) -> IMUMeasurement:
        c = self.config
        dt = self._dt_since_last(state.t)
        if dt > 0:
            self.gyro_bias = self.gyro_bias + self.rng.normal(
                0.0, c.gyro_bias_rw * math.sqrt(dt), 3
            )
            self.accel_bias = self.accel_bias + self.rng.normal(
                0.0, c.accel_bias_rw * math.sqrt(dt), 3
            )
            if c.gyro_bias_instability > 0:
                a = math.exp(-dt / c.gyro_bias_tau_s)
                self.gyro_bias_gm = a * self.gyro_bias_gm + self.rng.normal(
                    0.0, c.gyro_bias_instability * math.sqrt(1.0 - a * a), 3
                )
        sq = math.sqrt(c.rate_hz)
        R = state.rotation
        g_body = R.T @ np.array([0.0, 0.0, c.gravity])  # -(R^T g_world) with g_world = -g ez
        if c.gyro_averaged and dt > 0 and self._R_prev is not None:
            omega = rotvec_from_matrix(self._R_prev.T @ R) / dt
            sg = c.gyro_noise_density / math.sqrt(dt)
        else:
            omega = np.asarray(state.angular_velocity_body, float)
            sg = c.gyro_noise_density * sq
        self._R_prev = R
        gyro = omega + self.gyro_bias + self.gyro_bias_gm + self.rng.normal(0.0, sg, 3)
        f = (
            np.asarray(state.acceleration_body, float)
            + g_body
            + self.accel_bias
            + self.rng.normal(0.0, c.accel_noise_density * sq, 3)
        )
        return IMUMeasurement(t=float(state.t), gyro=gyro, specific_force=f)


class DVL(NavSensor[DVLConfig, DVLMeasurement]):
    """Bottom-track velocity over ground in the body frame,
    ``v = (1 + s) Rz(m) v_true + b + n`` with the turn-on constants s (scale factor),
    m (yaw misalignment) and b (offset) of the config; lock only for
    ``min_altitude <= altitude <= max_altitude`` (unknown altitude → no lock), and each
    ping inside the window drops out with ``dropout_prob``. With ``averaged`` the
    velocity is the mean over the time since the previous ping (see DVLConfig)."""

    def __init__(self, config: DVLConfig, rng: np.random.Generator) -> None:
        super().__init__(config, rng)
        self._prev: tuple[float, np.ndarray, np.ndarray] | None = None
        # turn-on constants: scale factor, yaw misalignment, velocity offset
        self.scale_error = float(rng.normal(0.0, config.scale_factor_std))
        self.misalignment = float(rng.normal(0.0, config.misalignment_std))
        self.velocity_bias = rng.normal(0.0, config.velocity_bias_std, 3)
        c, s = math.cos(self.misalignment), math.sin(self.misalignment)
        self._M = (1.0 + self.scale_error) * np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def _sample(self, state: VehicleState) -> DVLMeasurement:
        c = self.config
        alt = float(state.altitude)
        # Draw both numbers every ping so the random stream does not depend on lock state.
        u = self.rng.random()
        noise = self.rng.normal(0.0, c.velocity_noise_std, 3)
        lock = (
            math.isfinite(alt) and c.min_altitude <= alt <= c.max_altitude and u >= c.dropout_prob
        )
        t = float(state.t)
        R = state.rotation
        p = np.asarray(state.position, float)
        t_start = None
        v_true = np.asarray(state.velocity_body, float)
        if c.averaged and self._prev is not None and t > self._prev[0]:
            t0, p0, R0 = self._prev
            half = matrix_from_rotvec(0.5 * rotvec_from_matrix(R0.T @ R))
            v_true = (R0 @ half).T @ ((p - p0) / (t - t0))
            t_start = t0
        self._prev = (t, p.copy(), R)
        v = self._M @ v_true + self.velocity_bias + noise if lock else None
        return DVLMeasurement(t=t, velocity_body=v, valid=lock, altitude=alt, t_start=t_start)


class DepthSensor(NavSensor[DepthConfig, DepthMeasurement]):
    """depth = true depth + bias + white noise, quantized to ``resolution``."""

    def _sample(self, state: VehicleState) -> DepthMeasurement:
        c = self.config
        d = state.depth + c.bias + self.rng.normal(0.0, c.noise_std)
        if c.resolution > 0:
            d = round(d / c.resolution) * c.resolution
        return DepthMeasurement(t=float(state.t), depth=float(d))


class AHRS(NavSensor[AHRSConfig, AHRSMeasurement]):
    """Roll, pitch with white noise; yaw with the deviation, drift and noise of
    :class:`AHRSConfig`, wrapped to (-pi, pi]. ``deviation`` (4,) holds the turn-on
    coefficients [a1, b1, a2, b2], ``drift`` the Gauss–Markov state, rad."""

    def __init__(self, config: AHRSConfig, rng: np.random.Generator) -> None:
        super().__init__(config, rng)
        sd = [config.hard_iron_std] * 2 + [config.soft_iron_std] * 2
        self.deviation = rng.normal(0.0, 1.0, 4) * np.array(sd)
        self.drift = float(rng.normal(0.0, config.drift_std))

    def yaw_error(self, yaw: float) -> float:
        """Deterministic part of the yaw error at true heading ``yaw``, rad."""
        basis = np.array([math.sin(yaw), math.cos(yaw), math.sin(2 * yaw), math.cos(2 * yaw)])
        return float(self.config.yaw_bias + basis @ self.deviation + self.drift)

    def _sample(self, state: VehicleState) -> AHRSMeasurement:
        c = self.config
        dt = self._dt_since_last(state.t)
        roll, pitch, yaw = state.euler
        n = self.rng.normal(0.0, 1.0, 3)
        if dt > 0 and c.drift_std > 0:
            a = math.exp(-dt / c.drift_tau_s)
            self.drift = a * self.drift + c.drift_std * math.sqrt(1.0 - a * a) * float(
                self.rng.normal()
            )
        yaw_m = yaw + self.yaw_error(float(yaw)) + c.yaw_noise_std * n[2]
        yaw_m = math.atan2(math.sin(yaw_m), math.cos(yaw_m))
        return AHRSMeasurement(
            t=float(state.t),
            roll=float(roll + c.roll_pitch_noise_std * n[0]),
            pitch=float(pitch + c.roll_pitch_noise_std * n[1]),
            yaw=float(yaw_m),
        )


class GPS(NavSensor[GPSConfig, GPSMeasurement]):
    """Horizontal position fix, only while ``depth < max_depth``."""

    def _sample(self, state: VehicleState) -> GPSMeasurement:
        c = self.config
        noise = self.rng.normal(0.0, c.horizontal_noise_std, 2)
        if state.depth < c.max_depth:
            return GPSMeasurement(
                t=float(state.t),
                position_xy=np.asarray(state.position[:2], float) + noise,
                valid=True,
            )
        return GPSMeasurement(t=float(state.t), position_xy=None, valid=False)
