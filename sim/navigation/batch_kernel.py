"""Compiled per-tick pass of :class:`sim.navigation.batch.NavBatch` over N vehicles.

Each function is the scalar arithmetic of ``sim.navigation.sensors`` (IMU, DVL,
DepthSensor, AHRS ``_sample`` and ``NavSensor.poll``'s schedule) and of
``sim.navigation.dead_reckoning.DeadReckoner`` (``_propagate``, ``add``, ``increment``:
the estimate, not its covariance) in the same order of operations, over rows of packed
arrays, compiled by numba (cache on disk). Random numbers are not drawn here: each
sensor's standard normals (and the DVL's uniforms) come pre-drawn from that sensor's own
generator, in its order of draws, in a per-vehicle buffer with a cursor.

Packed arrays (N rows, one per vehicle; built by NavBatch):
  S   (N, S_COLS) float state, columns named by the constants below (NaN = "None");
  RP  (N, 9) the IMU's previous body->world rotation (row-major);
  DM  (N, 9) the DVL's turn-on matrix (1 + s) Rz(m), row-major;
  CFG (C_COLS,) the configuration (rates, noise figures, flags);
  ZI, ZA, ZD (N, k) the IMU, AHRS, depth standard normals; ZV (N, k, 4) per DVL ping a
  uniform then three standard normals; CUR (N, 4) int cursors into them (imu, dvl, depth,
  ahrs);
  OUT (N, 10) the readings of this tick: gyro 0:3 rad/s, DVL velocity 3:6 m/s, DVL
  altitude 6 m, depth 7 m, roll 8, pitch 9 rad; REP (N, 5) bool: IMU, DVL, DVL valid,
  depth, AHRS reported this tick.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# S columns: schedules (next due time, last sample time) of imu, dvl, depth, ahrs
NEXT = 0  # 0:4
LAST = 4  # 4:8
GB = 8  # gyro turn-on + random-walk bias (3)
GM = 11  # gyro Gauss-Markov bias (3)
DVB = 14  # DVL velocity offset (3)
# dead reckoner
T = 17
T_START = 18
P = 19  # (2)
PHI = 21
V = 22  # held DVL velocity (3)
W = 25  # held gyro y, z (2)
ROLL = 27
PITCH = 28
T_V = 29  # time of the held DVL sample (NaN: none)
T_W = 30  # time of the held gyro sample (NaN: none)
B_HAT = 31  # (2) gyro y, z bias estimate
S_COLS = 33

# CFG entries
C_PERIOD = 0  # 0:4 sample periods of imu, dvl, depth, ahrs, s
C_IMU_RATE = 4
C_GYRO_RW = 5
C_GYRO_INST = 6
C_GYRO_TAU = 7
C_GYRO_DENS = 8
C_GYRO_AVG = 9  # 1.0: the IMU's gyro_averaged
C_DVL_STD = 10
C_DVL_MIN = 11
C_DVL_MAX = 12
C_DVL_DROP = 13
C_DEPTH_STD = 14
C_DEPTH_BIAS = 15
C_DEPTH_RES = 16
C_AHRS = 17  # 1.0: an AHRS is fitted
C_RP_STD = 18
C_DRIFT = 19  # 1.0: the AHRS drift process draws
C_DR_DENS = 20  # the dead reckoner's gyro_noise_density, NaN for None
C_COLS = 21

IMU_DRAWS = 15  # most standard normals one IMU sample takes
AHRS_DRAWS = 4


@numba.njit(cache=True)
def _due(S, i, k, t, period):
    """``NavSensor.poll``'s schedule of sensor k at time t; True when a sample is due
    (then the next due time is advanced as the sensor advances it)."""
    eps = 1e-9 * max(1.0, abs(t))
    if math.isnan(S[i, NEXT + k]):
        S[i, NEXT + k] = t
    if t + eps >= S[i, NEXT + k]:
        S[i, NEXT + k] += period
        if S[i, NEXT + k] <= t + eps:
            S[i, NEXT + k] = t + period
        return True
    return False


@numba.njit(cache=True)
def _dt_since_last(S, i, k, t):
    last = S[i, LAST + k]
    return 0.0 if math.isnan(last) else max(0.0, t - last)


@numba.njit(cache=True)
def _rotvec(m, v):
    """``sim.frames.rotvec_from_matrix`` of a (3, 3) matrix into v (3,)."""
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    k = 0  # max(range(4), key=...): the first index of the largest of m00, m11, m22, tr
    best = m[0, 0]
    for j in range(1, 4):
        key = tr if j == 3 else m[j, j]
        if key > best:
            best = key
            k = j
    if k == 3:
        w = 0.5 * math.sqrt(1.0 + tr)
        f = 0.25 / w
        v[0] = (m[2, 1] - m[1, 2]) * f
        v[1] = (m[0, 2] - m[2, 0]) * f
        v[2] = (m[1, 0] - m[0, 1]) * f
    else:
        i, j, h = k, (k + 1) % 3, (k + 2) % 3
        vi = 0.5 * math.sqrt(1.0 + m[i, i] - m[j, j] - m[h, h])
        f = 0.25 / vi
        w = (m[h, j] - m[j, h]) * f
        v[i] = vi
        v[j] = (m[j, i] + m[i, j]) * f
        v[h] = (m[h, i] + m[i, h]) * f
    if w < 0:
        w = -w
        v[0], v[1], v[2] = -v[0], -v[1], -v[2]
    s = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if s < 1e-300:
        v[:] = 0.0
        return
    a = 2.0 * math.atan2(s, w) / s
    for j in range(3):
        v[j] = v[j] * a


@numba.njit(cache=True)
def _imu(S, RP, ZI, CUR, CFG, i, t, R, omega, gyro, work):
    """``IMU._sample``: the gyro (3,) into gyro; the accelerometer's draws are taken
    and dropped (its output is not produced). work (5, 3): scratch."""
    dt = _dt_since_last(S, i, 0, t)
    c = CUR[i, 0]
    if dt > 0:
        s = CFG[C_GYRO_RW] * math.sqrt(dt)
        for j in range(3):
            S[i, GB + j] = S[i, GB + j] + s * ZI[i, c + j]
        c += 6  # gyro and accelerometer random walks
        if CFG[C_GYRO_INST] > 0:
            a = math.exp(-dt / CFG[C_GYRO_TAU])
            s = CFG[C_GYRO_INST] * math.sqrt(1.0 - a * a)
            for j in range(3):
                S[i, GM + j] = a * S[i, GM + j] + s * ZI[i, c + j]
            c += 3
    om = work[0]
    if CFG[C_GYRO_AVG] > 0 and dt > 0 and not math.isnan(S[i, LAST]):
        D = work[2:5]
        for r in range(3):
            for q in range(3):
                D[r, q] = RP[i, r] * R[0, q] + RP[i, 3 + r] * R[1, q] + RP[i, 6 + r] * R[2, q]
        rv = work[1]
        _rotvec(D, rv)
        for j in range(3):
            om[j] = rv[j] / dt
        sg = CFG[C_GYRO_DENS] / math.sqrt(dt)
    else:
        for j in range(3):
            om[j] = omega[j]
        sg = CFG[C_GYRO_DENS] * math.sqrt(CFG[C_IMU_RATE])
    for r in range(3):
        for q in range(3):
            RP[i, 3 * r + q] = R[r, q]
    for j in range(3):
        gyro[j] = om[j] + S[i, GB + j] + S[i, GM + j] + sg * ZI[i, c + j]
    CUR[i, 0] = c + 6  # gyro noise, then the accelerometer's
    S[i, LAST] = t


@numba.njit(cache=True)
def _dvl(S, DM, ZV, CUR, CFG, i, t, vb, alt, out):
    """``DVL._sample`` (instantaneous velocity): out[0:3] the velocity; returns lock."""
    k = CUR[i, 1]
    u = ZV[i, k, 0]
    lock = math.isfinite(alt) and CFG[C_DVL_MIN] <= alt <= CFG[C_DVL_MAX] and u >= CFG[C_DVL_DROP]
    if lock:
        for r in range(3):
            mv = DM[i, 3 * r] * vb[0] + DM[i, 3 * r + 1] * vb[1] + DM[i, 3 * r + 2] * vb[2]
            out[r] = mv + S[i, DVB + r] + CFG[C_DVL_STD] * ZV[i, k, 1 + r]
    CUR[i, 1] = k + 1
    S[i, LAST + 1] = t
    return lock


@numba.njit(cache=True)
def _depth(S, ZD, CUR, CFG, i, t, depth):
    """``DepthSensor._sample``."""
    d = depth + CFG[C_DEPTH_BIAS] + CFG[C_DEPTH_STD] * ZD[i, CUR[i, 2]]
    CUR[i, 2] += 1
    if CFG[C_DEPTH_RES] > 0:
        d = np.rint(d / CFG[C_DEPTH_RES]) * CFG[C_DEPTH_RES]
    S[i, LAST + 2] = t
    return d


@numba.njit(cache=True)
def _ahrs(S, ZA, CUR, CFG, i, t, roll, pitch, out):
    """``AHRS._sample``'s roll and pitch into out (2,); the yaw's draws are taken."""
    dt = _dt_since_last(S, i, 3, t)
    c = CUR[i, 3]
    s = CFG[C_RP_STD]
    out[0] = roll + s * ZA[i, c]
    out[1] = pitch + s * ZA[i, c + 1]
    c += 3
    if dt > 0 and CFG[C_DRIFT] > 0:
        c += 1
    CUR[i, 3] = c
    S[i, LAST + 3] = t


@numba.njit(cache=True)
def _levelling(S, i):
    cr, sr = math.cos(S[i, ROLL]), math.sin(S[i, ROLL])
    cp, sp = math.cos(S[i, PITCH]), math.sin(S[i, PITCH])
    return cp, sp * sr, sp * cr, cr, -sr, sr / cp, cr / cp


@numba.njit(cache=True)
def _propagate(S, i, t):
    """``DeadReckoner._propagate``, the estimate only."""
    h = t - S[i, T]
    if h <= 0:
        return
    t00, t01, t02, t11, t12, cz0, cz1 = _levelling(S, i)
    rate = cz0 * (S[i, W] - S[i, B_HAT]) + cz1 * (S[i, W + 1] - S[i, B_HAT + 1])
    phi_mid = S[i, PHI] + 0.5 * rate * h
    c, s = math.cos(phi_mid), math.sin(phi_mid)
    v0, v1, v2 = S[i, V], S[i, V + 1], S[i, V + 2]
    a = t00 * v0 + t01 * v1 + t02 * v2
    b = 0.0 * v0 + t11 * v1 + t12 * v2
    S[i, P] = S[i, P] + (c * a - s * b) * h
    S[i, P + 1] = S[i, P + 1] + (s * a + c * b) * h
    S[i, PHI] = S[i, PHI] + rate * h
    S[i, T] = t


@numba.njit(cache=True)
def _trapezoid(S, i, t_prev, t_k):
    if math.isnan(t_prev):
        return 0.0
    h = t_k - t_prev
    if h <= 0:
        return 0.0
    a = max(t_prev, S[i, T_START]) - t_prev
    return (h * h - a * a) / (2.0 * h)


@numba.njit(cache=True)
def _add_gyro(S, CFG, i, t, g1, g2):
    """``DeadReckoner.add`` of an IMU measurement (gyro y, z)."""
    _propagate(S, i, t)
    _, _, _, _, _, cz0, cz1 = _levelling(S, i)
    tw = S[i, T_W]
    if not math.isnan(CFG[C_DR_DENS]) and not math.isnan(tw) and t > tw:
        wt = t - max(tw, S[i, T_START])
    else:
        wt = _trapezoid(S, i, tw, t)
    if wt > 0:
        S[i, PHI] += (cz0 * (g1 - S[i, W]) + cz1 * (g2 - S[i, W + 1])) * wt
    S[i, W] = g1
    S[i, W + 1] = g2
    S[i, T_W] = t


@numba.njit(cache=True)
def _add_dvl(S, i, t, v):
    """``DeadReckoner.add`` of a valid instantaneous DVL velocity v (3,)."""
    _propagate(S, i, t)
    wt = _trapezoid(S, i, S[i, T_V], t)
    if wt > 0:
        t00, t01, t02, t11, t12, cz0, cz1 = _levelling(S, i)
        span = t - max(S[i, T_V], S[i, T_START])
        rate = cz0 * (S[i, W] - S[i, B_HAT]) + cz1 * (S[i, W + 1] - S[i, B_HAT + 1])
        ph = S[i, PHI] - 0.5 * rate * span
        c, s = math.cos(ph), math.sin(ph)
        # G = R T wt, (2, 3); p += G (v_new - v)
        g00, g01, g02 = (c * t00 - s * 0.0) * wt, (c * t01 - s * t11) * wt, (c * t02 - s * t12) * wt
        g10, g11, g12 = (s * t00 + c * 0.0) * wt, (s * t01 + c * t11) * wt, (s * t02 + c * t12) * wt
        d0, d1, d2 = v[0] - S[i, V], v[1] - S[i, V + 1], v[2] - S[i, V + 2]
        S[i, P] = S[i, P] + (g00 * d0 + g01 * d1 + g02 * d2)
        S[i, P + 1] = S[i, P + 1] + (g10 * d0 + g11 * d1 + g12 * d2)
    for j in range(3):
        S[i, V + j] = v[j]
    S[i, T_V] = t


@numba.njit(cache=True)
def wrap(a):
    """Angle a (rad) wrapped to (-π, π] (``slam.types.wrap_angle`` of one float)."""
    w = (a + math.pi) % (2.0 * math.pi) - math.pi
    return math.pi if w == -math.pi else w


@numba.njit(cache=True)
def _quat_frames(q, R):
    """R (3, 3) of ``sim.frames.matrix_from_wxyz`` and (roll, pitch) of
    ``euler_from_wxyz`` of one wxyz quaternion (normalized first, as ``_unit_quat``)."""
    n = math.sqrt(((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]) + q[3] * q[3])
    w, x, y, z = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    R[0, 0] = 1 - 2 * (y * y + z * z)
    R[0, 1] = 2 * (x * y - w * z)
    R[0, 2] = 2 * (x * z + w * y)
    R[1, 0] = 2 * (x * y + w * z)
    R[1, 1] = 1 - 2 * (x * x + z * z)
    R[1, 2] = 2 * (y * z - w * x)
    R[2, 0] = 2 * (x * z - w * y)
    R[2, 1] = 2 * (y * z + w * x)
    R[2, 2] = 1 - 2 * (x * x + y * y)
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(min(max(2 * (w * y - z * x), -1.0), 1.0))
    return roll, pitch


@numba.njit(cache=True)
def poll(active, t, quat, vb, omega, depth, alt, S, RP, DM, CFG, ZI, ZA, ZD, ZV, CUR, OUT, REP):
    """``NavSuite.poll`` of every active vehicle at its time t[i]: sample the due sensors
    (from the states quat (N,4) wxyz, vb/omega (N,3) body velocity and rate, depth and
    alt (N,)) into OUT/REP, then feed the dead reckoner in ``add_all``'s order (IMU, DVL,
    then AHRS at equal times)."""
    R = np.empty((3, 3))
    buf = np.empty(3)
    rp = np.empty(2)
    work = np.empty((5, 3))
    for i in range(active.shape[0]):
        for j in range(5):
            REP[i, j] = False
        if not active[i]:
            continue
        ti = t[i]
        roll, pitch = _quat_frames(quat[i], R)
        if _due(S, i, 0, ti, CFG[C_PERIOD]):
            _imu(S, RP, ZI, CUR, CFG, i, ti, R, omega[i], OUT[i, 0:3], work)
            REP[i, 0] = True
        if _due(S, i, 1, ti, CFG[C_PERIOD + 1]):
            REP[i, 1] = True
            REP[i, 2] = _dvl(S, DM, ZV, CUR, CFG, i, ti, vb[i], alt[i], OUT[i, 3:6])
            OUT[i, 6] = alt[i]
        if _due(S, i, 2, ti, CFG[C_PERIOD + 2]):
            OUT[i, 7] = _depth(S, ZD, CUR, CFG, i, ti, depth[i])
            REP[i, 3] = True
        if CFG[C_AHRS] > 0 and _due(S, i, 3, ti, CFG[C_PERIOD + 3]):
            _ahrs(S, ZA, CUR, CFG, i, ti, roll, pitch, rp)
            OUT[i, 8] = rp[0]
            OUT[i, 9] = rp[1]
            REP[i, 4] = True
        if REP[i, 0]:
            _add_gyro(S, CFG, i, ti, OUT[i, 1], OUT[i, 2])
        if REP[i, 1]:
            _propagate(S, i, ti)
            if REP[i, 2]:
                for j in range(3):
                    buf[j] = OUT[i, 3 + j]
                _add_dvl(S, i, ti, buf)
        if REP[i, 4]:
            _propagate(S, i, ti)
            S[i, ROLL] = OUT[i, 8]
            S[i, PITCH] = OUT[i, 9]


@numba.njit(cache=True)
def odometry(active, t, S, delta):
    """``DeadReckoner.increment`` (estimate) of every active vehicle up to t[i] into
    delta (N, 3) [dx, dy, dphi], then the cut."""
    for i in range(active.shape[0]):
        if not active[i]:
            continue
        _propagate(S, i, t[i])
        delta[i, 0] = S[i, P]
        delta[i, 1] = S[i, P + 1]
        delta[i, 2] = wrap(S[i, PHI])
        S[i, P] = 0.0
        S[i, P + 1] = 0.0
        S[i, PHI] = 0.0
        S[i, T_START] = S[i, T]
