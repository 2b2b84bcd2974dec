"""NavSuite's scalar replacements of library calls give the library's bits:
``_yaw_rotated`` against scipy's Rotation composition (the second implementation)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from sim.navigation.suite import _yaw_rotated


def test_yaw_rotated_equals_scipy_bit_for_bit():
    """20,000 random quaternions (some off unit norm by 1e-15, as MuJoCo's are) and yaw
    offsets in (-4, 4) rad: the same bytes as scipy's from_euler('z') * from_quat."""
    rng = np.random.default_rng(3)
    for k in range(20_000):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        if k % 2:
            q = q * (1.0 + rng.normal() * 1e-15)
        d = rng.uniform(-4.0, 4.0) if k % 3 else rng.uniform(-0.05, 0.05)
        ref = (Rotation.from_euler("z", d) * Rotation.from_quat(np.roll(q, -1))).as_quat()
        np.testing.assert_array_equal(_yaw_rotated(q, d), np.roll(ref, 1))
