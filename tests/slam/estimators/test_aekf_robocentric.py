"""Robocentric AEKF: prediction Jacobians against finite differences, and world-frame
outputs equal to the world-frame AEKF's where the two are exactly equivalent (prediction
and augmentation involve no linearization of observations)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.estimators import make_estimator
from slam.estimators.aekf import AEKFSlam
from slam.estimators.aekf_robocentric import RobocentricAEKFSlam, robo_predict


@pytest.fixture(autouse=True, scope="module")
def _single_blas_thread():
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def _move(x, u):
    """Second implementation of the robocentric motion: every point p -> Rot(-dphi)(p - t)."""
    c, s = math.cos(u[2]), math.sin(u[2])
    out = x.copy()
    pts = x[[0, 1, *list(range(3, x.size))]].reshape(-1, 2) - u[:2]
    rot = pts @ np.array([[c, s], [-s, c]]).T
    out[[0, 1]] = rot[0]
    out[3:] = rot[1:].reshape(-1)
    out[2] = x[2] - u[2]
    return out


def test_robocentric_prediction_matches_finite_differences(rng):
    x = np.concatenate([[2.0, -1.0, 0.4], rng.uniform(-10, 10, 6)])
    A = rng.standard_normal((9, 9)) * 0.2
    P = A @ A.T
    u = np.array([0.6, 0.05, 0.1])
    Q = np.diag([1e-3, 4e-4, 2e-4])
    x2, P2 = robo_predict(x, P, u, Q)
    np.testing.assert_allclose(x2, _move(x, u), atol=1e-12)
    eps = 1e-6
    F = np.stack(
        [(_move(x + eps * e, u) - _move(x - eps * e, u)) / (2 * eps) for e in np.eye(9)], 1
    )
    G = np.stack(
        [(_move(x, u + eps * e) - _move(x, u - eps * e)) / (2 * eps) for e in np.eye(3)], 1
    )
    np.testing.assert_allclose(P2, F @ P @ F.T + G @ Q @ G.T, atol=1e-8)


def test_world_outputs_equal_world_frame_filter_before_any_update():
    """Predict, augment, predict: no observation linearization yet, so the robocentric
    filter's world pose and landmarks equal the world-frame AEKF's exactly (to rounding)."""
    R = np.diag([0.01, 3e-4])
    Q = np.diag([2e-3, 5e-4, 3e-4])
    a, b = AEKFSlam(preset="reference"), RobocentricAEKFSlam()
    for f in (a, b):
        f.predict_arrays([1.0, 0.1, 0.2], Q)
        f.update_arrays([[8.0, 0.3], [12.0, -0.5]], R)
        f.predict_arrays([0.8, -0.05, -0.1], Q)
    np.testing.assert_allclose(b.pose()[0], a.pose()[0], atol=1e-12)
    np.testing.assert_allclose(b.pose()[1], a.pose()[1], atol=1e-12)
    np.testing.assert_allclose(b.landmarks()[0], a.landmarks()[0], atol=1e-12)
    np.testing.assert_allclose(b.landmarks()[1], a.landmarks()[1], atol=1e-12)


def test_robocentric_runs_the_dense_loop_through_the_factory():
    from slam.experiments import get_experiment, run_once

    spec = get_experiment("dense-loop", n_loops=1)
    est = make_estimator("aekf-robocentric")
    assert est.name == "aekf-robocentric"
    r = run_once(spec, "aekf-robocentric", 2, {"association": "known"})
    assert r.n_duplicates == 0 and np.isfinite(r.landmark_rmse)
    assert r.frac_in_3sigma >= 0.9
