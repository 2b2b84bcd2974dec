"""A vehicle's navigation payload: all five sensors plus the dead reckoner, polled once per
control tick. The runner uses it to produce sensor logs and odometry increments."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from sim.navigation import dr_covariance as _cov
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
MAX_GYRO_HEADING_DRIFT_DEG = 1.0  # per minute: a gyro-only heading source must stay below


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
    compass's absolute error. ``matched_odometry_covariance``: see
    :meth:`NavSuite.odometry`."""

    imu: IMUConfig = field(default_factory=lambda: IMUConfig.preset("consumer"))
    dvl: DVLConfig = field(default_factory=lambda: DVLConfig.preset("rdi600"))
    depth: DepthConfig = field(default_factory=lambda: DepthConfig.preset("keller"))
    ahrs: AHRSConfig | None = field(default_factory=lambda: AHRSConfig.preset("mems_ahrs"))
    gps: GPSConfig = field(default_factory=lambda: GPSConfig.preset("standalone"))
    coast_velocity_std: float = 0.05
    initial_velocity_std: float = 1.0
    heading_aiding: bool | None = None
    matched_odometry_covariance: bool = True

    def __post_init__(self) -> None:
        if self.heading_aiding not in (None, True, False):
            raise ValueError(
                "NavSuiteConfig.heading_aiding must be None (auto), True or False, "
                f"got {self.heading_aiding!r}"
            )
        if not isinstance(self.matched_odometry_covariance, bool):
            raise ValueError(
                "NavSuiteConfig.matched_odometry_covariance must be True or False, "
                f"got {self.matched_odometry_covariance!r}"
            )
        if self.ahrs is None:
            drift = math.degrees(self.imu.gyro_bias_init_std * AUTO_AIDING_HORIZON_S)
            if self.heading_aiding:
                raise ValueError("NavSuiteConfig.heading_aiding is True but ahrs is None")
            if drift > MAX_GYRO_HEADING_DRIFT_DEG:
                raise ValueError(
                    "NavSuiteConfig.ahrs: the vehicle has no heading source - no compass/AHRS "
                    f"and a gyro whose turn-on bias (imu.gyro_bias_init_std = "
                    f"{self.imu.gyro_bias_init_std:g} rad/s) drifts {drift:.3g}° a minute "
                    f"(a heading reference needs <= {MAX_GYRO_HEADING_DRIFT_DEG:g}°/min: "
                    "a FOG-class IMU, or add an ahrs)"
                )

    @property
    def aided(self) -> bool:
        """Whether the dead reckoner fuses the AHRS yaw (``heading_aiding`` resolved)."""
        if self.ahrs is None:
            return False
        if self.heading_aiding is not None:
            return self.heading_aiding
        return self.imu.gyro_bias_init_std * AUTO_AIDING_HORIZON_S > self.ahrs.heading_rms

    @property
    def heading_source(self) -> str:
        """``"compass-aided gyro"`` or ``"gyro"`` (FOG-class heading without compass)."""
        return "compass-aided gyro" if self.aided else "gyro"


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
        initial_pose: np.ndarray | None = None,
    ) -> None:
        """``initial_pose`` [x, y, yaw] (world m, rad): the pose the vehicle's navigation
        starts from (a surface GPS fix and heading alignment); default the origin."""
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        r = rng.spawn(5)
        self.config = config
        self.imu = IMU(config.imu, r[0])
        self.dvl = DVL(config.dvl, r[1])
        self.depth = DepthSensor(config.depth, r[2])
        self.ahrs = AHRS(config.ahrs, r[3]) if config.ahrs is not None else None
        self.gps = GPS(config.gps, r[4])
        self._pose_cut = np.zeros(3) if initial_pose is None else np.asarray(initial_pose, float)
        if self._pose_cut.shape != (3,) or not np.all(np.isfinite(self._pose_cut)):
            raise ValueError(f"initial_pose must be finite [x, y, yaw], got {initial_pose!r}")
        self._depth_nav = float("nan")
        self.n_dvl_valid = 0
        dr_config = DeadReckoningConfig.from_sensors(
            config.dvl,
            config.imu,
            coast_velocity_std=config.coast_velocity_std,
            initial_velocity_std=config.initial_velocity_std,
            ahrs=config.ahrs if config.aided else None,
        )
        self.dead_reckoner = DeadReckoner(
            dr_config, t0=t0, initial_velocity_body=initial_velocity_body
        )
        # never cut: the exact covariance of the whole run's dead-reckoned pose
        self._whole = (
            DeadReckoner(dr_config, t0=t0, initial_velocity_body=initial_velocity_body)
            if config.matched_odometry_covariance
            else None
        )
        self._yaw0 = float(self._pose_cut[2])
        # world-frame covariance SLAM's predict recursion has reached at the previous cut
        self._cov_cut = np.zeros((3, 3))

    def poll(self, state: VehicleState) -> NavReadings:
        out = NavReadings(
            imu=self.imu.poll(state),
            dvl=self.dvl.poll(state),
            depth=self.depth.poll(state),
            ahrs=self.ahrs.poll(state) if self.ahrs is not None else [],
            gps=self.gps.poll(state),
        )
        self.dead_reckoner.add_all([*out.ahrs, *out.imu, *out.dvl])
        if self._whole is not None:
            self._whole.add_all([*out.ahrs, *out.imu, *out.dvl])
        self.n_dvl_valid += sum(1 for m in out.dvl if m.valid)
        if out.depth:
            self._depth_nav = out.depth[-1].depth
        return out

    def odometry(self, t: float) -> OdometryIncrement:
        """The dead-reckoned increment since the previous call, up to ``t``.

        With ``matched_odometry_covariance`` (default) its covariance Q is matched to the
        sensors' error model: the increments' errors are correlated (DVL scale factor
        and misalignment, compass deviation, gyro bias are slow or constant), which a
        SLAM predict ``P ← F P Fᵀ + G Q Gᵀ`` that treats them as white cannot represent;
        Q is chosen so that this recursion reproduces, cut after cut, the exact
        covariance Σ(t) of the whole run's dead-reckoned pose (a never-cut copy of the
        dead reckoner): ``Q = Gᵀ (Σ_k − F Σ̃_{k−1} Fᵀ) G`` with ``Σ̃`` the covariance the
        recursion itself has reached, its negative eigenvalues (an error that shrinks
        again, e.g. a scale error on the way back) set to zero. Then ``Σ̃_k = Σ_k`` while
        Σ grows and ``Σ̃_k ≥ Σ_k`` (conservative) after it shrinks; differencing the true
        Σ_{k−1} instead would add every regrowth on top of the clipped excess, inflating
        ``Σ̃`` without bound over a run of back-and-forth lines. Otherwise Q is the
        increment's own (marginal) covariance.
        """
        x_prev = self._pose_cut
        inc = self.dead_reckoner.increment(t)
        self._pose_cut = _compose(x_prev, inc.delta)
        if self._whole is None:
            return inc
        Q = _cov.matched_odometry_cov(
            self._whole.covariance_since_cut(t),
            self._cov_cut,
            self._yaw0,
            float(x_prev[2]),
            float(inc.delta[0]),
            float(inc.delta[1]),
        )
        return OdometryIncrement(delta=inc.delta, cov=Q, t=inc.t, t_start=inc.t_start)

    def pose(self) -> np.ndarray:
        """The vehicle's own navigation pose [x, y, yaw] (world m, rad): the initial pose
        composed with every dead-reckoned increment, up to the last measurement."""
        p, phi = self.dead_reckoner.running()
        return _compose(self._pose_cut, np.array([p[0], p[1], phi]))

    def navigation_state(self, truth: VehicleState) -> VehicleState:
        """What the autopilot steers on: ``truth`` with x, y and yaw replaced by the
        navigation pose and z by the depth sensor (once it has reported). Roll, pitch,
        velocities and altitude stay true (their navigation errors are second order
        for the guidance here; stated simplification)."""
        x, y, yaw = self.pose()
        q = _yaw_rotated(truth.quat_wxyz, yaw - float(truth.euler[2]))
        z = -self._depth_nav if math.isfinite(self._depth_nav) else float(truth.position[2])
        return replace(truth, position=np.array([x, y, z]), quat_wxyz=q)

    def summary(self) -> dict:
        """Sensor suite facts for metrics: heading source, DVL lock fraction, warnings."""
        n = self.dead_reckoner.n_dvl
        out = {
            "heading_source": self.config.heading_source,
            "dvl_pings": n,
            "dvl_lock_fraction": self.n_dvl_valid / n if n else None,
            "warnings": [],
        }
        if n and self.n_dvl_valid == 0:
            c = self.config.dvl
            out["warnings"].append(
                f"DVL never had bottom lock ({n} pings): the altitude stayed outside "
                f"[{c.min_altitude:g}, {c.max_altitude:g}] m (nav.dvl min/max_altitude); "
                "dead reckoning coasted on its initial velocity"
            )
        return out


