"""Forward-looking sonar: point target cell, fan geometry, labels, errors."""

from __future__ import annotations

import numpy as np
import pytest

from sim.sonar import ForwardLookingSonar, fan_image, preset
from sim.sonar.scenes import SceneObject, build_scene

R_T, B_T = 20.0, np.deg2rad(12.0)


@pytest.fixture(scope="module")
def target_scene():
    """Thin vertical pole (radius 0.1 m, 6 m tall) at range 20 m, bearing +12° (port) from
    the FLS — a point in the horizontal image plane; vehicle 30 m above the seabed so the
    seabed stays outside the beam within range."""
    sc0 = build_scene(altitude=30.0, seabed_cells=10)
    p = sc0.data.site_xpos[sc0.sites["fls"]]
    centre = p + R_T * np.array([np.cos(B_T), np.sin(B_T), 0.0])
    sc = build_scene(
        altitude=30.0, seabed_cells=10, objects=[SceneObject("cylinder", tuple(centre), (0.1, 3.0))]
    )
    return sc, centre


def _fls(sc, **over):
    cfg = preset(
        "blueview_p900_90",
        max_range=40.0,
        n_bins=400,
        n_beams=128,
        tilt_deg=0.0,
        vertical_fov_deg=20.0,
        rays_per_beam=32,
        **over,
    )
    return ForwardLookingSonar(
        cfg, sc.model, sc.data, sc.sites["fls"], sc.geom_object_id, sc.geom_reflectivity, sc.water
    )


