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


def test_single_quaternion_fast_path_is_bit_identical_to_the_array_path():
    """Second implementation: the (N, 4) array path of the same function, bit for bit."""
    from sim.frames import euler_from_wxyz, matrix_from_wxyz

    rng = np.random.default_rng(4)
    for _ in range(2000):
        q = rng.normal(size=4) * rng.uniform(0.1, 3.0)
        np.testing.assert_array_equal(matrix_from_wxyz(q), matrix_from_wxyz(q[None])[0])
        e = euler_from_wxyz(q)
        w, x, y, z = q / np.linalg.norm(q, axis=-1)
        ref = [
            np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)),
            np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0)),
            np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)),
        ]
        np.testing.assert_array_equal(e, ref)


def test_rotvec_conversions_match_scipy_from_tiny_to_half_turn_angles():
    """Independent implementation: scipy's Rotation, angles 1e-8 rad to pi."""
    from scipy.spatial.transform import Rotation

    from sim.frames import matrix_from_rotvec, rotvec_from_matrix

    rng = np.random.default_rng(5)
    for _ in range(3000):
        axis = rng.normal(size=3)
        rv = axis / np.linalg.norm(axis) * 10 ** rng.uniform(-8, np.log10(np.pi))
        M = Rotation.from_rotvec(rv).as_matrix()
        np.testing.assert_allclose(rotvec_from_matrix(M), rv, rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(matrix_from_rotvec(rv), M, rtol=0, atol=1e-15)
