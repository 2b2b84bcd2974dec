"""Sub-mapping AEKF: one local map reproduces the plain AEKF; with small local maps the
chain of origins composes poses exactly as the plain filter would, and the cost per
update depends on the local map size only."""

from __future__ import annotations

import numpy as np
import pytest

from slam.estimators import make_estimator
from slam.estimators.aekf import AEKFSlam, predict
from slam.estimators.aekf_submap import SubmapAEKFSlam, compose_pose
from slam.experiments import get_experiment
from slam.sim2d import simulate_run


@pytest.fixture(autouse=True, scope="module")
def _single_blas_thread():
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


@pytest.fixture(scope="module")
def run():
    spec = get_experiment("dense-loop", n_loops=1)
    return simulate_run(spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(5))


def test_one_large_submap_equals_plain_aekf(run):
    a, b = AEKFSlam(), make_estimator("aekf-submap", max_landmarks=10_000)
    for i in range(300):
        for f in (a, b):
            f.predict(run.odometry(i))
            f.update(run.observations(i))
    np.testing.assert_allclose(b.pose()[0], a.pose()[0])
    np.testing.assert_allclose(b.pose()[1], a.pose()[1], atol=1e-15)
    np.testing.assert_allclose(b.landmarks()[0], a.landmarks()[0])
    assert b.n_submaps == 1


def test_compose_pose_equals_ekf_prediction():
    """Origin ⊕ local pose with independent covariances = an EKF prediction of the origin
    by the local pose used as an odometry increment (second implementation)."""
    o, Po = np.array([3.0, -1.0, 0.7]), np.diag([0.1, 0.2, 0.01])
    v, Pv = np.array([5.0, 2.0, -0.3]), np.diag([0.3, 0.1, 0.02])
    x1, P1 = compose_pose(o, Po, v, Pv)
    x2, P2 = predict(o, Po, v, Pv)
    np.testing.assert_allclose(x1, x2)
    np.testing.assert_allclose(P1, P2)


def test_small_submaps_bound_the_local_state_and_stay_consistent(run):
    f = SubmapAEKFSlam(max_landmarks=8, jacobians="fej")
    for i in range(run.n_scans):
        f.predict(run.odometry(i))
        f.update(run.observations(i))
        assert f.local.n_landmarks <= 8
    assert f.n_submaps >= 3
    lm, cov = f.landmarks()
    assert lm.shape[0] == f.labels.size
    # every global landmark lies within 3σ of its true position (consistent composition)
    e = run.landmarks[f.labels] - lm
    d2 = np.einsum("ni,nij,nj->n", e, np.linalg.inv(cov), e)
    assert np.mean(d2 <= 9.0) >= 0.9
    with pytest.raises(ValueError, match="max_landmarks"):
        SubmapAEKFSlam(max_landmarks=0)
