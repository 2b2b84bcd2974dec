"""SLAM metrics against published numbers and hand-made cases."""

from __future__ import annotations

import numpy as np
import pytest

from slam.metrics import (
    chi2_bounds,
    fraction_inside,
    landmark_errors,
    landmark_mahalanobis,
    named_landmark_errors,
    nees,
    trajectory_rmse,
)


def test_chi2_bounds_published_values_and_monte_carlo():
    """Issue/Bar-Shalom: n = 3, 50 runs → [2.36, 3.72]; and a Monte Carlo of averages of
    50 χ²₃ draws falls inside about 95 % of the time (independent of scipy's ppf)."""
    lo, hi = chi2_bounds(3, 50)
    assert round(lo, 2) == 2.36 and round(hi, 2) == 3.72
    rng = np.random.default_rng(1)
    avg = rng.chisquare(3, size=(20_000, 50)).mean(axis=1)
    assert abs(fraction_inside(avg, (lo, hi)) - 0.95) < 0.01
    with pytest.raises(ValueError, match="n_runs"):
        chi2_bounds(3, 0)


def test_landmark_errors_assignment_labels_and_duplicates():
    true = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    est = np.array([[10.5, 0.0], [0.0, 0.3], [0.2, 0.0], [50.0, 50.0]])
    le = landmark_errors(est, true, max_distance=5.0)
    pairs = dict(zip(le.true_index.tolist(), le.est_index.tolist()))
    assert pairs == {0: 2, 1: 0}  # nearest one-to-one; the farther duplicate is unmatched
    assert le.n_unmatched_est == 2 and le.n_unmatched_true == 1
    np.testing.assert_allclose(le.rmse, np.sqrt((0.2**2 + 0.5**2) / 2))
    # with labels: the label decides, even if another estimate is closer
    le2 = landmark_errors(est, true, est_labels=[1, 0, -1, -1])
    assert dict(zip(le2.true_index.tolist(), le2.est_index.tolist()))[0] == 1
    named = named_landmark_errors(le2, est, true, {"A": (0.1, 0.1), "C": (20, 0)})
    assert named["A"] == pytest.approx(0.3) and np.isnan(named["C"])


def test_nees_hand_case_and_mahalanobis():
    err = np.array([[1.0, 0.0, 0.0], [0.0, 2.0, 0.1]])
    P = np.stack([np.diag([1.0, 1.0, 1.0]), np.diag([4.0, 1.0, 0.01])])
    np.testing.assert_allclose(nees(err, P), [1.0, 4.0 + 1.0])
    md = landmark_mahalanobis(np.zeros((1, 2)), np.diag([4.0, 1.0])[None], np.array([[2.0, 1.0]]))
    np.testing.assert_allclose(md, [np.sqrt(2.0)])


def test_trajectory_rmse_wraps_heading():
    t = np.array([[0.0, 0.0, np.pi - 0.01], [3.0, 4.0, 0.0]])
    e = np.array([[0.0, 0.0, -np.pi + 0.01], [0.0, 0.0, 0.0]])
    pos, head = trajectory_rmse(t, e)
    assert pos == pytest.approx(np.sqrt(25 / 2))
    assert head == pytest.approx(np.sqrt(0.02**2 / 2))
