"""The fleet's fusion inputs saved by a run (fleet_maps.npz) re-run the same fusion offline."""

from __future__ import annotations

import numpy as np

from sim.runner.fleet import load_fleet_inputs, save_fleet_inputs
from slam.fleet import GpsFix, VehicleMap, fuse_maps


def test_saved_inputs_reproduce_the_fused_map(tmp_path):
    rng = np.random.default_rng(0)
    L = rng.uniform(-40, 40, (6, 2))
    maps = []
    for k, idx in enumerate(([0, 1, 2, 3], [2, 3, 4, 5])):
        x = np.r_[rng.normal(0, 1, 2), 0.3, (L[idx] + rng.normal(0, 0.2, (4, 2))).ravel()]
        A = rng.normal(size=(11, 11)) * 0.1
        maps.append(VehicleMap(x, A @ A.T + 0.04 * np.eye(11), f"v{k}"))
    gps = [GpsFix(1, [0.5, -0.2], np.eye(2) * 4.0)]
    path = tmp_path / "fleet_maps.npz"
    save_fleet_inputs(path, maps, gps, np.zeros((2, 3)), L)
    maps2, gps2, poses, truth = load_fleet_inputs(path)
    np.testing.assert_array_equal(poses, np.zeros((2, 3)))
    assert [m.name for m in maps2] == ["v0", "v1"]
    np.testing.assert_array_equal(truth, L)
    a, b = fuse_maps(maps, gps), fuse_maps(maps2, gps2)
    assert a.n_paired == b.n_paired == 2
    np.testing.assert_array_equal(a.landmarks, b.landmarks)
    np.testing.assert_array_equal(a.cov, b.cov)
