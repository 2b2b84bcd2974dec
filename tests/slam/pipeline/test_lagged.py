"""The fixed-lag SLAM feeder (slam.pipeline.lagged) and the increment composition it uses
(slam.estimators.aekf.compose_odometry)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam.estimators.aekf import compose_odometry
from slam.pipeline.lagged import LaggedSlam, apply_increment
from slam.types import Odometry, RangeBearing

inc = st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-3, 3)).map(
    lambda t: np.array(t, dtype=float)
)


@settings(max_examples=50, deadline=None)
@given(inc, inc, st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-3, 3)))
def test_composed_increment_equals_sequential_application(d1, d2, p0):
    """Composition is exact for the mean: applying d1 then d2 equals applying compose(d1, d2)."""
    pose = np.array(p0)
    seq = apply_increment(apply_increment(pose, d1), d2)
    d, _ = compose_odometry(d1, np.zeros((3, 3)), d2, np.zeros((3, 3)))
    one = apply_increment(pose, d)
    assert np.allclose(seq[:2], one[:2], atol=1e-9)
    assert np.isclose(np.cos(seq[2] - one[2]), 1.0)


def test_composed_covariance_matches_monte_carlo(rng):
    """First-order covariance of a composed increment agrees with sampling (small noise)."""
    d1, d2 = np.array([1.0, 0.2, 0.3]), np.array([2.0, -0.5, 0.1])
    C1, C2 = np.diag([1e-4, 2e-4, 1e-5]), np.diag([3e-4, 1e-4, 2e-5])
    _, C = compose_odometry(d1, C1, d2, C2)
    n = 40000
    a = d1 + rng.multivariate_normal(np.zeros(3), C1, n)
    b = d2 + rng.multivariate_normal(np.zeros(3), C2, n)
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    samples = np.column_stack(
        [
            a[:, 0] + c * b[:, 0] - s * b[:, 1],
            a[:, 1] + s * b[:, 0] + c * b[:, 1],
            a[:, 2] + b[:, 2],
        ]
    )
    assert np.allclose(np.cov(samples.T), C, rtol=0.05, atol=2e-6)


class _Recorder:
    """Minimal estimator: integrates odometry, records each call with the pose at that time."""

    name = "recorder"

    def __init__(self):
        self.x = np.zeros(3)
        self.P = np.zeros((3, 3))
        self.calls = []

    def predict(self, odometry):
        self.x = apply_increment(self.x, odometry.delta)
        self.calls.append(("predict", odometry.t))

    def update(self, observations):
        self.calls.append(("update", observations[0].t, self.x.copy()))

    def pose(self):
        return self.x.copy(), self.P.copy()

    def landmarks(self):
        return np.zeros((0, 2)), np.zeros((0, 2, 2))


def test_late_observation_applied_at_pose_of_its_ping():
    """A detection made at t=0.3 but delivered at t=1.0 updates the filter when its pose is
    the pose at t=0.3 (vehicle moving 1 m per 0.1 s along x: x = 3 m), not at t=1.0."""
    est = _Recorder()
    lag = LaggedSlam(est)
    for k in range(1, 11):
        lag.add_odometry(Odometry([1.0, 0, 0], np.eye(3) * 1e-4, t=0.1 * k))
    obs = RangeBearing([5.0, np.pi / 2], np.eye(2) * 0.01, t=0.3)
    lag.add_observations(0.3, [obs])
    lag.release(0.5)
    upd = [c for c in est.calls if c[0] == "update"]
    assert len(upd) == 1 and np.isclose(upd[0][2][0], 3.0)
    assert np.isclose(lag.t_done, 0.5)
    t, cur = lag.current_pose()  # lagged estimate + queued odometry = pose now
    assert np.isclose(t, 1.0) and np.isclose(cur[0], 10.0)
    with pytest.raises(ValueError, match="older than the released horizon"):
        lag.add_observations(0.2, [obs])


def test_odometry_between_observations_is_one_predict_unless_a_history_node_is_due():
    """With no observation, increments are composed into one predict; with record_dt = 2 s
    the history gets nodes at 2 s and 4 s and at the end (5 s), and the final pose is the
    same either way (composition is exact for the mean)."""
    poses = []
    for record_dt, n_pred in ((100.0, 1), (2.0, 3)):
        est = _Recorder()
        lag = LaggedSlam(est, record_dt=record_dt)
        for k in range(1, 6):
            lag.add_odometry(Odometry([1.0, 0, 0.1], np.eye(3) * 1e-4, t=float(k)))
        lag.release(5.0)
        assert [c[0] for c in est.calls] == ["predict"] * n_pred and lag.t_done == 5.0
        poses.append(est.x)
    assert np.allclose(poses[0], poses[1])
    assert [r.t for r in lag.history] == [2.0, 4.0, 5.0]
