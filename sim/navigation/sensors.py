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

The noise models are the standard ones of inertial-navigation practice (white noise
given as a spectral density plus a bias random walk for the IMU, IEEE Std 952 style); no
library provides them for a simulated state, so they are written here.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import ClassVar, Generic, TypeVar

import numpy as np

from sim.frames import matrix_from_rotvec, rotvec_from_matrix
from sim.state import VehicleState

GRAVITY = 9.80665  # standard gravity, m/s²

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


# --------------------------------------------------------------------------- validation


def _check_positive(obj, *names: str) -> None:
    for n in names:
        v = getattr(obj, n)
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise ValueError(f"{type(obj).__name__}.{n} must be a finite number > 0, got {v!r}")


def _check_nonneg(obj, *names: str) -> None:
    for n in names:
        v = getattr(obj, n)
        if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
            raise ValueError(f"{type(obj).__name__}.{n} must be a finite number >= 0, got {v!r}")


def _check_finite(obj, *names: str) -> None:
    for n in names:
        v = getattr(obj, n)
        if not (isinstance(v, int | float) and math.isfinite(v)):
            raise ValueError(f"{type(obj).__name__}.{n} must be a finite number, got {v!r}")


def _check_probability(obj, name: str) -> None:
    v = getattr(obj, name)
    if not (isinstance(v, int | float) and 0.0 <= v < 1.0):
        raise ValueError(f"{type(obj).__name__}.{name} must be in [0, 1), got {v!r}")


def _preset(cls, presets: dict, name: str):
    if name not in presets:
        raise ValueError(f"unknown {cls.__name__} preset {name!r}; allowed: {sorted(presets)}")
    return presets[name]


# --------------------------------------------------------------------------- configs


@dataclass(frozen=True)
class IMUConfig:
    """Strapdown IMU (gyro + accelerometer), each axis independent.

    rate_hz                 : sample rate, Hz (> 0).
    delay_s                 : delivery latency, s (>= 0).
    gyro_noise_density      : angle random walk, rad/s/√Hz; per-sample std is
                              ``density * sqrt(rate_hz)``.
    gyro_bias_rw            : gyro bias random walk, rad/s²/√Hz (rate random walk).
    gyro_bias_init_std      : std of the turn-on bias, rad/s.
    accel_noise_density     : velocity random walk, m/s²/√Hz.
    accel_bias_rw           : accelerometer bias random walk, m/s³/√Hz.
    accel_bias_init_std     : std of the turn-on accelerometer bias, m/s².
    gravity                 : magnitude of gravity in the specific force, m/s².
    gyro_averaged           : True (default): each gyro sample is the mean body rate over
                              the interval since the previous sample — a strapdown IMU's
                              delta-angle output (integrated internally at its raw rate) —
                              taken from the true orientation change, with white noise of
                              std ``density / sqrt(Δt)`` (white noise of density N averaged
                              over Δt). The first sample, and False, give the instantaneous
                              rate with std ``density * sqrt(rate_hz)``.
    """

    rate_hz: float = 100.0
    delay_s: float = 0.0
    gyro_noise_density: float = 2.4e-4
    gyro_bias_rw: float = 1.0e-5
    gyro_bias_init_std: float = 5.0e-3
    accel_noise_density: float = 1.7e-3
    accel_bias_rw: float = 1.0e-4
    accel_bias_init_std: float = 0.02
    gravity: float = GRAVITY
    gyro_averaged: bool = True

    PRESETS: ClassVar[dict[str, dict]] = {
        # Consumer MEMS (BMI088 / MPU-class datasheet figures): gyro 0.014 °/s/√Hz
        # (ARW 0.84 °/√h), accel 175 µg/√Hz, uncalibrated turn-on bias ~0.3 °/s (zero-rate
        # offset spec ±1 °/s) and 20 mg; rate random walk 1e-5 rad/s/√s (≈124 °/h/√h:
        # the bias wanders ~15-20 °/h over a few minutes, the consumer bias-instability
        # range). A gyro-only heading drifts ~20° a minute with the turn-on bias: the
        # dead reckoner fuses the AHRS yaw and estimates the bias (NavSuiteConfig).
        "consumer": dict(
            rate_hz=100.0,
            gyro_noise_density=2.4e-4,
            gyro_bias_rw=1.0e-5,
            gyro_bias_init_std=5.0e-3,
            accel_noise_density=1.7e-3,
            accel_bias_rw=1.0e-4,
            accel_bias_init_std=0.02,
        ),
        # Tactical FOG IMU (KVH 1750-class): ARW 0.012 °/√h = 3.5e-6 rad/s/√Hz, bias
        # instability 0.05 °/h, accel 0.12 mg/√Hz, turn-on bias 1 mg.
        "tactical": dict(
            rate_hz=200.0,
            gyro_noise_density=3.5e-6,
            gyro_bias_rw=1.0e-8,
            gyro_bias_init_std=2.4e-7,
            accel_noise_density=1.2e-3,
            accel_bias_rw=1.0e-5,
            accel_bias_init_std=0.01,
        ),
    }

    def __post_init__(self) -> None:
        _check_positive(self, "rate_hz", "gravity")
        _check_nonneg(
            self,
            "delay_s",
            "gyro_noise_density",
            "gyro_bias_rw",
            "gyro_bias_init_std",
            "accel_noise_density",
            "accel_bias_rw",
            "accel_bias_init_std",
        )
        if not isinstance(self.gyro_averaged, bool):
            raise ValueError(
                f"IMUConfig.gyro_averaged must be True or False, got {self.gyro_averaged!r}"
            )

    @classmethod
    def preset(cls, name: str, **overrides) -> IMUConfig:
        """``"consumer"`` or ``"tactical"``, with keyword overrides."""
        return cls(**{**_preset(cls, cls.PRESETS, name), **overrides})


