"""DVL + gyro dead reckoning, cut into odometry increments for the SLAM predict step.

The output of one interval ``[t0, t1]`` is ``delta = [dx, dy, dphi]``: the horizontal
displacement expressed in the heading frame at ``t0`` (x along the heading at t0, y to
port) and the heading change, with its covariance ``cov`` (3, 3). This is the X_δ, P_δ of
the thesis' AEKF predict (REFERENCE.md, eqs. 5.21–5.27). ``sim`` may not import ``slam``
outside the runner, so increments are :class:`OdometryIncrement` with the same fields as
``slam.types.Odometry``; the runner converts with ``Odometry(inc.delta, inc.cov, inc.t)``.

Mechanisation: the latest DVL velocity and gyro rate are held until the next sample
(zero-order hold); when the next sample arrives the span between the two is corrected
to linear interpolation (trapezoid rule), so only the tail after the last sample of an
interval is extrapolated. Gyro samples that are interval means (a delta-angle IMU,
``IMUConfig.gyro_averaged``, ``gyro_noise_density`` set here) and DVL velocities that
are means over the ping interval (``DVLConfig.averaged``, ``DVLMeasurement.t_start``)
instead replace the held value over the span they average — exact for the simulated
trajectory, where MuJoCo's semi-implicit Euler step moves the pose with the post-step
velocity, so instantaneous rates at a tick are half a physics step out of step with it
(~0.1° of heading per turn, ~5 mm per speed change of the alister9 at 10 ms). Between
events the relative pose integrates

    p <- p + R(phi_mid) T v h,    phi <- phi + c · (w_yz - b) h,

with ``T`` the top two rows of ``Ry(pitch) Rx(roll)`` (levels the DVL velocity with the
AHRS attitude), ``c = (sin(roll), cos(roll)) / cos(pitch)`` (Euler yaw rate from the body
y and z rates), ``phi_mid`` the heading at the middle of the chunk and ``b`` the y/z
gyro-bias estimate (0 at start, estimated with heading aiding).

Heading aiding (``ahrs_yaw_std`` set, the default of :meth:`DeadReckoningConfig.from_sensors`
when an AHRS config is given): the AHRS/compass yaw is fused into the heading with a
Kalman update that also estimates the gyro bias, as vehicle navigation systems do. A
consumer MEMS gyro's turn-on bias (~0.3 °/s) makes a pure gyro heading drift ~20° a
minute; worse, the bias is common to every increment, so a SLAM predict that treats
increments as independent adds their variances where the errors add coherently
(n σ² instead of n² σ²) and becomes wildly over-confident. With the compass fused, the
residual bias is small and the heading error is bounded, so increments are close to
independent. Without aiding (``ahrs_yaw_std=None``) the heading is the gyro integral.

Covariance: exact linear propagation of an augmented error state
``e = [dp (2), e_psi, e0, n_v (3), n_w (2), b_w (2), s, m, b_v (3), k (4), g]`` — the
sensor-model constants (DVL scale factor s, yaw misalignment m and offset b_v; compass
deviation coefficients k) and the compass drift g are "consider" states: they carry the
datasheet errors of sensors.py into the covariance, and the compass update's
innovation is ``−e_psi + basis(ψ)·k + g + v``. Before them: the position error of the interval, the
heading error now ``e_psi`` and a clone ``e0`` of it taken at the start of the interval
(stochastic cloning: the increment's heading error is ``e_psi − e0``; without aiding
both start at zero and ``e0`` stays zero, so ``e_psi`` is the heading-change error; with
aiding the compass measures absolute heading, so both are absolute errors), the noise of the
*held* DVL sample (constant until the next ping, so it is a state, not white process
noise), the noise of the held y/z gyro sample, and the residual y/z gyro bias (true
minus estimate). A new sample replaces its noise state by a fresh independent draw (zero
cross-covariance, variance = per-sample variance of the configured sensor). The bias
carries the IMU's turn-on bias variance and its random walk. The compass update is a
Schmidt ("consider") Kalman update: only the position, the current heading and the bias
are corrected (the clone ``e0`` must stay fixed — the previous increment has been handed
out — and the held noise states are not worth estimating), with the Joseph-form
covariance, which is exact for any gain. Without DVL lock the last velocity is held and
its error random-walks with ``coast_velocity_std`` (m/s/√s). Not modelled: roll/pitch
noise of the levelling (second order for a near-level vehicle), the x gyro (it does not
enter the yaw rate), a constant compass offset
(``AHRSConfig.yaw_bias`` — it cancels in heading differences), extrapolation error of
the held samples inside an increment that ends between two samples (it matters only for
increments much shorter than the DVL ping interval: sub-millimetre errors, against a
sub-millimetre σ). After a DVL dropout the gap back to the last valid ping is
interpolated when lock returns.
The filter is written here because it is a small custom error-state model; the
linearisation mirrors the AEKF predict Jacobians.

Increments of one run are still correlated through the states that carry over a cut
(held noise, residual bias, ``e0``); consistency of the *composed* increments is tested
by Monte Carlo (tests/sim/navigation/test_nav_consumer_imu.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.navigation import dr_covariance as _cov
from sim.navigation.sensors import (
    AHRSConfig,
    AHRSMeasurement,
    DVLConfig,
    DVLMeasurement,
    IMUConfig,
    IMUMeasurement,
)

__all__ = ["DeadReckoner", "DeadReckoningConfig", "OdometryIncrement", "true_increment"]

# indices of the augmented error state
_P = slice(0, 2)
_PHI = 2
_E0 = 3
_NV = slice(4, 7)
_NW = slice(7, 9)  # held gyro noise, body y and z
_B = slice(9, 11)  # residual gyro bias, body y and z
_S = 11  # DVL scale-factor error (constant)
_M = 12  # DVL yaw misalignment, rad (constant)
_BV = slice(13, 16)  # DVL velocity offset, body frame, m/s (constant)
_K = slice(16, 20)  # compass deviation coefficients a1, b1, a2, b2, rad (constant)
_G = 20  # compass Gauss–Markov drift, rad
_N = 21
_EYE = np.eye(_N)  # copied, never written: an identity without np.eye's cost per use
_EYE.flags.writeable = False
# states a compass update corrects (the others are "consider" states)
_UPDATED = np.zeros(_N, bool)
_UPDATED[[0, 1, 2, 9, 10]] = True


@dataclass(frozen=True)
class OdometryIncrement:
    """One dead-reckoned interval; same fields as ``slam.types.Odometry``.

    delta   : (3,) [dx m, dy m, dphi rad], heading frame at ``t_start`` (x forward, y port).
    cov     : (3, 3) covariance of ``delta``.
    t       : end of the interval, s.
    t_start : start of the interval, s.
    """

    delta: np.ndarray
    cov: np.ndarray
    t: float
    t_start: float = 0.0

    def __post_init__(self) -> None:
        d = np.asarray(self.delta, float).reshape(-1)
        c = np.asarray(self.cov, float)
        if d.shape != (3,) or c.shape != (3, 3):
            raise ValueError(
                f"OdometryIncrement needs delta (3,) and cov (3, 3), got {d.shape}, {c.shape}"
            )
        # a finite sum means all finite (one scalar test; the full one only on overflow)
        if not math.isfinite(float(d.sum()) + float(c.sum())) and not (
            np.all(np.isfinite(d)) and np.all(np.isfinite(c))
        ):
            raise ValueError(f"OdometryIncrement must be finite, got delta={d}, cov={c.tolist()}")
        object.__setattr__(self, "delta", d)
        object.__setattr__(self, "cov", c)


@dataclass(frozen=True)
class DeadReckoningConfig:
    """Noise figures the dead reckoner assumes (normally taken from the sensor configs).

    dvl_velocity_std   : per-ping velocity noise, m/s (DVLConfig.velocity_noise_std).
    gyro_sample_std    : per-sample gyro noise, rad/s (density · sqrt(rate)); with
                         ``gyro_noise_density`` only for the first sample.
    gyro_noise_density : None (point samples) or the gyro's noise density, rad/s/√Hz, when
                         each gyro sample is the mean rate since the previous one (noise
                         std density/√Δt; IMUConfig.gyro_averaged).
    gyro_bias_std      : initial gyro-bias std, rad/s (IMUConfig.gyro_bias_init_std).
    gyro_bias_rw       : gyro-bias random walk, rad/s²/√Hz.
    coast_velocity_std : growth of velocity error without DVL lock, m/s/√s.
    initial_velocity_std : std of the (zero) velocity assumed before the first lock, m/s.
    gyro_bias_estimate : bias subtracted from the z gyro, rad/s (a calibration value;
                         with heading aiding, the initial value of the estimated bias).
    ahrs_yaw_std       : std of the AHRS/compass yaw white noise, rad, fused into the
                         heading; None (default) = no heading aiding, gyro-only heading.
    dvl_scale_std, dvl_misalignment_std, dvl_bias_std : the DVL's constant errors
                         (DVLConfig.scale_factor_std, misalignment_std rad,
                         velocity_bias_std m/s), carried as error states.
    compass_hard_iron_std, compass_soft_iron_std, compass_drift_std (rad),
    compass_drift_tau_s (s) : the compass deviation and drift of AHRSConfig, carried as
                         error states of the heading aiding.
    gyro_bias_instability, gyro_bias_tau_s : the gyro's Gauss–Markov bias instability
                         (rad/s, s), propagated as the random walk of the same short-time
                         diffusion 2σ²/τ (conservative beyond τ).
    """

    dvl_velocity_std: float
    gyro_sample_std: float
    gyro_bias_std: float = 0.0
    gyro_bias_rw: float = 0.0
    coast_velocity_std: float = 0.05
    initial_velocity_std: float = 1.0
    gyro_bias_estimate: float = 0.0
    ahrs_yaw_std: float | None = None
    gyro_noise_density: float | None = None
    dvl_scale_std: float = 0.0
    dvl_misalignment_std: float = 0.0
    dvl_bias_std: float = 0.0
    compass_hard_iron_std: float = 0.0
    compass_soft_iron_std: float = 0.0
    compass_drift_std: float = 0.0
    compass_drift_tau_s: float = 600.0
    gyro_bias_instability: float = 0.0
    gyro_bias_tau_s: float = 100.0

    def __post_init__(self) -> None:
        for n in ("compass_drift_tau_s", "gyro_bias_tau_s"):
            v = getattr(self, n)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"DeadReckoningConfig.{n} must be a finite number > 0, got {v!r}")
        for n in (
            "dvl_velocity_std",
            "gyro_sample_std",
            "gyro_bias_std",
            "gyro_bias_rw",
            "coast_velocity_std",
            "initial_velocity_std",
            "dvl_scale_std",
            "dvl_misalignment_std",
            "dvl_bias_std",
            "compass_hard_iron_std",
            "compass_soft_iron_std",
            "compass_drift_std",
            "gyro_bias_instability",
        ):
            v = getattr(self, n)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"DeadReckoningConfig.{n} must be a finite number >= 0, got {v!r}")
        if not math.isfinite(self.gyro_bias_estimate):
            raise ValueError(
                f"DeadReckoningConfig.gyro_bias_estimate must be finite, got {self.gyro_bias_estimate!r}"
            )
        for n, what in (("ahrs_yaw_std", "no heading aiding"), ("gyro_noise_density", "point")):
            a = getattr(self, n)
            if a is not None and not (isinstance(a, int | float) and math.isfinite(a) and a >= 0):
                raise ValueError(
                    f"DeadReckoningConfig.{n} must be None ({what}) or a finite number >= 0, "
                    f"got {a!r}"
                )

    @classmethod
    def from_sensors(
        cls,
        dvl: DVLConfig,
        imu: IMUConfig,
        coast_velocity_std: float = 0.05,
        initial_velocity_std: float = 1.0,
        ahrs: AHRSConfig | None = None,
    ) -> DeadReckoningConfig:
        """The noise the configured DVL and IMU (and AHRS, if given: heading aiding with
        its yaw noise) actually produce."""
        compass = {}
        if ahrs is not None:
            compass = dict(
                compass_hard_iron_std=ahrs.hard_iron_std,
                compass_soft_iron_std=ahrs.soft_iron_std,
                compass_drift_std=ahrs.drift_std,
                compass_drift_tau_s=ahrs.drift_tau_s,
            )
        return cls(
            dvl_velocity_std=dvl.velocity_noise_std,
            gyro_sample_std=imu.gyro_noise_density * math.sqrt(imu.rate_hz),
            gyro_bias_std=math.hypot(imu.gyro_bias_init_std, imu.gyro_bias_instability),
            gyro_bias_rw=imu.gyro_bias_rw,
            coast_velocity_std=coast_velocity_std,
            initial_velocity_std=initial_velocity_std,
            ahrs_yaw_std=None if ahrs is None else ahrs.yaw_noise_std,
            gyro_noise_density=imu.gyro_noise_density if imu.gyro_averaged else None,
            dvl_scale_std=dvl.scale_factor_std,
            dvl_misalignment_std=dvl.misalignment_std,
            dvl_bias_std=dvl.velocity_bias_std,
            gyro_bias_instability=imu.gyro_bias_instability,
            gyro_bias_tau_s=imu.gyro_bias_tau_s,
            **compass,
        )


def _rot2(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def _wrap(a: float) -> float:
    w = (a + math.pi) % (2.0 * math.pi) - math.pi
    return math.pi if w == -math.pi else w


class DeadReckoner:
    """Integrates DVL velocity and gyro yaw rate; :meth:`increment` cuts an interval.

    Feed measurements in time order with :meth:`add` (IMU, DVL, AHRS measurements; AHRS
    supplies roll/pitch for levelling and, with ``config.ahrs_yaw_std`` set, the yaw that
    aids the heading). ``increment(t)`` integrates the held values up to ``t`` and returns
    the interval since the previous cut. ``heading`` is the absolute heading estimate
    (rad, CCW from east) once a compass yaw has been fused, else None; ``gyro_bias`` the
    current z-gyro bias estimate, rad/s.
    """

    def __init__(
        self,
        config: DeadReckoningConfig,
        t0: float = 0.0,
        initial_velocity_body: np.ndarray | None = None,
    ) -> None:
        """``initial_velocity_body`` (3,) m/s: velocity held until the first DVL lock
        (default zero: a vehicle starting at rest), with ``config.initial_velocity_std``."""
        self.config = config
        self.t = float(t0)
        self.t_start = float(t0)
        self.p = np.zeros(2)
        self.phi = 0.0
        # held DVL body velocity
        self.v = (
            np.zeros(3)
            if initial_velocity_body is None
            else np.asarray(initial_velocity_body, float).reshape(3)
        )
        if not np.all(np.isfinite(self.v)):
            raise ValueError(f"initial_velocity_body must be finite, got {self.v}")
        self.w = np.zeros(2)  # held gyro rate, body y and z, rad/s
        self.roll = 0.0
        self.pitch = 0.0
        self.coasting = True  # no DVL lock yet
        # y and z gyro bias estimate, rad/s
        self.b_hat = np.array([0.0, float(config.gyro_bias_estimate)])
        self.psi0: float | None = None  # absolute heading at the interval start (aided)
        self.P = np.zeros((_N, _N))
        self.P[_B, _B] = np.eye(2) * config.gyro_bias_std**2
        self.P[_NV, _NV] = np.eye(3) * config.initial_velocity_std**2
        self.P[_S, _S] = config.dvl_scale_std**2
        self.P[_M, _M] = config.dvl_misalignment_std**2
        self.P[_BV, _BV] = np.eye(3) * config.dvl_bias_std**2
        self.P[_K, _K] = np.diag(
            [config.compass_hard_iron_std**2] * 2 + [config.compass_soft_iron_std**2] * 2
        )
        self.P[_G, _G] = config.compass_drift_std**2
        self.n_dvl = 0
        self.n_dvl_dropped = 0
        self._t_v: float | None = None  # time of the held DVL sample
        self._t_w: float | None = None  # time of the held gyro sample

    # -- propagation -------------------------------------------------------------------

    def _propagate(self, t: float) -> None:
        h = t - self.t
        if h < -1e-9:
            raise ValueError(f"measurement time {t} is before the dead reckoner's time {self.t}")
        if h <= 0:
            return
        c = self.config
        cr, sr = math.cos(self.roll), math.sin(self.roll)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        # top two rows of Ry(pitch) @ Rx(roll): levelled body velocity
        T = np.array([[cp, sp * sr, sp * cr], [0.0, cr, -sr]])
        cz = np.array([sr, cr]) / cp  # Euler yaw rate from body y and z rates
        rate = float(cz @ (self.w - self.b_hat))
        phi_mid = self.phi + 0.5 * rate * h
        R = _rot2(phi_mid)
        dp = R @ (T @ self.v) * h
        # error-state transition F P Fᵀ and process noise (dr_covariance.propagate)
        RT = R @ T
        a = math.exp(-h / c.compass_drift_tau_s)
        q_b = c.gyro_bias_rw**2 + 2.0 * c.gyro_bias_instability**2 / c.gyro_bias_tau_s
        _cov.propagate(
            self.P,
            np.array([-dp[1], dp[0]]),  # d(dp)/d(phi_mid), phi_mid from e_psi − e0
            RT,
            cz,
            # constant DVL errors: v_meas - v = s v + m Jz v + b (first order)
            R @ (T @ self.v),
            R @ (T @ np.array([-self.v[1], self.v[0], 0.0])),
            h,
            a,
            c.compass_drift_std**2 * (1.0 - a * a),
            q_b * h if q_b > 0 else 0.0,
            c.coast_velocity_std**2 * h if self.coasting and c.coast_velocity_std > 0 else 0.0,
        )
        self.p = self.p + dp
        self.phi = self.phi + rate * h
        self.t = t

    def _fresh_noise(self, idx, var: float) -> None:
        i0, k = (idx.start, idx.stop - idx.start) if isinstance(idx, slice) else (idx, 1)
        _cov.fresh_noise(self.P, i0, k, var)

    # -- inputs ------------------------------------------------------------------------

    def _trapezoid(self, t_prev: float | None, t_k: float) -> float:
        """Weight w of the trapezoidal correction for the part of [t_prev, t_k] inside the
        current interval: ∫ (t - t_prev)/h dt over [max(t_prev, t_start), t_k]."""
        if t_prev is None:
            return 0.0
        h = t_k - t_prev
        if h <= 0:
            return 0.0
        a = max(t_prev, self.t_start) - t_prev
        return (h * h - a * a) / (2.0 * h)

    def _correct(self, rows, cols: slice, G, var: float) -> None:
        """Propagate the error of a correction ``G (n_new − n_old)`` of the state rows
        (the caller applies the correction itself): remove G n_old, draw a fresh n_new
        of the noise states ``cols`` with variance ``var``, add G n_new
        (dr_covariance.correct)."""
        r0 = rows.start if isinstance(rows, slice) else rows
        G = np.asarray(G, float).reshape(-1, cols.stop - cols.start)
        _cov.correct(self.P, r0, cols.start, G, var)

    def _levelling(self) -> tuple[np.ndarray, np.ndarray]:
        """Levelling rows T (2, 3) and the Euler yaw-rate coefficients (2,) of the body
        y and z rates: yaw rate = (sin(roll) w_y + cos(roll) w_z) / cos(pitch)."""
        cr, sr = math.cos(self.roll), math.sin(self.roll)
        cp, sp = math.cos(self.pitch), math.sin(self.pitch)
        return np.array([[cp, sp * sr, sp * cr], [0.0, cr, -sr]]), np.array([sr, cr]) / cp

    def add(self, m: IMUMeasurement | DVLMeasurement | AHRSMeasurement) -> None:
        """Take one measurement (must not be older than the last one).

        A new DVL or gyro sample also corrects the span since the previous sample from
        zero-order hold to linear interpolation (trapezoid rule) — without it a vehicle
        accelerating at a (m/s²) is under-estimated by ~a·h/2 per second, a bias far
        above the noise of a good DVL — with the error of the correction propagated.
        """
        self._propagate(m.t)
        c = self.config
        if isinstance(m, IMUMeasurement):
            w_new = np.asarray(m.gyro, float)[1:3].copy()
            T, cz = self._levelling()
            if c.gyro_noise_density is not None and self._t_w is not None and m.t > self._t_w:
                # interval mean over [t_w, t]: replace the held rate on the part of the
                # span inside this interval; noise of a mean of white noise over the span
                wt = m.t - max(self._t_w, self.t_start)
                var = c.gyro_noise_density**2 / (m.t - self._t_w)
                self.phi += float(cz @ (w_new - self.w)) * wt
                self._correct(_PHI, _NW, cz * wt, var)
                self.w = w_new
                self._t_w = m.t
                return
            wt = self._trapezoid(self._t_w, m.t)
            if wt > 0:
                self.phi += float(cz @ (w_new - self.w)) * wt
                self._correct(_PHI, _NW, cz * wt, c.gyro_sample_std**2)
            else:
                self._fresh_noise(_NW, c.gyro_sample_std**2)
            self.w = w_new
            self._t_w = m.t
        elif isinstance(m, DVLMeasurement):
            self.n_dvl += 1
            if m.valid and m.velocity_body is not None:
                v_new = np.asarray(m.velocity_body, float).copy()
                T, cz = self._levelling()
                if m.t_start is not None and m.t > max(m.t_start, self.t_start):
                    # mean velocity over [t_start, t]: replace the held one on the part of
                    # that window inside this interval (rotated at the window's middle)
                    wt = m.t - max(m.t_start, self.t_start)
                    R = _rot2(self.phi - 0.5 * float(cz @ (self.w - self.b_hat)) * wt)
                    G = R @ T * wt
                    self.p = self.p + G @ (v_new - self.v)
                    self._correct(_P, _NV, G, c.dvl_velocity_std**2)
                    self.v = v_new
                    self._t_v = m.t
                    self.coasting = False
                    return
                # after a dropout too: interpolate over the gap since the last valid ping
                wt = self._trapezoid(self._t_v, m.t)
                if wt > 0:
                    T, cz = self._levelling()
                    span = m.t - max(self._t_v, self.t_start)
                    R = _rot2(self.phi - 0.5 * float(cz @ (self.w - self.b_hat)) * span)
                    G = R @ T * wt
                    self.p = self.p + G @ (v_new - self.v)
                    self._correct(_P, _NV, G, c.dvl_velocity_std**2)
                else:
                    self._fresh_noise(_NV, c.dvl_velocity_std**2)
                self.v = v_new
                self._t_v = m.t
                self.coasting = False
            else:
                # keep the held velocity and its (now correlated, growing) error
                self.n_dvl_dropped += 1
                self.coasting = True
        elif isinstance(m, AHRSMeasurement):
            self.roll, self.pitch = float(m.roll), float(m.pitch)
            if c.ahrs_yaw_std is not None:
                self._heading_update(float(m.yaw), c.ahrs_yaw_std**2)
        else:
            raise ValueError(
                "DeadReckoner.add takes IMUMeasurement, DVLMeasurement or AHRSMeasurement, "
                f"got {type(m).__name__}"
            )

    @property
    def heading(self) -> float | None:
        """Absolute heading estimate, rad (CCW from east), None before the first compass."""
        return None if self.psi0 is None else _wrap(self.psi0 + self.phi)

    @property
    def gyro_bias(self) -> float:
        """Current z-gyro bias estimate, rad/s."""
        return float(self.b_hat[1])

    def _heading_update(self, yaw: float, var: float) -> None:
        """Fuse an absolute yaw measurement ``yaw`` (rad) of variance ``var`` (rad²).

        The first one initialises the absolute heading (its error is the measurement
        noise ``v``: ``e_psi := v`` and, the heading change being unchanged,
        ``e0 := v − (e_psi − e0)``). Later ones are a scalar Schmidt-Kalman update with
        innovation ``wrap(yaw − psi0 − phi) = −e_psi + v``.
        """
        if not math.isfinite(yaw):
            raise ValueError(f"AHRS yaw must be finite, got {yaw!r}")
        if self.psi0 is None:
            self.psi0 = _wrap(yaw - self.phi)
            hc = self._compass_row(yaw)
            A = _EYE.copy()
            A[_PHI, :] = hc
            A[_E0, :] += hc
            A[_E0, _PHI] -= 1.0
            self.P = A @ self.P @ A.T
            g = np.zeros(_N)
            g[_PHI] = g[_E0] = 1.0
            self.P += var * np.outer(g, g)
            return
        h = self._compass_row(self.psi0 + self.phi)
        h[_PHI] = -1.0
        y = _wrap(yaw - self.psi0 - self.phi)
        Ph = self.P @ h
        S = float(h @ Ph) + var
        if S <= 1e-30:  # perfect compass on an already exact heading: nothing to learn
            return
        K = np.where(_UPDATED, Ph / S, 0.0)
        dx = K * y  # estimate of the error state
        self.p = self.p - dx[_P]
        self.phi = self.phi - dx[_PHI]
        self.b_hat = self.b_hat + dx[_B]  # the bias state is (true − estimate)
        _cov.schmidt_update(self.P, K, h, var)  # Joseph form: P ← A P Aᵀ + K var Kᵀ

    @staticmethod
    def _compass_row(psi: float) -> np.ndarray:
        """Row of the compass error ``basis(psi)·k + g`` in the error state."""
        h = np.zeros(_N)
        h[_K] = [math.sin(psi), math.cos(psi), math.sin(2 * psi), math.cos(2 * psi)]
        h[_G] = 1.0
        return h

    def running(self) -> tuple[np.ndarray, float]:
        """Displacement (2,) m and heading change (rad) since the last cut, in the heading
        frame at the cut, up to the last measurement (no extrapolation, no cut)."""
        return self.p.copy(), float(self.phi)

    def add_all(self, measurements) -> None:
        """Add measurements in time order; at equal times the AHRS comes last, so the
        compass is compared with a heading whose last span is already interpolated from
        the gyro sample of that time, not extrapolated (a lag that biases the update in
        turns)."""
        for m in sorted(measurements, key=lambda m: (m.t, isinstance(m, AHRSMeasurement))):
            self.add(m)

    def covariance_since_cut(self, t: float) -> np.ndarray:
        """Integrate to ``t`` and return the (3, 3) covariance of ``[dx, dy, dphi]`` since
        the last cut (no cut: a reckoner never cut gives the exact covariance of the
        whole run's dead-reckoned pose, in the frame of its start)."""
        self._propagate(float(t))
        return _cov.cut_covariance(self.P)

    def increment(self, t: float) -> OdometryIncrement:
        """Integrate to ``t`` and return ``[dx, dy, dphi]`` since the last cut, with cov."""
        cov = self.covariance_since_cut(t)
        inc = OdometryIncrement(
            delta=np.array([self.p[0], self.p[1], _wrap(self.phi)]),
            cov=cov,
            t=self.t,
            t_start=self.t_start,
        )
        # new interval: position error restarts at zero; with an absolute heading the
        # clone e0 takes the current heading error, without one the heading-change error
        # restarts at zero; held-noise and bias states carry over. P ← A P Aᵀ for that
        # A (rows of the identity or zero) is a copy of rows and columns, done in place
        P = self.P
        P[_P, :] = 0.0
        P[:, _P] = 0.0
        if self.psi0 is not None:
            P[_E0, :] = P[_PHI, :]
            P[:, _E0] = P[:, _PHI]
        else:
            P[_PHI, :] = 0.0
            P[:, _PHI] = 0.0
        if self.psi0 is not None:
            self.psi0 = _wrap(self.psi0 + self.phi)
        self.p = np.zeros(2)
        self.phi = 0.0
        self.t_start = self.t
        return inc


def true_increment(pose0: np.ndarray, pose1: np.ndarray) -> np.ndarray:
    """Exact ``[dx, dy, dphi]`` between two 2-D poses ``[x, y, yaw]`` (world), expressed in
    the frame of ``pose0`` — the quantity :class:`DeadReckoner` estimates."""
    pose0 = np.asarray(pose0, float)
    pose1 = np.asarray(pose1, float)
    d = _rot2(-pose0[2]) @ (pose1[:2] - pose0[:2])
    return np.array([d[0], d[1], _wrap(pose1[2] - pose0[2])])
