"""Mechanically scanned imaging sonar: head stepping, motion during the scan, labels."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.sonar import MSISSonar, preset
from sim.sonar.scenes import SceneObject, build_scene


def test_msis_scan_with_moving_vehicle_motion_compensated():
    """Kinematics: the vehicle moves at 1 m/s during the scan, so ping k's pose is v·k/f_ping
    further on; pole echoes mapped with each ping's own pose fall on the pole (within its
    radius + one bin + beam footprint), while mapping them with the first ping's pose does not."""
    pole = np.array([6.0, 8.0])
    sc = build_scene(
        altitude=5.0,
        seabed_cells=10,
        objects=[SceneObject("cylinder", (pole[0], pole[1], 3.0), (0.3, 4.0))],
    )
    cfg = preset(
        "msis", max_range=20.0, n_bins=400, step_deg=3.6, tilt_deg=0.0, vertical_beamwidth_deg=10.0
    )
    son = MSISSonar(
        cfg, sc.model, sc.data, sc.sites["msis"], sc.geom_object_id, sc.geom_reflectivity, sc.water
    )

    def advance(dt):
        sc.data.qvel[:6] = [1.0, 0, 0, 0, 0, 0]
        mujoco.mj_step(sc.model, sc.data, nstep=round(dt / sc.model.opt.timestep))

    scan = son.scan(sc.data, np.random.default_rng(0), advance)
    n = cfg.n_steps
    assert scan.intensity.shape == (n, cfg.n_bins)
    np.testing.assert_allclose(np.diff(scan.head_angle), np.deg2rad(cfg.step_deg))
    moved = scan.sensor_position[-1, 0] - scan.sensor_position[0, 0]
    assert moved == pytest.approx((n - 1) / cfg.ping_rate_hz * 1.0, rel=0.02)
    k, b = np.nonzero(scan.labels == 1)
    assert k.size > 0
    pts = scan.cells_to_world(k, b)[:, :2]
    d_own = np.linalg.norm(pts - pole, axis=1)
    beam_half = np.deg2rad(cfg.horizontal_beamwidth_deg) * 0.75 * scan.ranges[b]
    assert np.all(d_own < 0.3 + son.bin_width + beam_half + 0.05)
    # same cells with the first ping's pose: off by the distance travelled
    first = scan.sensor_position[0, :2] + (pts - scan.sensor_position[k, :2])
    assert np.min(np.linalg.norm(first - pole, axis=1)) > 1.0
    # hit positions are on the pole's surface
    hp = scan.hit_position[k, b, :2]
    assert np.all(np.abs(np.linalg.norm(hp - pole, axis=1) - 0.3) < son.bin_width + 0.01)


def test_msis_sector_and_static_vehicle():
    """A 90° sector has sector/step pings; without ``advance`` every pose is the same."""
    sc = build_scene(altitude=5.0, seabed_cells=10)
    cfg = preset("msis", sector_deg=90.0, step_deg=9.0, sector_center_deg=0.0)
    son = MSISSonar(
        cfg, sc.model, sc.data, sc.sites["msis"], sc.geom_object_id, sc.geom_reflectivity, sc.water
    )
    scan = son.scan(sc.data, np.random.default_rng(0))
    assert scan.head_angle.size == 10
    assert scan.head_angle[0] == pytest.approx(np.deg2rad(-45.0))
    assert np.ptp(scan.sensor_position, axis=0).max() == 0.0


def test_msis_bad_config():
    with pytest.raises(ValueError, match="step_deg"):
        preset("msis", step_deg=0.0)
    with pytest.raises(ValueError, match="sector_deg"):
        preset("msis", sector_deg=400.0)


def test_fls_and_msis_seeded_runs_bit_identical():
    """Determinism: same scene and seed → identical bytes for FLS frames and MSIS scans."""
    from sim.sonar import ForwardLookingSonar

    sc = build_scene(
        altitude=5.0,
        seabed_cells=10,
        objects=[SceneObject("box", (8.0, 2.0, 1.0), (1.0, 1.0, 1.0))],
    )
    out = []
    for _ in range(2):
        fls = ForwardLookingSonar(
            preset("blueview_p900_90", max_range=30.0, n_bins=300, n_beams=64),
            sc.model,
            sc.data,
            sc.sites["fls"],
            sc.geom_object_id,
            sc.geom_reflectivity,
            sc.water,
        )
        ms = MSISSonar(
            preset("msis", sector_deg=36.0),
            sc.model,
            sc.data,
            sc.sites["msis"],
            sc.geom_object_id,
            sc.geom_reflectivity,
            sc.water,
        )
        rng = np.random.default_rng(11)
        f = fls.frame(sc.data, rng)
        s = ms.scan(sc.data, rng)
        out.append(
            f.image.tobytes() + f.labels.tobytes() + s.intensity.tobytes() + s.labels.tobytes()
        )
    assert out[0] == out[1]
