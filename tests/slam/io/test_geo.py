"""Georeferenced outputs: slant-range correction against g = √(r² − h²), a target placed
at its known UTM position in the GeoTIFF read back by rasterio, UTM zones, covariance
ellipses and the local ↔ lon/lat round trip against slam.sidescan_slam's projection."""

from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio

from slam.frontend.bottom_track import track_bottom
from slam.frontend.mosaic import grid_mosaic, slant_range_correct
from slam.io.geo import (
    ELLIPSE_K,
    covariance_ellipse,
    landmarks_geojson,
    lonlat_from_local,
    mosaic_from_recording,
    project_lonlat,
    utm_epsg,
    write_geojson,
    write_geotiff,
)
from slam.io.sidescan import read_sidescan
from slam.io.waterfall import Waterfall

DR = 0.05  # m per slant sample


def _wf(p=40, s=400, values=None):
    nan = np.full(p, np.nan)
    img = np.ones((p, 2 * s), dtype=np.float32) if values is None else values
    return Waterfall(intensity=img, samples_per_side=s, time_s=np.arange(p) * 0.1,
                     slant_range_m=np.full(p, s * DR), frequency_hz=nan, sound_velocity_m_s=nan)


def test_slant_range_correction_matches_flat_seabed_geometry():
    """Starboard sample k holds k + 0.5 (its centre range / DR): the corrected bin at
    ground range g must hold √(g² + h²) / DR, and the water column is nan."""
    p, s, h = 5, 400, 4.0
    k = np.arange(s, dtype=np.float32) + 0.5
    img = np.concatenate([np.tile(k[::-1], (p, 1)), np.tile(k, (p, 1))], axis=1)
    ground = slant_range_correct(_wf(p, s, img), np.full(p, h), ground_res_m=0.1)
    g = (np.arange(ground.bins_per_side) + 0.5) * 0.1
    expect = np.sqrt(g**2 + h**2) / DR
    stbd = ground.image[0, ground.bins_per_side :]
    ok = np.isfinite(stbd)
    assert ok.sum() > 100
    np.testing.assert_allclose(stbd[ok], expect[ok], rtol=1e-4)
    # last finite bin: where slant range reaches the last sample centre
    assert g[ok].max() <= np.sqrt((s * DR) ** 2 - h**2)
    np.testing.assert_allclose(ground.image[0, : ground.bins_per_side][::-1][ok], expect[ok], rtol=1e-4)


def test_target_lands_at_its_utm_position_in_the_geotiff(tmp_path):
    """Track due north (heading 0) at easting 500000: a starboard target at ground range
    12 m must appear 12 m east of the track, in the GeoTIFF's own coordinates."""
    p, s, h = 60, 400, 5.0
    img = np.ones((p, 2 * s), dtype=np.float32)
    r_target = np.hypot(12.0, h)
    img[28:32, s + int(r_target / DR)] = 100.0
    ground = slant_range_correct(_wf(p, s, img), np.full(p, h), ground_res_m=0.1)
    north = 4_000_000.0 + 0.5 * np.arange(p)
    m = grid_mosaic(ground, np.full(p, 500_000.0), north, np.zeros(p), cell_m=0.5, crs="EPSG:32633")
    path = write_geotiff(tmp_path / "m.tif", m)
    with rasterio.open(path) as ds:
        assert ds.crs.to_epsg() == 32633
        band = ds.read(1)
        row, col = np.unravel_index(np.nanargmax(band), band.shape)
        x, y = ds.xy(row, col)
        assert np.isnan(ds.nodata)
    assert abs(x - 500_012.0) <= 0.75
    assert abs(y - (4_000_000.0 + 0.5 * 30)) <= 1.5


def test_utm_zone_codes_and_projection():
    assert utm_epsg(-111.51, 36.88) == 32612  # Humminbird recording, Utah
    assert utm_epsg(-68.8, 48.5) == 32619  # St. Lawrence
    assert utm_epsg(151.2, -33.9) == 32756  # Sydney, south
    e, n = project_lonlat(np.array([-111.0]), np.array([0.0]), 32612)  # central meridian
    np.testing.assert_allclose(e, 500_000.0, atol=1e-6)
    np.testing.assert_allclose(n, 0.0, atol=1e-6)
    with pytest.raises(ValueError, match="out of range"):
        utm_epsg(200.0, 0.0)


