"""FLS / MSIS polar front end (slam.frontend.polar)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.frontend.polar import (
    FLS_FRONTEND,
    PersistenceFilter,
    PolarFrontend,
    PolarFrontendConfig,
    condition_polar,
    footprint_gap_groups,
    region_moments,
    xy_to_range_bearing,
)
from slam.pipeline import segmenter

DR_DB = 50.0  # display dynamic range of the synthetic frames (the FLS preset's)
N_BINS, N_BEAMS, R_MIN, R_MAX, FOV = 256, 128, 0.5, 30.0, math.radians(90.0)
BIN = (R_MAX - R_MIN) / N_BINS
RANGES = R_MIN + (np.arange(N_BINS) + 0.5) * BIN
BEARINGS = (0.5 - (np.arange(N_BEAMS) + 0.5) / N_BEAMS) * FOV


def _frame(rng, target_rb=None, contrast_db=15.0, size=(6, 4)):
    """Synthetic log-compressed FLS frame: fully developed speckle (exponential intensity,
    i.e. Rayleigh amplitude) over a seabed whose level falls 20 dB across the range, no
    return nearer than 12 m (the vertical beam misses the seabed), and optionally a
    bright patch of size (bins, beams) centred at target (range m, bearing rad)."""
    level = 10 ** (-2.0 * (RANGES - 12.0) / (R_MAX - 12.0))
    inten = rng.exponential(1.0, (N_BINS, N_BEAMS)) * level[:, None]
    if target_rb is not None:
        i = int(np.argmin(np.abs(RANGES - target_rb[0])))
        j = int(np.argmin(np.abs(BEARINGS - target_rb[1])))
        sl = np.s_[i - size[0] // 2 : i + size[0] // 2, j - size[1] // 2 : j + size[1] // 2]
        inten[sl] *= 10 ** (contrast_db / 10)
    db = 10 * np.log10(np.maximum(inten, 1e-12)) + 30.0  # display: 0..DR_DB dB -> 0..1
    img = np.clip(db / DR_DB, 0.0, 1.0)
    img[RANGES < 12.0, :] = 0.0
    return img.astype(np.float32)


def _frontend(config=FLS_FRONTEND) -> PolarFrontend:
    return PolarFrontend(
        "fls",
        segmenter("improved-otsu", "auto"),
        ranges=RANGES,
        angles=BEARINGS,
        bin_width=BIN,
        angular_cell=FOV / N_BEAMS,
        log_compressed=True,
        dynamic_range_db=DR_DB,
        config=config,
    )


def test_region_moments_of_a_bar_match_uniform_variance_length_squared_over_12():
    """A 1-cell-wide bar of n unit cells along x: variance (n² - 1)/12 (discrete uniform),
    centroid at the middle, zero cross-track variance; a second label is independent."""
    lab = np.zeros((3, 12), int)
    lab[1, 1:11] = 1  # 10 cells
    lab[0, 0] = 2
    y, x = np.mgrid[0:3, 0:12].astype(float)
    c, M, n = region_moments(lab, 2, x, y)
    assert n.tolist() == [10, 1]
    np.testing.assert_allclose(c[0], [5.5, 1.0])
    np.testing.assert_allclose(M[0], [[(10**2 - 1) / 12, 0.0], [0.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(M[1], 0.0, atol=1e-12)


def test_xy_to_range_bearing_propagates_an_axis_covariance_analytically():
    """A point on the x axis at 10 m: x variance is range variance, y variance divided by
    r² is bearing variance (first-order polar Jacobian), plus the native cell terms."""
    r, b, R = xy_to_range_bearing(
        np.array([[10.0, 0.0]]), np.diag([4.0, 1.0])[None], np.array([0.1]), np.array([0.01])
    )
    assert r[0] == pytest.approx(10.0) and b[0] == pytest.approx(0.0)
    np.testing.assert_allclose(R[0], [[4.1, 0.0], [0.0, 0.01 + 1.0 / 100.0]], atol=1e-12)


def test_footprint_gap_joins_fragments_of_one_long_object_and_not_a_neighbour():
    """Two 10 m bars along x end to end with a 1 m gap (centroids 11 m apart) are one
    object for a 3 m merge radius (gap = 11 - 5 - 5 = 1 m, half length sqrt(3 var) with
    var = L²/12); a compact region 6 m beyond the second bar's end is not."""
    bar = np.diag([10.0**2 / 12, 0.01])
    dot = np.diag([0.01, 0.01])
    xy = np.array([[0.0, 0.0], [11.0, 0.0], [22.0, 0.0]])
    g = footprint_gap_groups(xy, np.stack([bar, bar, dot]), 3.0)
    assert g[0] == g[1] and g[2] != g[1]