@dataclass(frozen=True)
class DVLConfig:
    """Doppler velocity log in bottom-track mode.

    rate_hz          : ping rate, Hz.
    delay_s          : delivery latency, s.
    velocity_noise_std : white noise per axis per ping, m/s.
    max_altitude     : no bottom lock above this altitude, m.
    min_altitude     : no bottom lock below this altitude (blanking distance), m.
    dropout_prob     : probability that a ping inside the lock window still loses lock.
    averaged         : False (default): the instantaneous velocity of the state. True:
                       each ping reports the mean body velocity over the time since the
                       previous ping (position change over that time, rotated by the
                       mid-span attitude), consistent with the simulated trajectory
                       whatever the integrator (MuJoCo's semi-implicit step leaves the
                       instantaneous velocity half a physics step out of step with the
                       pose: mm per speed change). Not the default: a dead reckoner cut
                       much faster than the ping rate extrapolates the held mean, which
                       lags by an extra half ping interval under acceleration (~0.25 m
                       instead of ~0.12 m over the alister9's launch in the runner).
                       The first ping is always instantaneous.
    """

    rate_hz: float = 5.0
    delay_s: float = 0.0
    velocity_noise_std: float = 0.005
    max_altitude: float = 90.0
    min_altitude: float = 0.5
    dropout_prob: float = 0.01
    averaged: bool = False

    PRESETS: ClassVar[dict[str, dict]] = {
        # Typical 600 kHz bottom-tracking DVL (Teledyne RDI Workhorse/Pathfinder 600 class):
        # ~90 m bottom-track range, 0.5 m blanking, ~0.3-0.5 cm/s single-ping std at
        # survey speed, up to ~7 Hz.
        "rdi600": dict(
            rate_hz=5.0,
            velocity_noise_std=0.005,
            max_altitude=90.0,
            min_altitude=0.5,
            dropout_prob=0.01,
        ),
        # Small 1 MHz DVL (Water Linked A50 class): 50 m range, ~1 cm/s noise.
        "a50": dict(
            rate_hz=8.0,
            velocity_noise_std=0.01,
            max_altitude=50.0,
            min_altitude=0.05,
            dropout_prob=0.02,
        ),
    }

    def __post_init__(self) -> None:
        _check_positive(self, "rate_hz", "max_altitude")
        _check_nonneg(self, "delay_s", "velocity_noise_std", "min_altitude")
        _check_probability(self, "dropout_prob")
        if not isinstance(self.averaged, bool):
            raise ValueError(f"DVLConfig.averaged must be True or False, got {self.averaged!r}")
        if self.min_altitude >= self.max_altitude:
            raise ValueError(
                f"DVLConfig.min_altitude must be < max_altitude ({self.max_altitude}), "
                f"got {self.min_altitude}"
            )

    @classmethod
    def preset(cls, name: str, **overrides) -> DVLConfig:
        """``"rdi600"`` (typical 600 kHz) or ``"a50"``, with keyword overrides."""
        return cls(**{**_preset(cls, cls.PRESETS, name), **overrides})


