"""The thesis's 2-D models written out once more for the estimator tests (independent of
``slam.estimators``, so the filters are checked against a second implementation).

Importable in every test as ``slam_reference_models`` (pytest ``pythonpath``)."""

from __future__ import annotations

import numpy as np

from slam.types import wrap_angle

R_DEFAULT = np.diag([0.1**2, np.deg2rad(1.0) ** 2])  # σ_r 0.1 m, σ_b 1° (reference)


def range_bearing(x, m):
    """``[r m, b rad]`` of landmark ``m (2,)`` seen from pose ``x = [x, y, phi]``."""
    d = m - x[:2]
    return np.array([np.hypot(*d), wrap_angle(np.arctan2(d[1], d[0]) - x[2])])


def motion(x, u):
    """Pose ``x`` moved by the body-frame increment ``u = [dx, dy, dphi]`` (thesis eq. 5.21)."""
    c, s = np.cos(x[2]), np.sin(x[2])
    return np.array([x[0] + u[0] * c - u[1] * s, x[1] + u[0] * s + u[1] * c, x[2] + u[2]])


def num_jac(f, x, eps=1e-6):
    """Central-difference Jacobian of ``f`` at ``x``."""
    f0 = f(x)
    J = np.empty((f0.size, x.size))
    for i in range(x.size):
        dx = np.zeros_like(x)
        dx[i] = eps
        J[:, i] = (f(x + dx) - f(x - dx)) / (2 * eps)
    return J
