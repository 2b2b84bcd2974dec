"""slam.types: validation and angle wrapping (property test against the definition)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from slam.types import Odometry, RangeBearing, wrap_angle


@given(st.floats(-1e4, 1e4, allow_nan=False))
def test_wrap_angle_in_range_and_equivalent(a):
    w = wrap_angle(a)
    assert -np.pi < w <= np.pi
    # same direction: sin and cos agree
    assert np.isclose(np.sin(w), np.sin(a), atol=1e-9)
    assert np.isclose(np.cos(w), np.cos(a), atol=1e-9)


def test_wrap_angle_keeps_plus_pi_and_vectorizes():
    assert wrap_angle(np.pi) == np.pi
    np.testing.assert_allclose(wrap_angle(np.array([3 * np.pi, -np.pi, 0.5])), [np.pi, np.pi, 0.5])


def test_rejects_non_finite_and_bad_shapes():
    with pytest.raises(ValueError, match="finite"):
        Odometry(delta=[np.nan, 0, 0], cov=np.eye(3))
    with pytest.raises(ValueError, match=r"shape \(3, 3\)"):
        Odometry(delta=[0, 0, 0], cov=np.eye(2))
    with pytest.raises(ValueError, match="range must be > 0"):
        RangeBearing(z=[0.0, 0.1], R=np.eye(2))