def test_local_frame_round_trip_against_sidescan_slam():
    """Second implementation: slam.sidescan_slam.local_poses_from_nav projects lon/lat to
    local metres; lonlat_from_local must invert it."""
    from slam.sidescan_slam import local_poses_from_nav

    lon = np.array([-68.80, -68.7995, -68.7990])
    lat = np.array([48.50, 48.5004, 48.5007])
    poses, _, origin = local_poses_from_nav(
        {"x": lon, "y": lat, "heading_deg": np.zeros(3)}, "degrees"
    )
    back_lon, back_lat = lonlat_from_local(poses[:, 0], poses[:, 1], origin)
    np.testing.assert_allclose(back_lon, lon, atol=1e-10)
    np.testing.assert_allclose(back_lat, lat, atol=1e-10)


def test_covariance_ellipse_axes_and_geojson(tmp_path):
    cov = np.array([[4.0, 0.0], [0.0, 1.0]])
    ring = covariance_ellipse([10.0, 20.0], cov)
    d = ring - [10.0, 20.0]
    np.testing.assert_allclose(np.abs(d[:, 0]).max(), 2.0 * ELLIPSE_K, rtol=1e-3)
    np.testing.assert_allclose(np.abs(d[:, 1]).max(), 1.0 * ELLIPSE_K, rtol=1e-2)
    np.testing.assert_allclose(ring[0], ring[-1])
    np.testing.assert_allclose(ELLIPSE_K**2, 5.991, atol=1e-3)  # chi2(2) 95 % quantile
    with pytest.raises(ValueError, match="positive semi-definite"):
        covariance_ellipse([0, 0], [[1.0, 0.0], [0.0, -1.0]])
    fc = landmarks_geojson(np.array([[0.0, 0.0]]), cov[None], lambda e, n: lonlat_from_local(e, n, (-68.8, 48.5)))
    path = write_geojson(tmp_path / "lm.geojson", fc)
    back = json.loads(path.read_text())
    kinds = [f["properties"]["kind"] for f in back["features"]]
    assert kinds == ["landmark", "covariance_ellipse"]
    np.testing.assert_allclose(back["features"][0]["geometry"]["coordinates"], [-68.8, 48.5])
    assert back["features"][0]["properties"]["sigma_major_m"] == pytest.approx(2.0)


def test_mosaic_from_synthetic_xtf_with_lonlat(tmp_path, write_xtf, rng):
    """An XTF with real-looking navigation (NavUnits 3) mosaics in its UTM zone, and the
    track's centre lies inside the GeoTIFF's bounds."""
    p, s = 40, 300
    port = np.full((p, s), 50, dtype=np.uint16)
    stbd = np.full((p, s), 50, dtype=np.uint16)
    port[:, -40:] = 2  # water column at the nadir end of the stored port row
    stbd[:, :40] = 2
    port = port + rng.integers(0, 5, size=port.shape).astype(np.uint16)
    stbd = stbd + rng.integers(0, 5, size=stbd.shape).astype(np.uint16)
    lon = np.full(p, -68.8)
    lat = 48.5 + np.arange(p) * 1e-5
    path = write_xtf(tmp_path / "nav.xtf", port, stbd, np.arange(p) * 0.5, slant=30.0,
                     lonlat=(lon, lat), heading=np.full(p, 0.5), altitude=np.full(p, 4.0))
    rec = read_sidescan(path)
    assert rec.nav.has_position.all()
    m = mosaic_from_recording(rec, track_bottom(rec.waterfall))
    assert m.crs == "EPSG:32619"
    e, n = project_lonlat(lon, lat, 32619)
    h, w = m.image.shape
    assert m.west_m < e.mean() < m.west_m + w * m.cell_m
    assert m.north_m - h * m.cell_m < n.mean() < m.north_m
    assert np.isfinite(m.image).mean() > 0.3