def test_point_target_in_expected_bin_and_beam(target_scene):
    """Analytic: a point target at range r and bearing β lands in bin (r − r_min)/δr and the
    beam whose centre bearing is nearest β (±1 beam: the pole spans ~0.6°)."""
    sc, centre = target_scene
    son = _fls(sc)
    f = son.frame(sc.data, np.random.default_rng(0))
    i, j = np.unravel_index(np.argmax(f.image), f.image.shape)
    r_front = R_T - 0.1  # the echo comes from the pole's near surface
    bin_exp = int((r_front - son.config.min_range) // son.bin_width)
    beam_exp = int(np.argmin(np.abs(f.bearings - B_T)))
    assert abs(i - bin_exp) <= 1
    assert abs(j - beam_exp) <= 1
    assert f.labels[i, j] == 1
    assert np.linalg.norm(f.hit_position[i, j, :2] - centre[:2]) < 0.1 + son.bin_width
    assert f.cell_of(r_front, B_T)[0] == bin_exp
    assert np.all(f.labels[f.labels != 1] == -1)  # nothing else in view


def test_fan_image_geometry_matches_polar(target_scene):
    """Second implementation: every fan pixel equals the polar image bilinearly sampled
    (scipy.ndimage.map_coordinates) at the pixel's own range and bearing; the target's
    fan maximum maps back to the polar maximum's range/bearing within 2 bins / 1.5 beams."""
    from scipy import ndimage

    sc, _ = target_scene
    son = _fls(sc, acoustic=dict(speckle="none"))
    f = son.frame(sc.data, np.random.default_rng(0))
    fan = fan_image(f, resolution=0.05)
    db = f.bearings[0] - f.bearings[1]
    ii, jj = np.nonzero(fan.mask)
    sel = np.random.default_rng(1).choice(ii.size, 2000, replace=False)
    rr, bb = fan.pixel_to_range_bearing(ii[sel], jj[sel])
    row = (rr - f.ranges[0]) / son.bin_width
    col = (f.bearings[0] - bb) / db
    inside = (row >= 0) & (row <= f.ranges.size - 1) & (col >= 0) & (col <= f.bearings.size - 1)
    ref = ndimage.map_coordinates(f.image.astype(np.float64), [row[inside], col[inside]], order=1)
    np.testing.assert_allclose(fan.image[ii[sel], jj[sel]][inside], ref, atol=2e-3)
    pi, pj = np.unravel_index(np.argmax(fan.image), fan.image.shape)
    r, b = fan.pixel_to_range_bearing(pi, pj)
    i, j = np.unravel_index(np.argmax(f.image), f.image.shape)
    assert abs(r - f.ranges[i]) < 2 * son.bin_width
    assert abs(b - f.bearings[j]) < 1.5 * db
    x, y = fan.pixel_to_xy(pi, pj)
    assert fan.xy_to_pixel(x, y) == (pi, pj)


def test_fls_sees_seabed_band_from_lower_beam_edge():
    """Analytic: with tilt τ and vertical FOV v, the seabed first appears at h / sin(τ + v/2)."""
    sc = build_scene(altitude=5.0, seabed_cells=10)
    son = ForwardLookingSonar(
        preset("blueview_p900_90", max_range=60.0, n_bins=600, n_beams=64, beam_pattern="rect"),
        sc.model,
        sc.data,
        sc.sites["fls"],
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
    )
    f = son.frame(sc.data, np.random.default_rng(0))
    h = float(sc.data.site_xpos[sc.sites["fls"], 2])
    first = int(np.flatnonzero((f.labels == 0).any(axis=1))[0])
    r_exp = h / np.sin(np.deg2rad(10.0 + 10.0))
    centre_beam = f.labels[:, 32]
    assert abs(f.ranges[int(np.flatnonzero(centre_beam == 0)[0])] - r_exp) < 3 * son.bin_width
    assert f.ranges[first] <= r_exp + 3 * son.bin_width


def test_fls_bad_config():
    with pytest.raises(ValueError, match="n_bins"):
        preset("blueview_p900_90", n_bins=100000)
    with pytest.raises(ValueError, match="horizontal_fov_deg"):
        preset("blueview_p900_90", horizontal_fov_deg=200.0)


def test_fls_seabed_has_no_coverage_gaps_over_ripples():
    """Continuity: over a rippled seabed (10 cm ripples, 1.5 m wavelength, far finer than the
    16-ray vertical fan's ground spacing) every range cell of the central beams between the
    first bottom return and the far edge of the seabed band is insonified (no false shadows)."""
    sc = build_scene(altitude=5.0, seabed_size=80.0, seabed_cells=320, ripples=(0.1, 1.5))
    son = ForwardLookingSonar(
        preset("blueview_p900_90", max_range=35.0, n_bins=350, n_beams=32, rays_per_beam=16),
        sc.model,
        sc.data,
        sc.sites["fls"],
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
    )
    f = son.frame(sc.data, np.random.default_rng(0))
    for beam in range(12, 20):
        col = f.labels[:, beam]
        seen = np.flatnonzero(col == 0)
        assert seen.size > 50
        assert np.all(col[seen[0] : seen[-1] + 1] == 0)


def test_fls_mean_intensity_follows_range_law_on_flat_seabed():
    """Closed form (rect beams, Lambert, flat seabed at depth h below the FLS): a range cell
    δr of a beam of azimuth width Δβ covers ground area r·Δβ·δr, so
    I(r) = SL·μ·(h/r)²·(r Δβ δr)·r⁻⁴·10^(−2αr/10); the simulated polar image (16 rays per
    beam, speckle off) follows it within 1 dB over the seabed band (but its last 3 m, where
    the last in-range ray's footprint shape is extrapolated: ≈ 1 dB there) — no steps where
    neighbouring rays' footprints meet."""
    from sim.sonar.acoustics import absorption_db_per_m

    sc = build_scene(altitude=5.0, seabed_cells=20)
    quiet = dict(
        speckle="none", noise_level_db=-100.0, tvg="none", log_compression=False, specular_db=None
    )
    cfg = preset(
        "blueview_p900_90",
        max_range=60.0,
        n_bins=600,
        n_beams=32,
        beam_pattern="rect",
        tilt_deg=10.0,
        vertical_fov_deg=20.0,
        acoustic=quiet,
    )
    son = ForwardLookingSonar(
        cfg, sc.model, sc.data, sc.sites["fls"], sc.geom_object_id, sc.geom_reflectivity, sc.water
    )
    f = son.frame(sc.data, np.random.default_rng(0))
    h = float(sc.data.site_xpos[sc.sites["fls"], 2])
    r = f.ranges
    alpha = absorption_db_per_m(cfg.frequency_hz, sc.water, sc.water.depth - h)
    sl = 10 ** (cfg.acoustic.source_level_db / 10)
    mu = 10 ** (cfg.acoustic.lambert_mu_db / 10)
    dbeta = np.deg2rad(cfg.horizontal_fov_deg) / cfg.n_beams
    expected = (
        sl * mu * (h / r) ** 2 * (r * dbeta * son.bin_width) * r**-4 * 10 ** (-0.2 * alpha * r)
    )
    sel = (r > h / np.sin(np.deg2rad(20.0)) + 1.0) & (r < cfg.max_range - 3.0)
    err = 10 * np.log10(f.image[sel][:, [4, 16, 28]] / expected[sel, None])
    assert np.max(np.abs(err)) < 1.0
