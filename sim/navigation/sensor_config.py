"""Configs of the navigation sensors (IMU, DVL, pressure depth, compass/AHRS, GPS): the
frozen dataclasses a scenario's ``[vehicles.nav]`` table and the vehicles'
``navigation.toml`` presets become, each validated once with errors that name the field,
the value and the allowed range. The sensors that use them are in sim.navigation.sensors.

Units: SI (rad, rad/s, m/s, m, s, Hz); each field's docstring states its own. The sources
of the preset numbers are in the vehicles' READMEs (section "Navigation sensors").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

GRAVITY = 9.80665  # standard gravity, m/s²

__all__ = [
    "GRAVITY",
    "AHRSConfig",
    "DVLConfig",
    "DepthConfig",
    "GPSConfig",
    "IMUConfig",
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


def _check_at_most(obj, name: str, hi: float, what: str) -> None:
    v = getattr(obj, name)
    if v > hi:
        raise ValueError(f"{type(obj).__name__}.{name} must be <= {hi:.6g} ({what}), got {v!r}")


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
    gyro_bias_instability   : in-run bias instability (datasheet "bias stability"),
                              rad/s: std of a first-order Gauss–Markov gyro bias
                              component with correlation time ``gyro_bias_tau_s``, s.
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
    gyro_bias_instability: float = 0.0
    gyro_bias_tau_s: float = 100.0

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
            gyro_bias_instability=2.4e-7,
            gyro_bias_tau_s=300.0,
        ),
        # Industrial MEMS AHRS gyro (Xsens MTi-300 datasheet, Movella 2023): noise density
        # 0.01 °/s/√Hz = 1.75e-4 rad/s/√Hz, in-run bias stability 10 °/h = 4.8e-5 rad/s,
        # accelerometer 60 µg/√Hz and 15 µg in-run. Turn-on bias 0.2 °/s and the 100 s
        # correlation time: assumptions (not on the datasheet).
        "mti300": dict(
            rate_hz=100.0,
            gyro_noise_density=1.75e-4,
            gyro_bias_rw=0.0,
            gyro_bias_init_std=3.5e-3,
            accel_noise_density=5.9e-4,
            accel_bias_rw=1.0e-5,
            accel_bias_init_std=0.01,
            gyro_bias_instability=4.8e-5,
            gyro_bias_tau_s=100.0,
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
            "gyro_bias_instability",
        )
        _check_positive(self, "gyro_bias_tau_s")
        if not isinstance(self.gyro_averaged, bool):
            raise ValueError(
                f"IMUConfig.gyro_averaged must be True or False, got {self.gyro_averaged!r}"
            )

    @classmethod
    def preset(cls, name: str, **overrides) -> IMUConfig:
        """``"consumer"``, ``"mti300"`` or ``"tactical"``, with keyword overrides."""
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
    scale_factor_std : std of the DVL's constant fractional scale-factor error (drawn at
                       turn-on; the datasheet's "long-term accuracy ±x %"), dimensionless.
    misalignment_std : std of the constant residual yaw misalignment between the DVL and
                       the heading reference after calibration, rad.
    velocity_bias_std: std of a constant velocity offset per axis (the "± y cm/s" term of
                       the long-term accuracy), m/s.
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
    scale_factor_std: float = 0.0
    misalignment_std: float = 0.0
    velocity_bias_std: float = 0.0

    PRESETS: ClassVar[dict[str, dict]] = {
        # 600 kHz bottom-tracking DVL (Teledyne RDI Workhorse Navigator 600 datasheet):
        # bottom track 0.7-90 m, long-term accuracy ±0.2 % ±0.1 cm/s, ~0.5 cm/s single-
        # ping std at survey speed, up to ~7 Hz. Misalignment 0.1° after an in-situ
        # alignment calibration (Kinsey & Whitcomb, IEEE JOE 32(2), 2007: residuals of
        # ~0.1° after calibration, degrees before).
        "rdi600": dict(
            rate_hz=5.0,
            velocity_noise_std=0.005,
            max_altitude=90.0,
            min_altitude=0.7,
            dropout_prob=0.01,
            scale_factor_std=0.002,
            misalignment_std=math.radians(0.1),
            velocity_bias_std=0.001,
        ),
        # Small 1 MHz DVL (Water Linked DVL A50 datasheet): 0.05-50 m, long-term accuracy
        # ±1 % (standard firmware; ±0.1 % "performance"), ±0.1 cm/s, ~1 cm/s single ping,
        # 4-15 Hz. Misalignment 0.5°: hand-mounted on a small ROV without in-situ
        # calibration (assumption, between Kinsey & Whitcomb's calibrated and raw figures).
        "a50": dict(
            rate_hz=8.0,
            velocity_noise_std=0.01,
            max_altitude=50.0,
            min_altitude=0.05,
            dropout_prob=0.02,
            scale_factor_std=0.01,
            misalignment_std=math.radians(0.5),
            velocity_bias_std=0.001,
        ),
    }

    def __post_init__(self) -> None:
        _check_positive(self, "rate_hz", "max_altitude")
        _check_nonneg(
            self,
            "delay_s",
            "velocity_noise_std",
            "min_altitude",
            "scale_factor_std",
            "misalignment_std",
            "velocity_bias_std",
        )
        _check_probability(self, "dropout_prob")
        _check_at_most(self, "scale_factor_std", 0.1, "a 10 % scale error is no DVL")
        _check_at_most(self, "misalignment_std", math.radians(10.0), "10° (in rad)")
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
    """Compass / attitude-heading reference: roll, pitch, yaw.

    The yaw error is ``yaw_bias + a1 sin ψ + b1 cos ψ + a2 sin 2ψ + b2 cos 2ψ + g(t) + n``:
    a constant offset (uncompensated declination), the one-cycle (hard-iron) and two-cycle
    (soft-iron) compass deviation residual left by calibration — coefficients a1, b1 ~
    N(0, hard_iron_std²) and a2, b2 ~ N(0, soft_iron_std²) drawn at turn-on, so each
    contributes its std as RMS over headings — a slow first-order Gauss–Markov drift g of
    std ``drift_std`` and correlation time ``drift_tau_s`` (magnetic disturbances,
    temperature), and white noise n of std ``yaw_noise_std``. All angles in rad.
    ``heading_rms`` is the total RMS heading error, the figure an AHRS datasheet quotes.
    """

    rate_hz: float = 10.0
    delay_s: float = 0.0
    yaw_noise_std: float = math.radians(1.0)
    roll_pitch_noise_std: float = math.radians(0.2)
    yaw_bias: float = 0.0
    hard_iron_std: float = 0.0
    soft_iron_std: float = 0.0
    drift_std: float = 0.0
    drift_tau_s: float = 600.0

    PRESETS: ClassVar[dict[str, dict]] = {
        # MEMS AHRS with magnetometer (Xsens MTi-300 datasheet, Movella 2023: heading
        # 1 deg RMS, roll/pitch 0.2 deg RMS). The split of the 1° into white noise 0.3°,
        # hard-iron residual 0.7°, soft-iron 0.3° and a 0.5° drift over 10 min is an
        # assumption (RMS total 0.96°); LORD 3DM-GX5-25 quotes the same class (±0.8°).
        "mems_ahrs": dict(
            rate_hz=10.0,
            yaw_noise_std=math.radians(0.3),
            roll_pitch_noise_std=math.radians(0.2),
            hard_iron_std=math.radians(0.7),
            soft_iron_std=math.radians(0.3),
            drift_std=math.radians(0.5),
            drift_tau_s=600.0,
        ),
        # Gyrocompass (FOG INS class, e.g. iXblue PHINS: 0.01° sec(lat) heading; 0.05° here
        # at mid latitude), 0.01° roll/pitch; no magnetic deviation.
        "gyrocompass": dict(
            rate_hz=20.0, yaw_noise_std=math.radians(0.05), roll_pitch_noise_std=math.radians(0.01)
        ),
    }

    def __post_init__(self) -> None:
        _check_positive(self, "rate_hz", "drift_tau_s")
        _check_nonneg(
            self,
            "delay_s",
            "yaw_noise_std",
            "roll_pitch_noise_std",
            "hard_iron_std",
            "soft_iron_std",
            "drift_std",
        )
        _check_finite(self, "yaw_bias")
        for n in ("yaw_noise_std", "hard_iron_std", "soft_iron_std", "drift_std"):
            _check_at_most(self, n, math.radians(30.0), "30° (in rad): no heading source")

    @property
    def heading_rms(self) -> float:
        """Total RMS heading error over headings, rad (the datasheet's heading accuracy)."""
        return math.sqrt(
            self.yaw_bias**2
            + self.yaw_noise_std**2
            + self.hard_iron_std**2
            + self.soft_iron_std**2
            + self.drift_std**2
        )

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
