"""A vehicle's navigation payload: all five sensors plus the dead reckoner, polled once per
control tick. The runner uses it to produce sensor logs and odometry increments."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sim.navigation.dead_reckoning import DeadReckoner, DeadReckoningConfig, OdometryIncrement
from sim.navigation.sensors import (
    AHRS,
    DVL,
    GPS,
    IMU,
    AHRSConfig,
    AHRSMeasurement,
    DepthConfig,
    DepthMeasurement,
    DepthSensor,
    DVLConfig,
    DVLMeasurement,
    GPSConfig,
    GPSMeasurement,
    IMUConfig,
    IMUMeasurement,
)
from sim.state import VehicleState

__all__ = ["NavReadings", "NavSuite", "NavSuiteConfig"]

AUTO_AIDING_HORIZON_S = 60.0  # heading_aiding=None: aid if the turn-on bias beats the AHRS in this


@dataclass(frozen=True)
class NavSuiteConfig:
    """Sensor configs of one vehicle (defaults: consumer IMU, 600 kHz DVL, Keller-class
    depth, MEMS AHRS, standalone GPS) and the dead reckoner's coast noise, m/s/√s, and
    prior std of the initial velocity, m/s. ``heading_aiding``: True = the dead reckoner
    fuses the AHRS yaw into its gyro heading and estimates the gyro bias, as a vehicle's
    navigation does; False = gyro-only heading; None (default) = aid when the gyro's
    turn-on bias alone would take a gyro-only heading past the AHRS yaw accuracy within
    a minute (``gyro_bias_init_std * 60 s > yaw_noise_std``): the consumer MEMS IMU
    (~20° a minute) is aided, the tactical FOG (0.003° a minute) is not — fusing a 1°
    compass into it would only trade its sub-millidegree relative heading for the
    compass's absolute error."""

    imu: IMUConfig = field(default_factory=lambda: IMUConfig.preset("consumer"))
    dvl: DVLConfig = field(default_factory=lambda: DVLConfig.preset("rdi600"))
    depth: DepthConfig = field(default_factory=lambda: DepthConfig.preset("keller"))
    ahrs: AHRSConfig = field(default_factory=lambda: AHRSConfig.preset("mems_ahrs"))
    gps: GPSConfig = field(default_factory=lambda: GPSConfig.preset("standalone"))
    coast_velocity_std: float = 0.05
    initial_velocity_std: float = 1.0
    heading_aiding: bool | None = None

    def __post_init__(self) -> None:
        if self.heading_aiding not in (None, True, False):
            raise ValueError(
                "NavSuiteConfig.heading_aiding must be None (auto), True or False, "
                f"got {self.heading_aiding!r}"
            )

    @property
    def aided(self) -> bool:
        """Whether the dead reckoner fuses the AHRS yaw (``heading_aiding`` resolved)."""
        if self.heading_aiding is not None:
            return self.heading_aiding
        return self.imu.gyro_bias_init_std * AUTO_AIDING_HORIZON_S > self.ahrs.yaw_noise_std


@dataclass(frozen=True)
class NavReadings:
    """Measurements delivered on one tick (lists, oldest first; usually 0 or 1 each)."""

    imu: list[IMUMeasurement]
    dvl: list[DVLMeasurement]
    depth: list[DepthMeasurement]
    ahrs: list[AHRSMeasurement]
    gps: list[GPSMeasurement]


class NavSuite:
    """Owns the sensors (each with its own child Generator spawned from ``rng``) and a
    :class:`DeadReckoner` fed with the IMU, DVL and AHRS measurements."""

    def __init__(
        self,
        config: NavSuiteConfig,
        rng: np.random.Generator,
        t0: float = 0.0,
        initial_velocity_body: np.ndarray | None = None,
    ) -> None:
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        r = rng.spawn(5)
        self.config = config
        self.imu = IMU(config.imu, r[0])
        self.dvl = DVL(config.dvl, r[1])
        self.depth = DepthSensor(config.depth, r[2])
        self.ahrs = AHRS(config.ahrs, r[3])
        self.gps = GPS(config.gps, r[4])
        self.dead_reckoner = DeadReckoner(
            DeadReckoningConfig.from_sensors(
                config.dvl,
                config.imu,
                coast_velocity_std=config.coast_velocity_std,
                initial_velocity_std=config.initial_velocity_std,
                ahrs=config.ahrs if config.aided else None,
            ),
            t0=t0,
            initial_velocity_body=initial_velocity_body,
        )

    def poll(self, state: VehicleState) -> NavReadings:
        out = NavReadings(
            imu=self.imu.poll(state),
            dvl=self.dvl.poll(state),
            depth=self.depth.poll(state),
            ahrs=self.ahrs.poll(state),
            gps=self.gps.poll(state),
        )
        self.dead_reckoner.add_all([*out.ahrs, *out.imu, *out.dvl])
        return out

    def odometry(self, t: float) -> OdometryIncrement:
        """The dead-reckoned increment since the previous call, up to ``t``."""
        return self.dead_reckoner.increment(t)