@dataclass(frozen=True)
class DepthConfig:
    """Pressure depth sensor (depth = pressure / (rho g), converted by the sensor).

    noise_std : white noise, m.  bias : constant offset, m (e.g. a wrong density or
    atmospheric reference).  resolution : output quantization step, m (0 = none).
    """

    rate_hz: float = 10.0
    delay_s: float = 0.0
    noise_std: float = 0.02
    bias: float = 0.0
    resolution: float = 0.0

    PRESETS: ClassVar[dict[str, dict]] = {
        # Keller 33X-class 0.01 % FS of a 30 bar range ≈ 3 cm.
        "keller": dict(rate_hz=10.0, noise_std=0.02, bias=0.0, resolution=0.001),
        # Bar30-class hobby sensor: 2 mm resolution, several cm of offset and noise.
        "bar30": dict(rate_hz=10.0, noise_std=0.05, bias=0.1, resolution=0.002),
    }

    def __post_init__(self) -> None:
        _check_positive(self, "rate_hz")
        _check_nonneg(self, "delay_s", "noise_std", "resolution")
        _check_finite(self, "bias")

    @classmethod
    def preset(cls, name: str, **overrides) -> DepthConfig:
        return cls(**{**_preset(cls, cls.PRESETS, name), **overrides})


@dataclass(frozen=True)
class AHRSConfig:
    """Compass / attitude-heading reference: roll, pitch, yaw with white noise.

    yaw_noise_std, roll_pitch_noise_std : rad.  yaw_bias : constant heading offset, rad
    (uncompensated deviation / declination).
    """

    rate_hz: float = 10.0
    delay_s: float = 0.0
    yaw_noise_std: float = math.radians(1.0)
    roll_pitch_noise_std: float = math.radians(0.2)
    yaw_bias: float = 0.0

    PRESETS: ClassVar[dict[str, dict]] = {
        # Fluxgate/MEMS AHRS: 1° heading, 0.2° roll/pitch.
        "mems_ahrs": dict(
            rate_hz=10.0, yaw_noise_std=math.radians(1.0), roll_pitch_noise_std=math.radians(0.2)
        ),
        # Gyrocompass (FOG INS class): 0.05° heading, 0.01° roll/pitch.
        "gyrocompass": dict(
            rate_hz=20.0, yaw_noise_std=math.radians(0.05), roll_pitch_noise_std=math.radians(0.01)
        ),
    }

    def __post_init__(self) -> None:
        _check_positive(self, "rate_hz")
        _check_nonneg(self, "delay_s", "yaw_noise_std", "roll_pitch_noise_std")
        _check_finite(self, "yaw_bias")

    @classmethod
    def preset(cls, name: str, **overrides) -> AHRSConfig:
        return cls(**{**_preset(cls, cls.PRESETS, name), **overrides})


@dataclass(frozen=True)
class GPSConfig:
    """GNSS receiver: fixes only when the antenna is out of the water.

    horizontal_noise_std : per axis, m.  max_depth : no fix deeper than this, m.
    """

    rate_hz: float = 1.0
    delay_s: float = 0.1
    horizontal_noise_std: float = 2.0
    max_depth: float = 0.5

    PRESETS: ClassVar[dict[str, dict]] = {
        "standalone": dict(rate_hz=1.0, horizontal_noise_std=2.0),
        "rtk": dict(rate_hz=5.0, horizontal_noise_std=0.02),
    }

    def __post_init__(self) -> None:
        _check_positive(self, "rate_hz")
        _check_nonneg(self, "delay_s", "horizontal_noise_std", "max_depth")

    @classmethod
    def preset(cls, name: str, **overrides) -> GPSConfig:
        return cls(**{**_preset(cls, cls.PRESETS, name), **overrides})


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

    gyro  = omega_body + b_g + n_g,          n_g ~ N(0, (N_g² rate) I)
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
        gyro = omega + self.gyro_bias + self.rng.normal(0.0, sg, 3)
        f = (
            np.asarray(state.acceleration_body, float)
            + g_body
            + self.accel_bias
            + self.rng.normal(0.0, c.accel_noise_density * sq, 3)
        )
        return IMUMeasurement(t=float(state.t), gyro=gyro, specific_force=f)


class DVL(NavSensor[DVLConfig, DVLMeasurement]):
    """Bottom-track velocity over ground in the body frame; lock only for
    ``min_altitude <= altitude <= max_altitude`` (unknown altitude → no lock), and each
    ping inside the window drops out with ``dropout_prob``. With ``averaged`` the
    velocity is the mean over the time since the previous ping (see DVLConfig)."""

    def __init__(self, config: DVLConfig, rng: np.random.Generator) -> None:
        super().__init__(config, rng)
        self._prev: tuple[float, np.ndarray, np.ndarray] | None = None

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
        v = v_true + noise if lock else None
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
    """Roll, pitch, yaw with white noise; yaw with a constant bias, wrapped to (-pi, pi]."""

    def _sample(self, state: VehicleState) -> AHRSMeasurement:
        c = self.config
        roll, pitch, yaw = state.euler
        n = self.rng.normal(0.0, 1.0, 3)
        yaw_m = yaw + c.yaw_bias + c.yaw_noise_std * n[2]
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