def test_persistence_confirms_a_recurring_object_and_not_scattered_speckle(rng):
    """k-of-n: an object at a fixed world point seen every frame is confirmed from the
    k-th frame on; points drawn uniformly over 40 m x 40 m away from it (3 per frame)
    recur within 1.5 m of each other with probability ~6 (3 pi 1.5² / 1600)² ~ 1e-3 per
    point, so none of 90 is confirmed (seeded)."""
    pf = PersistenceFilter(3, 5, 1.5, track_radius=3.0)
    obj = np.array([30.0, 30.0])
    confirmed_obj, confirmed_noise = [], 0
    for _ in range(30):
        noise = rng.uniform(-20, 20, (3, 2))
        w = np.vstack([obj + rng.normal(0, 0.1, 2), noise])
        conf, _ = pf.step(w, np.array([0.0, 0.0, 0.0]))
        confirmed_obj.append(bool(conf[0]))
        confirmed_noise += int(conf[1:].sum())
    assert confirmed_obj[:2] == [False, False] and all(confirmed_obj[2:])
    assert confirmed_noise == 0


def test_keyframing_emits_one_observation_per_distance_travelled():
    """A confirmed object seen every frame while the vehicle moves 0.1 m per frame: with
    keyframe_distance 2 m an observation is emitted on the first confirmed frame and then
    every 20 frames."""
    pf = PersistenceFilter(1, 1, 1.0, track_radius=3.0, keyframe_distance=2.0)
    emitted = [
        bool(pf.step(np.array([[10.0, 0.0]]), np.array([0.1 * k, 0.0, 0.0]))[1][0])
        for k in range(61)
    ]
    assert np.flatnonzero(emitted).tolist() == [0, 20, 40, 60]


@pytest.mark.parametrize(
    ("field", "value"),
    [("looks", 0), ("persistence_k", 6), ("top_db", 0.0), ("min_peak_db", -1.0)],
)
def test_bad_config_names_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        PolarFrontendConfig(**{field: value})


def test_conditioning_maps_background_to_zero_and_targets_above_the_peak_test(rng):
    """Fixed dB scale: on speckle the conditioned median sits near 0 dB above background
    (grey ~0) whatever the range falloff, and a 15 dB patch stays above min_peak_db."""
    img = _frame(rng, target_rb=(20.0, 0.2))
    g8, db = condition_polar(img, log_compressed=True, dynamic_range_db=DR_DB, cfg=FLS_FRONTEND)
    seabed = RANGES >= 13.0
    assert np.median(db[seabed]) < 1.5
    assert g8.dtype == np.uint8 and g8.max() > FLS_FRONTEND.min_peak_db * 255 / FLS_FRONTEND.top_db
    assert db.max() >= FLS_FRONTEND.min_peak_db


def test_fls_sequence_over_a_known_object_gives_observations_near_it_and_none_on_bare_seabed(
    rng,
):
    """Independent expectation: the synthetic object sits at a known world position (the
    vehicle at the origin heading 0, object at range 20 m, bearing 0.2 rad); every
    confirmed detection must lie within 1 m of it (cell 0.12 m x 0.7 deg, patch 0.7 m),
    it must be confirmed from the 3rd frame (3 of 5), and 30 frames of bare speckle must
    give no confirmed detection at all."""
    truth = 20.0 * np.array([math.cos(0.2), math.sin(0.2)])
    fe = _frontend()
    pose = np.zeros(3)
    near, confirmed = [], []
    for k in range(8):
        res = fe.process(_frame(rng, (20.0, 0.2)), altitude=None, poses_nav=pose, times=0.2 * k)
        confirmed.append(any(d.confirmed for d in res.detections))
        near += [np.hypot(*(d.world_xy_nav - truth)) for d in res.detections if d.confirmed]
    assert confirmed[2:] == [True] * 6
    assert near and max(near) < 1.0
    fe = _frontend()
    n_conf = 0
    for k in range(30):
        res = fe.process(_frame(rng), altitude=None, poses_nav=pose, times=0.2 * k)
        n_conf += sum(d.confirmed for d in res.detections)
    assert n_conf == 0


def test_extended_object_covariance_covers_its_length_across_and_behind(rng):
    """A 40-beam x 4-bin patch at 20 m is a ~9.8 m arc across the line of sight. By the
    config's definition its across-range sigma must be at least extent_bias x that length
    (the lit part's centroid vs the object's centre) and its range sigma at least
    shadow_bias x the length (its hidden far side). A compact 6 x 4 patch (0.7 m x 1 m)
    grows to ~10 x 12 cells through blur and dilation: its sigma stays below
    sqrt((2.5 m)² / 12 + (extent_bias x 1.2 m)²), far below the long patch's."""
    cfg = FLS_FRONTEND
    length = 20.0 * 40 * FOV / N_BEAMS
    res = _frontend().process(
        _frame(rng, (20.0, 0.0), size=(4, 40)), altitude=None, poses_nav=np.zeros(3), times=0.0
    )
    big = max(res.detections, key=lambda d: d.area_px)
    r, _ = big.observation.z
    sd_r, sd_b = np.sqrt(np.diag(big.observation.R))
    assert r * sd_b >= 0.9 * cfg.extent_bias * length
    assert sd_r >= 0.9 * cfg.shadow_bias * length
    res = _frontend().process(
        _frame(rng, (20.0, 0.0)), altitude=None, poses_nav=np.zeros(3), times=0.0
    )
    small = max(res.detections, key=lambda d: d.area_px)
    r, _ = small.observation.z
    sd_r, sd_b = np.sqrt(np.diag(small.observation.R))
    assert max(sd_r, r * sd_b) < math.sqrt(2.5**2 / 12 + (cfg.extent_bias * 1.2) ** 2)
