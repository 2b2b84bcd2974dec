"""The navigation of N vehicles at once: what N :class:`sim.navigation.NavSuite` report to
an agent, in one compiled pass per control tick.

For each vehicle it produces the readings the gymnasium envs observe — gyro (3,) rad/s,
DVL velocity (3,) m/s with its lock and altitude m, pressure depth m, AHRS roll and pitch
rad — and the dead-reckoned increment ``[dx, dy, dphi]`` of each control step, equal to
those of a NavSuite built with the same configuration and generator and polled with the
same states (tests/sim/navigation/test_nav_batch.py: the readings to the last bit where
the arithmetic is the same, the increments to rounding). What it leaves out, because no
env reads it: the odometry covariance (``NavSuite.odometry(t).cov``, the 21-state error
propagation that is most of a NavSuite's cost), the accelerometer's output, the AHRS yaw
and the GPS; their random draws are still taken where they share a generator with an
output, so every output stays on the NavSuite's random stream. Configurations it does
not batch raise ValueError naming the field: heading aiding (``NavSuiteConfig.aided``,
whose Kalman gain needs the covariance), a sensor delay (``delay_s`` > 0) and the
window-averaged DVL (``DVLConfig.averaged``).

Random numbers: each vehicle's sensors are built by their own constructors
(``sim.navigation.sensors``) from ``generator.spawn(5)`` as NavSuite builds them, so the
turn-on constants are theirs; each sensor's later draws are taken from its generator in
blocks of ``block`` samples into a buffer that the compiled pass reads in the sensor's
order of draws (a generator's stream does not depend on how many numbers one call asks
for).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sim.navigation import batch_kernel as K
from sim.navigation.sensors import AHRS, DVL, IMU
from sim.navigation.suite import NavSuiteConfig

__all__ = ["NavBatch"]


@numba.njit(cache=True)
def _dvl_draws(rng, out):
    """A DVL's draws of out.shape[0] pings, in ``DVL._sample``'s order: a uniform (the
    dropout), then three standard normals (the velocity noise)."""
    for k in range(out.shape[0]):
        out[k, 0] = rng.random()
        for j in range(3):
            out[k, 1 + j] = rng.standard_normal()


def _check_batchable(config: NavSuiteConfig) -> None:
    if not isinstance(config, NavSuiteConfig):
        raise ValueError(f"config must be a NavSuiteConfig, got {type(config).__name__}")
    if config.aided:
        raise ValueError(
            "NavSuiteConfig.heading_aiding: NavBatch does not fuse the compass into the "
            "heading (its gain needs the covariance); use NavSuite, or a gyro-only heading "
            "(heading_aiding=False, or a FOG-class imu)"
        )
    for name in ("imu", "dvl", "depth", "ahrs"):
        c = getattr(config, name)
        if c is not None and c.delay_s != 0:
            raise ValueError(
                f"NavSuiteConfig.{name}.delay_s = {c.delay_s!r}: NavBatch delivers every "
                "sample at its acquisition time; allowed: 0 (or use NavSuite)"
            )
    if config.dvl.averaged:
        raise ValueError(
            "NavSuiteConfig.dvl.averaged = True: NavBatch takes instantaneous DVL "
            "velocities; allowed: False (or use NavSuite)"
        )


def _config_row(config: NavSuiteConfig) -> np.ndarray:
    imu, dvl, dep, ahrs = config.imu, config.dvl, config.depth, config.ahrs
    c = np.zeros(K.C_COLS)
    c[K.C_PERIOD : K.C_PERIOD + 4] = [
        1.0 / imu.rate_hz,
        1.0 / dvl.rate_hz,
        1.0 / dep.rate_hz,
        1.0 / ahrs.rate_hz if ahrs is not None else 1.0,
    ]
    c[K.C_IMU_RATE] = imu.rate_hz
    c[K.C_GYRO_RW] = imu.gyro_bias_rw
    c[K.C_GYRO_INST] = imu.gyro_bias_instability
    c[K.C_GYRO_TAU] = imu.gyro_bias_tau_s
    c[K.C_GYRO_DENS] = imu.gyro_noise_density
    c[K.C_GYRO_AVG] = float(imu.gyro_averaged)
    c[K.C_DVL_STD] = dvl.velocity_noise_std
    c[K.C_DVL_MIN] = dvl.min_altitude
    c[K.C_DVL_MAX] = dvl.max_altitude
    c[K.C_DVL_DROP] = dvl.dropout_prob
    c[K.C_DEPTH_STD] = dep.noise_std
    c[K.C_DEPTH_BIAS] = dep.bias
    c[K.C_DEPTH_RES] = dep.resolution
    c[K.C_AHRS] = float(ahrs is not None)
    c[K.C_RP_STD] = ahrs.roll_pitch_noise_std if ahrs is not None else 0.0
    c[K.C_DRIFT] = float(ahrs is not None and ahrs.drift_std > 0)
    # DeadReckoningConfig.from_sensors: the gyro noise density only for averaged samples
    c[K.C_DR_DENS] = imu.gyro_noise_density if imu.gyro_averaged else math.nan
    return c


class NavBatch:
    """N vehicles' navigation sensors and dead reckoning (estimate only); see the module
    docstring. ``reset(i, rng, t0)`` starts vehicle i as ``NavSuite(config, rng, t0)``;
    ``poll`` then ``odometry`` once per control tick, as ``NavSuite.poll`` and
    ``NavSuite.odometry(t).delta``."""

    def __init__(self, config: NavSuiteConfig, n: int, block: int = 1024) -> None:
        _check_batchable(config)
        if int(n) < 1:
            raise ValueError(f"n = {n!r}; allowed: an integer >= 1 (vehicles)")
        if int(block) < 1:
            raise ValueError(f"block = {block!r}; allowed: an integer >= 1 (samples)")
        n, b = int(n), int(block)
        self.config = config
        self.n = n
        self._cfg = _config_row(config)
        self.S = np.full((n, K.S_COLS), np.nan)
        self._RP = np.zeros((n, 9))
        self._DM = np.zeros((n, 9))
        self._Z = [
            np.zeros((n, K.IMU_DRAWS * b)),  # imu
            np.zeros((n, b, 4)),  # dvl
            np.zeros((n, b)),  # depth
            np.zeros((n, K.AHRS_DRAWS * b)),  # ahrs
        ]
        # draws one tick may take from each buffer (none without an AHRS)
        self._need = np.array([K.IMU_DRAWS, 1, 1, K.AHRS_DRAWS if config.ahrs else 0])
        self._cap = np.array([z.shape[1] for z in self._Z])
        self._cur = np.zeros((n, 4), dtype=np.int64)
        self._gens: list[tuple | None] = [None] * n
        self.out = np.zeros((n, 10))
        self.reported = np.zeros((n, 5), dtype=bool)
        self._delta = np.zeros((n, 3))

    # ---------------------------------------------------------------- life cycle -------
    def reset(self, i: int, rng: np.random.Generator, t0: float = 0.0) -> None:
        """Vehicle i restarts as ``NavSuite(self.config, rng, t0)`` (same draws: its
        sensors' turn-on constants come from their own constructors)."""
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        c = self.config
        r = rng.spawn(5)
        imu = IMU(c.imu, r[0])
        dvl = DVL(c.dvl, r[1])
        ahrs = AHRS(c.ahrs, r[3]) if c.ahrs is not None else None
        s = self.S[i]
        s[:] = np.nan  # schedules and held-sample times: "None"
        s[K.GB : K.GB + 3] = imu.gyro_bias
        s[K.GM : K.GM + 3] = imu.gyro_bias_gm
        s[K.DVB : K.DVB + 3] = dvl.velocity_bias
        s[K.T] = s[K.T_START] = float(t0)
        s[K.P : K.P + 2] = 0.0
        s[K.PHI] = 0.0
        s[K.V : K.V + 3] = 0.0
        s[K.W : K.W + 2] = 0.0
        s[K.ROLL] = s[K.PITCH] = 0.0
        s[K.B_HAT : K.B_HAT + 2] = 0.0  # DeadReckoningConfig.gyro_bias_estimate
        self._DM[i] = dvl._M.ravel()
        self._gens[i] = (imu.rng, dvl.rng, r[2], ahrs.rng if ahrs is not None else None)
        self._cur[i] = self._cap  # empty: drawn on the next poll
        self._fill(i, np.ones(4, bool))

    def _fill(self, i: int, which: np.ndarray) -> None:
        """Keep the unread draws of vehicle i's buffers ``which`` and draw the rest."""
        for k in np.flatnonzero(which):
            g = self._gens[i][k]
            if g is None:
                continue
            z, c = self._Z[k], int(self._cur[i, k])
            left = z.shape[1] - c
            z[i, :left] = z[i, c:]
            if k == 1:
                _dvl_draws(g, z[i, left:])
            else:
                z[i, left:] = g.standard_normal(z.shape[1] - left)
            self._cur[i, k] = 0

    # ---------------------------------------------------------------- per tick ---------
    def poll(self, active, t, quat, velocity_body, omega_body, depth, altitude) -> None:
        """``NavSuite.poll`` of the active vehicles (bool (N,)) at times t (N,) s, from
        their true states: quat (N, 4) wxyz body->world, velocity_body and omega_body
        (N, 3) m/s and rad/s (body frame), depth (N,) m (positive down), altitude (N,) m.
        This tick's readings are in ``out`` (N, 10) — gyro 0:3, DVL velocity 3:6, DVL
        altitude 6, depth 7, roll 8, pitch 9 — where ``reported`` (N, 5) says so: IMU,
        DVL ping, DVL lock, depth, AHRS (other rows keep earlier values)."""
        low = self._cur + self._need > self._cap
        if low.any():
            for i in np.flatnonzero(low.any(axis=1)):
                self._fill(i, low[i])
        K.poll(
            active, t, quat, velocity_body, omega_body, depth, altitude, self.S, self._RP,
            self._DM, self._cfg, self._Z[0], self._Z[3], self._Z[2], self._Z[1], self._cur,
            self.out, self.reported,
        )  # fmt: skip

    def odometry(self, active, t) -> np.ndarray:
        """``NavSuite.odometry(t).delta`` of the active vehicles: (N, 3) [dx m, dy m,
        dphi rad] since the previous call, in the heading frame at its start (rows of
        inactive vehicles: unchanged)."""
        K.odometry(active, t, self.S, self._delta)
        return self._delta
