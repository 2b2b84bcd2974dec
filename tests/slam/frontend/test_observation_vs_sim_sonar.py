"""Observation model against the ray-cast sonar simulator (an independent implementation
of the same geometry): the pixel centroid of a simulated object, converted by the model,
lands where the simulator's rays hit the object."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from sim.sonar.config import preset
from sim.sonar.scenes import SceneObject, build_scene
from sim.sonar.sidescan import SideScanSonar
from slam.frontend.observation import SideScanGeometry, observe, world_xy


@pytest.mark.parametrize("y_obj", [15.0, -22.0])
def test_sss_object_centroid_maps_to_simulated_hits(y_obj):
    """Flat 2 m × 2 m × 0.1 m plate on a flat seabed, vehicle 9.9 m above it at the origin,
    heading 0: the model's (range, bearing) → world agrees with the mean ray-hit position
    of the plate's samples within 0.15 m (0.05 m samples, 0.1 m plate height bias)."""
    sc = build_scene(
        altitude=10.0,
        seabed_cells=20,
        objects=[SceneObject("box", (0.0, y_obj, 0.05), (1.0, 1.0, 0.05))],
    )
    cfg = preset("deepeye680d")
    sonar = SideScanSonar(
        cfg,
        sc.model,
        sc.data,
        (sc.sites["sss_port"], sc.sites["sss_starboard"]),
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
        "mujoco",
    )
    ping = sonar.ping(sc.data, np.random.default_rng(0))
    cols = np.flatnonzero(ping.labels == 1)
    assert cols.size > 5
    assert (cols.mean() < cfg.samples_per_side) == (y_obj > 0)  # port is the left half
    geom = SideScanGeometry(
        slant_range_max=cfg.max_range,
        slant_range_min=cfg.min_range,
        samples_per_side=cfg.samples_per_side,
        altitude=float(ping.altitude),
        along_track_spacing=0.1,
        transducer_y=float(abs(ping.sensor_position[0, 1])),
    )
    rb = observe(geom, (0.0, float(cols.mean())), (1.0, float(np.ptp(cols) + 1)))
    est = world_xy(np.zeros(3), rb.z)
    true = ping.hit_position[cols, :2].mean(axis=0)
    assert np.linalg.norm(est - true) < 0.15
    assert rb.z[1] == pytest.approx(np.sign(y_obj) * np.pi / 2)


def test_fls_polar_object_centroid_maps_to_simulated_hits():
    """3 m plate 19 m ahead, 6 m to port, FLS 5 m above the seabed (tilt 10°): the polar
    centroid, projected with the altitude, agrees with the mean ray hit within 0.2 m."""
    from sim.sonar.fls import ForwardLookingSonar
    from slam.frontend.observation import FLSGeometry

    sc = build_scene(
        altitude=5.0,
        seabed_cells=20,
        objects=[SceneObject("box", (20.0, 6.0, 0.05), (1.5, 1.5, 0.05))],
    )
    cfg = preset(
        "blueview_p900_90",
        max_range=40.0,
        n_bins=400,
        n_beams=128,
        range_resolution=0.05,
        rays_per_beam=64,
    )
    son = ForwardLookingSonar(
        cfg,
        sc.model,
        sc.data,
        sc.sites["fls"],
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
        "mujoco",
    )
    fr = son.frame(sc.data, np.random.default_rng(0))
    ii, jj = np.nonzero(fr.labels == 1)
    assert ii.size > 10
    geom = FLSGeometry(
        range_max=cfg.max_range,
        range_min=cfg.min_range,
        n_bins=cfg.n_bins,
        n_beams=cfg.n_beams,
        horizontal_fov_deg=cfg.horizontal_fov_deg,
        beamwidth_deg=cfg.beamwidth_deg,
        altitude=float(fr.sensor_position[2] - 0.1),
    )
    rb = observe(geom, (ii.mean(), jj.mean()), (np.ptp(ii) + 1.0, np.ptp(jj) + 1.0))
    est = world_xy(np.r_[fr.sensor_position[:2], 0.0], rb.z)
    assert np.linalg.norm(est - fr.hit_position[ii, jj, :2].mean(axis=0)) < 0.2


def test_fls_fan_pixels_agree_with_simulator_fan_image(rng):
    """Our Cartesian-fan pixel → (range, bearing) equals sim.sonar.fls.FanImage's mapping."""
    from sim.sonar.fls import FanImage
    from slam.frontend.observation import FLSGeometry, range_bearing_from_pixels

    fan = FanImage(np.zeros((400, 566)), np.ones((400, 566), bool), 40.0, 28.28, 0.1)
    geom = FLSGeometry(
        range_max=40.0,
        layout="cartesian",
        image_shape=(400, 566),
        fan_resolution=0.1,
        fan_y_max=28.28,
    )
    pix = np.column_stack([rng.integers(0, 380, 50), rng.integers(0, 566, 50)]).astype(float)
    r, b, _ = range_bearing_from_pixels(geom, pix)
    r_sim, b_sim = fan.pixel_to_range_bearing(pix[:, 0], pix[:, 1])
    np.testing.assert_allclose(r, r_sim, rtol=1e-12)
    np.testing.assert_allclose(b, b_sim, atol=1e-12)


def test_msis_cells_agree_with_simulator_cells_to_world(rng):
    """Our MSIS (row, bin) → (range, bearing) equals MSISScan.cells_to_world for a
    stationary vehicle (both assume the beam axis, zero tilt)."""
    from sim.sonar.msis import MSISSonar
    from slam.frontend.observation import MSISGeometry, range_bearing_from_pixels

    sc = build_scene(altitude=2.0, seabed_cells=10)
    cfg = preset("msis", step_deg=6.0, rays_vertical=8, rays_horizontal=3)
    scan = MSISSonar(
        cfg,
        sc.model,
        sc.data,
        sc.sites["msis"],
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
        "mujoco",
    ).scan(sc.data, rng)
    geom = MSISGeometry(
        range_max=cfg.max_range,
        range_min=cfg.min_range,
        n_bins=cfg.n_bins,
        step_deg=cfg.step_deg,
        sector_deg=cfg.sector_deg,
        sector_center_deg=cfg.sector_center_deg,
    )
    k = rng.integers(0, scan.head_angle.size, 40)
    i = rng.integers(0, cfg.n_bins, 40)
    r, b, _ = range_bearing_from_pixels(geom, np.column_stack([k, i]).astype(float))
    world = scan.cells_to_world(k, i)
    sensor = scan.sensor_position[k]
    np.testing.assert_allclose(
        world[:, :2] - sensor[:, :2], np.column_stack([r * np.cos(b), r * np.sin(b)]), atol=1e-9
    )
