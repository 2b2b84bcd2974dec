"""Observation model: pixel centroid → (range, bearing) → world round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from slam.frontend.observation import (
    FLSGeometry,
    MSISGeometry,
    SideScanGeometry,
    body_xy,
    observe,
    observe_regions,
    pixel_from_body,
    range_bearing_from_pixels,
    world_xy,
)
from slam.types import RangeBearing

SSS = SideScanGeometry(
    slant_range_max=30.0,
    samples_per_side=1000,
    altitude=8.0,
    along_track_spacing=0.15,
    along_track_beamwidth_deg=0.3,
)
FLS_P = FLSGeometry(
    range_max=50.0,
    range_min=0.5,
    n_bins=512,
    n_beams=256,
    horizontal_fov_deg=90.0,
    beamwidth_deg=1.0,
    altitude=3.0,
)
FLS_C = FLSGeometry(range_max=40.0, layout="cartesian", image_shape=(400, 600), beamwidth_deg=1.0)
MSIS = MSISGeometry(range_max=50.0, range_min=0.3, n_bins=500, step_deg=1.8, beamwidth_deg=3.0)

pose_st = st.tuples(st.floats(-100, 100), st.floats(-100, 100), st.floats(-np.pi, np.pi))


def _roundtrip(geom, xy_body, pose, bound):
    """body point → continuous pixel → integer pixel (what a segmenter would report) →
    RangeBearing → world; compare with the true world point."""
    pix = np.rint(pixel_from_body(geom, xy_body))
    rb = observe(geom, tuple(pix[0]), ref_row=0.0 if isinstance(geom, SideScanGeometry) else None)
    assert isinstance(rb, RangeBearing)
    c, s = np.cos(pose[2]), np.sin(pose[2])
    true_world = np.array(pose[:2]) + np.array([[c, -s], [s, c]]) @ xy_body[0]
    err = np.linalg.norm(world_xy(np.array(pose), rb.z) - true_world)
    assert err <= bound + 1e-9, (err, bound)
    return rb


@settings(max_examples=60, deadline=None)
@given(pose=pose_st, along=st.floats(-3, 3), ground=st.floats(2.0, 28.0), port=st.booleans())
def test_sss_roundtrip_within_resolution(pose, along, ground, port):
    """Half a ping along track plus half a sample of slant range mapped to ground
    (dg/dr = r/g) bound the quantization error."""
    y = ground if port else -ground
    slant = np.hypot(ground, SSS.altitude)
    assume(slant < SSS.slant_range_max - SSS.bin_width)
    bound = np.hypot(SSS.along_track_spacing / 2, (slant / ground) * SSS.bin_width / 2)
    rb = _roundtrip(SSS, np.array([[along, y]]), pose, bound)
    if abs(along) < 1e-9:
        assert rb.z[1] == pytest.approx(np.pi / 2 if port else -np.pi / 2)


@settings(max_examples=60, deadline=None)
@given(pose=pose_st, rho=st.floats(4.0, 48.0), theta=st.floats(-0.78, 0.78))
def test_fls_polar_roundtrip_within_resolution(pose, rho, theta):
    xy = np.array([[rho * np.cos(theta), rho * np.sin(theta)]])
    slant = np.hypot(rho, FLS_P.altitude)
    assume(slant <= FLS_P.range_max - FLS_P.bin_width)
    bound = np.hypot((slant / rho) * FLS_P.bin_width / 2, rho * FLS_P.beam_spacing / 2)
    _roundtrip(FLS_P, xy, pose, bound)


@settings(max_examples=60, deadline=None)
@given(pose=pose_st, x=st.floats(1.0, 39.0), y=st.floats(-29.0, 29.0))
def test_fls_cartesian_roundtrip_within_resolution(pose, x, y):
    bound = FLS_C.pixel_size / np.sqrt(2)
    _roundtrip(FLS_C, np.array([[x, y]]), pose, bound)


@settings(max_examples=60, deadline=None)
@given(pose=pose_st, rho=st.floats(1.0, 49.0), theta=st.floats(-np.pi, np.pi))
def test_msis_roundtrip_within_resolution(pose, rho, theta):
    xy = np.array([[rho * np.cos(theta), rho * np.sin(theta)]])
    bound = np.hypot(MSIS.bin_width / 2, rho * np.radians(MSIS.step_deg) / 2)
    _roundtrip(MSIS, xy, pose, bound)


def test_sss_analytic_case_and_covariance():
    """Starboard sample 499 (centre 15.015 m slant) at 8 m altitude: g = sqrt(r² − h²),
    bearing −90°; σ_r² = (bin² + (3 bins)²)/12 scaled by (r/g)²; σ_θ² = σ_x²/g²."""
    rb = observe(SSS, (10.0, 1000 + 499), extent_rc=(2.0, 3.0))
    r = 0.03 * 499.5
    g = np.sqrt(r**2 - 64.0)
    assert rb.z[0] == pytest.approx(g)
    assert rb.z[1] == pytest.approx(-np.pi / 2)
    var_g = (r / g) ** 2 * 0.03**2 * (1 + 9) / 12
    var_x = (0.15**2 * (1 + 4) + (r * np.radians(0.3)) ** 2) / 12
    np.testing.assert_allclose(rb.R, np.diag([var_g, var_x / g**2]), rtol=1e-9, atol=1e-15)
    port = observe(SSS, (10.0, 999 - 499), extent_rc=(2.0, 3.0))
    assert port.z[0] == pytest.approx(g) and port.z[1] == pytest.approx(np.pi / 2)


def test_sss_along_track_offset_bends_bearing():
    """A detection 20 pings (3 m) behind the reference ping on port at ground 10 m:
    bearing = atan2(10, −3)."""
    col = pixel_from_body(SSS, np.array([[0.0, 10.0]]))[0, 1]
    r, b, _ = range_bearing_from_pixels(SSS, np.array([[0.0, col]]), ref_row=20.0)
    assert b[0] == pytest.approx(np.arctan2(10.0, -3.0))
    assert r[0] == pytest.approx(np.hypot(10.0, 3.0))


def test_larger_region_means_larger_covariance():
    small = observe(FLS_P, (200.0, 100.0), (1.0, 1.0))
    big = observe(FLS_P, (200.0, 100.0), (20.0, 20.0))
    assert np.all(np.diag(big.R) > np.diag(small.R))
    assert np.all(np.linalg.eigvalsh(big.R) > 0)


def test_vectorized_regions_equal_single_calls():
    cents = np.array([[5.0, 100.0], [50.0, 1700.0], [70.0, 1500.0]])
    ext = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    many = observe_regions(SSS, cents, ext)
    for k in range(3):
        one = observe(SSS, tuple(cents[k]), tuple(ext[k]))
        np.testing.assert_allclose(many[k].z, one.z)
        np.testing.assert_allclose(many[k].R, one.R)
    assert observe_regions(SSS, np.zeros((0, 2)), np.zeros((0, 2))) == []
    mixed = np.array([[5.0, 100.0], [5.0, 1010.0], [5.0, 1500.0]])  # middle: water column
    with pytest.raises(ValueError, match="water column"):
        observe_regions(SSS, mixed, (1.0, 1.0))
    kept = observe_regions(SSS, mixed, (1.0, 1.0), on_invalid="skip")
    assert [k.meta["index"] for k in kept] == [0, 2]
    np.testing.assert_allclose(body_xy(np.array([2.0, np.pi / 2])), [0.0, 2.0], atol=1e-12)


def test_bad_inputs():
    with pytest.raises(ValueError, match="water column"):
        observe(SSS, (0.0, 1000 + 10))  # 0.3 m slant < 8 m altitude
    with pytest.raises(ValueError, match="column outside"):
        observe(SSS, (0.0, 5000.0))
    with pytest.raises(ValueError, match="finite"):
        observe(SSS, (np.nan, 10.0))
    with pytest.raises(ValueError, match="polar image"):
        observe(FLS_P, (-5.0, 10.0))
    with pytest.raises(ValueError, match="slant_range_min"):
        SideScanGeometry(
            slant_range_max=10,
            samples_per_side=10,
            altitude=1,
            along_track_spacing=0.1,
            slant_range_min=20,
        )
    with pytest.raises(ValueError, match="layout"):
        FLSGeometry(range_max=10, n_bins=10, n_beams=10, layout="fan")
    with pytest.raises(ValueError, match="image_shape"):
        FLSGeometry(range_max=10, layout="cartesian")
    with pytest.raises(ValueError, match="altitude"):
        SideScanGeometry(
            slant_range_max=10, samples_per_side=10, altitude=-1, along_track_spacing=0.1
        )


def test_sss_geometry_from_waterfall_altitude_and_spacing():
    """A waterfall whose seabed starts 100 samples from nadir (3 cm samples → 3.0 m, +½
    sample) and whose nav says 2 knots at 10 pings/s → Δa = 2·0.514444·0.1 m."""
    from slam.frontend.observation import sss_geometry_from_waterfall
    from slam.io.waterfall import Waterfall

    s, p = 1000, 20
    side = np.ones((p, s), np.float32)
    side[:, :100] = 0.01
    wf = Waterfall(
        intensity=np.concatenate([side[:, ::-1], side], axis=1),
        samples_per_side=s,
        time_s=np.arange(p) * 0.1,
        slant_range_m=np.full(p, 30.0),
        frequency_hz=np.full(p, 600e3),
        sound_velocity_m_s=np.full(p, 1500.0),
        nav={"speed_knots": np.full(p, 2.0), "altitude_m": np.full(p, 2.9)},
    )
    g = sss_geometry_from_waterfall(wf, 5)
    assert g.altitude == pytest.approx(100.5 * 0.03)
    assert g.along_track_spacing == pytest.approx(2 * 0.514444 * 0.1)
    assert sss_geometry_from_waterfall(wf, 5, altitude="nav").altitude == pytest.approx(2.9)
    wf2 = Waterfall(
        wf.intensity, s, wf.time_s, wf.slant_range_m, wf.frequency_hz, wf.sound_velocity_m_s
    )
    with pytest.raises(ValueError, match="along_track_spacing"):
        sss_geometry_from_waterfall(wf2, 5)
    with pytest.raises(ValueError, match="out of range"):
        sss_geometry_from_waterfall(wf, 99)
