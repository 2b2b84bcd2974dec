"""The thesis's 2-D models written out once more for the estimator tests (independent of
``slam.estimators``, so the filters are checked against a second implementation).

Importable in every test as ``slam_reference_models`` (pytest ``pythonpath``)."""

from __future__ import annotations

import math

import numpy as np

from slam.types import wrap_angle

R_DEFAULT = np.diag([0.1**2, np.deg2rad(1.0) ** 2])  # σ_r 0.1 m, σ_b 1° (reference)


def range_bearing(x, m):
    """``[r m, b rad]`` of landmark ``m (2,)`` seen from pose ``x = [x, y, phi]``."""
    d = m - x[:2]
    return np.array([np.hypot(*d), wrap_angle(np.arctan2(d[1], d[0]) - x[2])])


def observe_state_landmark(x, j):
    """``[r, b]`` of landmark ``j`` of an EKF-SLAM state ``x = [x, y, phi, x_1, y_1, ...]``
    (bearing not wrapped)."""
    d = x[3 + 2 * j : 5 + 2 * j] - x[:2]
    return np.array([math.hypot(*d), math.atan2(d[1], d[0]) - x[2]])


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


WELL_SEPARATED_LANDMARKS = np.array([[10.0, 0.0], [10.0, 10.0], [0.0, 12.0], [-8.0, 5.0]])


def drive_well_separated(f, seed: int = 3, steps: int = 30):
    """Known-answer association scenario shared by the estimators' tests: four landmarks
    10-20 m apart, all seen every scan in a random order while the vehicle creeps along an
    arc (odometry σ 2 cm / 1 cm / 0.5°). Asserts on every scan that the first scan creates
    each landmark and that a re-observation is matched to its own landmark or discarded
    (-1), never a wrong one and never new. Returns ``(first, n_matched, n_discarded)``,
    ``first[i]`` the estimator's index of landmark i."""
    from slam.types import Odometry, RangeBearing

    rng = np.random.default_rng(seed)
    lms = WELL_SEPARATED_LANDMARKS
    first: dict[int, int] = {}
    x = np.zeros(3)
    Q = np.diag([0.02**2, 0.01**2, np.deg2rad(0.5) ** 2])
    n_matched = n_discarded = 0
    for step in range(steps):
        order = rng.permutation(len(lms))
        obs = [
            RangeBearing(
                range_bearing(x, lms[i]) + rng.multivariate_normal(np.zeros(2), R_DEFAULT),
                R_DEFAULT,
            )
            for i in order
        ]
        res = f.update(obs)
        for j, i in enumerate(order):
            if step == 0:
                assert res.new[j]
                first[i] = res.associations[j]
            else:
                assert not res.new[j]
                assert res.associations[j] in (first[i], -1)
                n_matched += res.associations[j] == first[i]
                n_discarded += res.associations[j] == -1
        u = np.array([0.1, 0.0, 0.02])
        x = motion(x, u)
        f.predict(Odometry(u + rng.multivariate_normal(np.zeros(3), Q), Q))
    return first, n_matched, n_discarded
