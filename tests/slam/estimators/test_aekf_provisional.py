"""Delayed confirmation of new landmarks (``AEKFConfig.provisional_misses``): one outlying
observation of a known landmark, beyond the augment gate, must not leave a second
landmark where there is one object."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.estimators.aekf import AEKFConfig, AEKFSlam

R = np.diag([0.1**2, math.radians(1.0) ** 2])
Q = np.diag([0.01**2, 0.01**2, math.radians(0.05) ** 2])


def _observe(x, lm, rng, bearing_offset=0.0):
    d = lm - x[:2]
    z = np.array([np.hypot(*d), math.atan2(d[1], d[0]) - x[2] + bearing_offset])
    return (z + rng.standard_normal(2) * np.sqrt(np.diag(R)))[None, :]


@pytest.mark.parametrize("provisional", [None, 3])
def test_one_outlier_leaves_no_duplicate_only_with_delayed_confirmation(provisional):
    """A vehicle creeps past one landmark 20 m ahead, observing it every scan; on scan 5
    the bearing is 8σ off (beyond the augment gate: a new landmark is started). The truth
    is one object: with ``provisional_misses`` the once-seen landmark is removed once it
    has been in view and unobserved for that many scans; without it, it stays."""
    rng = np.random.default_rng(4)
    lm = np.array([20.0, 0.0])
    f = AEKFSlam(provisional_misses=provisional)
    x_true = np.zeros(3)
    for k in range(15):
        x_true = x_true + np.array([0.2, 0.0, 0.0])
        f.predict_arrays([0.2, 0.0, 0.0], Q)
        off = 8.0 * math.radians(1.0) if k == 5 else 0.0
        f.update_arrays(_observe(x_true, lm, rng, off), R)
        if k == 5:
            assert f.n_landmarks == 2  # the outlier started a landmark of its own
    assert f.n_landmarks == (1 if provisional else 2)
    means, _ = f.landmarks()
    assert np.linalg.norm(means[0] - lm) < 0.3  # the landmark kept is the object's


def test_a_new_landmark_seen_again_is_kept():
    """Two objects, each observed on every scan: neither is removed (both confirmed)."""
    rng = np.random.default_rng(5)
    lms = np.array([[15.0, 5.0], [18.0, -6.0]])
    f = AEKFSlam(provisional_misses=1)
    x_true = np.zeros(3)
    for _ in range(10):
        x_true = x_true + np.array([0.2, 0.0, 0.0])
        f.predict_arrays([0.2, 0.0, 0.0], Q)
        z = np.vstack([_observe(x_true, p, rng) for p in lms])
        f.update_arrays(z, R)
    assert f.n_landmarks == 2


def test_provisional_misses_must_be_positive():
    with pytest.raises(ValueError, match="provisional_misses must be >= 1 or None, got 0"):
        AEKFConfig(provisional_misses=0)
