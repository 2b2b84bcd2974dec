"""Frame conversions, in one place.

MuJoCo stores quaternions as wxyz; rerun and scipy want xyzw. World frame: z up, x east,
y north. Body frame: x forward, y port, z up. Converters are named ``x_from_y``.
"""

from __future__ import annotations

import numpy as np


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
    w, x, y, z = _check_quat(q_wxyz, "q_wxyz")
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.array([roll, pitch, yaw])
