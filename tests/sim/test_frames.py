"""sim.frames: round trips and agreement with scipy's Rotation (a second implementation)."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from sim.frames import (
    euler_from_wxyz,
    matrix_from_wxyz,
    wxyz_from_euler,
    wxyz_from_xyzw,
    xyzw_from_wxyz,
)

angle = st.floats(-np.pi + 1e-3, np.pi - 1e-3)


@given(angle, st.floats(-1.5, 1.5), angle)
def test_euler_matches_scipy_and_round_trips(roll, pitch, yaw):
    q = wxyz_from_euler(roll, pitch, yaw)
    ref = Rotation.from_euler("ZYX", [yaw, pitch, roll])
    np.testing.assert_allclose(matrix_from_wxyz(q), ref.as_matrix(), atol=1e-12)
    np.testing.assert_allclose(euler_from_wxyz(q), [roll, pitch, yaw], atol=1e-9)
    np.testing.assert_allclose(wxyz_from_xyzw(xyzw_from_wxyz(q)), q)