def _yaw_rotated(q_wxyz: np.ndarray, d: float) -> np.ndarray:
    """The unit quaternion (4,) wxyz of a rotation by d rad about world z composed with
    q_wxyz (normalized first): ``Rotation.from_euler("z", d) * Rotation.from_quat(q)`` of
    scipy in scalar arithmetic, with scipy's operations in its order (normalize the
    input, Hamilton product, normalize the result), so the same bits
    (tests/sim/navigation/test_nav_suite_speed.py checks against scipy)."""
    w, x, y, z = float(q_wxyz[0]), float(q_wxyz[1]), float(q_wxyz[2]), float(q_wxyz[3])
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    p0, p1, p2, p3 = 0.0, 0.0, math.sin(d / 2), math.cos(d / 2)
    r0 = p3 * x + w * p0 + (p1 * z - p2 * y)
    r1 = p3 * y + w * p1 + (p2 * x - p0 * z)
    r2 = p3 * z + w * p2 + (p0 * y - p1 * x)
    r3 = p3 * w - p0 * x - p1 * y - p2 * z
    m = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3)
    return np.array([r3 / m, r0 / m, r1 / m, r2 / m])


def _compose(pose: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """pose [x, y, yaw] ⊕ delta [dx, dy, dphi] (delta in the frame of pose)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    yaw = pose[2] + delta[2]
    return np.array(
        [
            pose[0] + c * delta[0] - s * delta[1],
            pose[1] + s * delta[0] + c * delta[1],
            math.atan2(math.sin(yaw), math.cos(yaw)),
        ]
    )
