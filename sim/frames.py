"""Frame conversions, in one place.

MuJoCo stores quaternions as wxyz; rerun and scipy want xyzw. World frame: z up, x east,
y north. Body frame: x forward, y port, z up. Converters are named ``x_from_y``.
"""

from __future__ import annotations

import math

import numpy as np


def _unit_quat(q) -> tuple[float, float, float, float] | None:
    """One (4,) quaternion normalized in Python floats, the same IEEE operations as
    ``_check_quat`` (sum of squares in order, square root, division) without numpy's
    per-call overhead; None when q is not a single finite non-zero quaternion."""
    if not (isinstance(q, np.ndarray) and q.shape == (4,) and q.dtype == np.float64):
        return None
    w, x, y, z = q.tolist()
    n = math.sqrt(((w * w + x * x) + y * y) + z * z)
    if not (math.isfinite(n) and n >= 1e-9):
        return None
    return w / n, x / n, y / n, z / n


def _check_quat(q: np.ndarray, name: str) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape[-1] != 4:
        raise ValueError(f"{name} must have 4 components in its last axis, got shape {q.shape}")
    n = np.linalg.norm(q, axis=-1)
    if not np.all(np.isfinite(q)) or np.any(n < 1e-9):
        raise ValueError(f"{name} must be a finite non-zero quaternion, got {q}")
    return q / n[..., None]


def xyzw_from_wxyz(q_wxyz) -> np.ndarray:
    """MuJoCo order (w, x, y, z) -> rerun/scipy order (x, y, z, w)."""
    q = np.asarray(q_wxyz, dtype=float)
    return np.concatenate([q[..., 1:], q[..., :1]], axis=-1)


def wxyz_from_xyzw(q_xyzw) -> np.ndarray:
    """rerun/scipy order (x, y, z, w) -> MuJoCo order (w, x, y, z)."""
    q = np.asarray(q_xyzw, dtype=float)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def matrix_from_wxyz(q_wxyz) -> np.ndarray:
    """Rotation matrix (..., 3, 3) taking body vectors to world vectors (body2world)."""
    u = _unit_quat(q_wxyz)
    if u is not None:  # one quaternion: same arithmetic in Python floats
        w, x, y, z = u
        return np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
    w, x, y, z = np.moveaxis(_check_quat(q_wxyz, "q_wxyz"), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def wxyz_from_euler(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Quaternion (w, x, y, z) from intrinsic z-y'-x'' Euler angles (yaw, pitch, roll), rad."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.array(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
    )


def euler_from_wxyz(q_wxyz) -> np.ndarray:
    """(roll, pitch, yaw) in rad from a quaternion (w, x, y, z); inverse of wxyz_from_euler."""
    u = _unit_quat(q_wxyz)
    w, x, y, z = _check_quat(q_wxyz, "q_wxyz") if u is None else u
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.array([roll, pitch, yaw])


def rotvec_from_matrix(R: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) (axis × angle, rad, angle in [0, π]) of a rotation matrix
    (3, 3), through its quaternion (Shepperd's choice of the largest pivot, accurate for
    small angles: angle = 2 atan2(|v|, w))."""
    m = np.asarray(R, dtype=float).tolist()
    tr = m[0][0] + m[1][1] + m[2][2]
    k = max(range(4), key=lambda i: tr if i == 3 else m[i][i])
    if k == 3:
        w = 0.5 * math.sqrt(1.0 + tr)
        f = 0.25 / w
        v = [(m[2][1] - m[1][2]) * f, (m[0][2] - m[2][0]) * f, (m[1][0] - m[0][1]) * f]
    else:
        i, j, h = k, (k + 1) % 3, (k + 2) % 3
        vi = 0.5 * math.sqrt(1.0 + m[i][i] - m[j][j] - m[h][h])
        f = 0.25 / vi
        w = (m[h][j] - m[j][h]) * f
        v = [0.0, 0.0, 0.0]
        v[i], v[j], v[h] = vi, (m[j][i] + m[i][j]) * f, (m[h][i] + m[i][h]) * f
    if w < 0:  # the shorter way round
        w, v = -w, [-c for c in v]
    s = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    if s < 1e-300:
        return np.zeros(3)
    angle = 2.0 * math.atan2(s, w)
    return np.array(v) * (angle / s)


def matrix_from_rotvec(rv: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of a rotation vector (3,) (Rodrigues' formula, with the
    series of sin θ/θ and (1 − cos θ)/θ² below θ = 1e-4 rad)."""
    x, y, z = (float(c) for c in rv)
    t2 = x * x + y * y + z * z
    if t2 < 1e-8:
        a = 1.0 - t2 / 6.0
        b = 0.5 - t2 / 24.0
    else:
        t = math.sqrt(t2)
        a = math.sin(t) / t
        b = (1.0 - math.cos(t)) / t2
    return np.array(
        [
            [1 - b * (y * y + z * z), b * x * y - a * z, b * x * z + a * y],
            [b * x * y + a * z, 1 - b * (x * x + z * z), b * y * z - a * x],
            [b * x * z - a * y, b * y * z + a * x, 1 - b * (x * x + y * y)],
        ]
    )
