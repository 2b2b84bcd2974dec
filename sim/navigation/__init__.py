"""Navigation sensors (IMU, DVL, pressure depth, compass/AHRS, GPS) and DVL+gyro dead
reckoning producing odometry increments with covariance for the SLAM predict step."""

from sim.navigation.dead_reckoning import (
    DeadReckoner,
    DeadReckoningConfig,
    OdometryIncrement,
    true_increment,
)
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
    NavSensor,
)
from sim.navigation.suite import NavReadings, NavSuite, NavSuiteConfig

__all__ = [
    "AHRS",
    "DVL",
    "GPS",
    "IMU",
    "AHRSConfig",
    "AHRSMeasurement",
    "DVLConfig",
    "DVLMeasurement",
    "DeadReckoner",
    "DeadReckoningConfig",
    "DepthConfig",
    "DepthMeasurement",
    "DepthSensor",
    "GPSConfig",
    "GPSMeasurement",
    "IMUConfig",
    "IMUMeasurement",
    "NavReadings",
    "NavSensor",
    "NavSuite",
    "NavSuiteConfig",
    "OdometryIncrement",
    "true_increment",
]
