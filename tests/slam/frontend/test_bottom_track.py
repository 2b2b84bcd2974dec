"""Bottom tracking: a synthetic waterfall with a known altitude per ping (speckled water
column with bright fish, a missing-bottom stretch) and the real recordings' own altitude
fields as independent references."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from slam.frontend.bottom_track import (
    BottomTrackConfig,
    fill_track,
    track_bottom,
    water_column_mask,
)
from slam.io.waterfall import Waterfall

DR = 0.02  # m per sample


def _synthetic(rng, p=300, s=600):
    """Port/starboard with Rayleigh speckle: water column at level 1, seabed at level 8
    from the true first-return sample; fish = bright 4-sample blobs in the water column on
    one side only; pings 200–219 have no bottom (water column to the end)."""
    alt = 3.0 + 1.5 * np.sin(np.arange(p) / 40.0)  # m
    first = np.round(alt / DR).astype(int)
    k = np.arange(s)[None, :]
    sides = []
    for _ in range(2):
        level = np.where(k >= first[:, None], 8.0, 1.0)
        level[200:220] = 1.0
        sides.append(level * rng.rayleigh(1.0, size=(p, s)))
    for i in rng.choice(np.arange(0, min(p, 200)), size=min(p, 25), replace=False):  # fish, stbd
        j = rng.integers(40, first[i] - 10)
        sides[1][i, j : j + 4] *= 30.0
    img = np.concatenate([sides[0][:, ::-1], sides[1]], axis=1)
    nan = np.full(p, np.nan)
    wf = Waterfall(
        intensity=img,
        samples_per_side=s,
        time_s=np.arange(p) * 0.1,
        slant_range_m=np.full(p, s * DR),
        frequency_hz=nan,
        sound_velocity_m_s=nan,
    )
    return wf, alt


def test_synthetic_track_within_two_samples_and_missing_bottom_is_nan(rng):
    wf, alt = _synthetic(rng)
    bt = track_bottom(wf)
    has = np.ones(wf.n_pings, dtype=bool)
    has[200:220] = False
    # no step: no invented bottom (the 5-ping along-track average reaches 2 pings in)
    assert not bt.found[203:217].any()
    assert bt.found[has].mean() > 0.97
    err = np.abs(bt.altitude_m - alt)[has & bt.found]
    assert np.percentile(err, 95) <= 2 * DR
    mask = water_column_mask(wf, bt)
    s = wf.samples_per_side
    i = 10
    assert mask[i, s : s + int(bt.sample[i])].all() and not mask[i, s + int(bt.sample[i])]
    assert not mask[205].any()
    filled = fill_track(bt)
    assert np.all(np.isfinite(filled))


def test_config_and_metadata_errors(rng):
    with pytest.raises(ValueError, match="first_fraction"):
        BottomTrackConfig(first_fraction=0.0)
    with pytest.raises(ValueError, match="blank_m"):
        BottomTrackConfig(blank_m=-1.0)
    wf, _ = _synthetic(rng, p=20)
    nan = np.full(20, np.nan)
    no_range = Waterfall(
        intensity=wf.intensity,
        samples_per_side=wf.samples_per_side,
        time_s=nan,
        slant_range_m=nan,
        frequency_hz=nan,
        sound_velocity_m_s=nan,
    )
    with pytest.raises(ValueError, match="slant range"):
        track_bottom(no_range)


@pytest.mark.shared_data
def test_scotsman_track_follows_the_xtf_altitude_field(shared_data):
    """The AUV's altimeter (XTF SensorPrimaryAltitude) against the sonar's first return."""
    from slam.io.sidescan import read_sidescan

    rec = read_sidescan(shared_data / "xtf" / "scotsman-iver2.xtf")
    bt = track_bottom(rec.waterfall)
    ok = bt.found & np.isfinite(rec.nav.altitude_m)
    assert ok.sum() >= 450
    a, b = bt.altitude_m[ok], rec.nav.altitude_m[ok]
    assert np.corrcoef(a, b)[0, 1] > 0.98
    assert np.sqrt(np.mean((a - b) ** 2)) < 1.5


@functools.lru_cache(maxsize=1)
def _humminbird(path: str):
    """The Humminbird recording, read once per test session (≈ 20 s)."""
    from slam.io.sidescan import read_sidescan

    return read_sidescan(path)


@pytest.mark.shared_data
def test_humminbird_track_follows_the_header_depth(shared_data):
    """Data README: the first return follows the unit's depth field with r = 0.93 over
    the first ~2,100 pings (independent tools); later pings jump to the multiple."""
    rec = _humminbird(str(shared_data / "humminbird" / "test.DAT"))
    bt = track_bottom(rec.waterfall)
    n = 2100
    ok = bt.found[:n] & np.isfinite(rec.nav.altitude_m[:n])
    assert ok.mean() > 0.95
    r = np.corrcoef(bt.altitude_m[:n][ok], rec.nav.altitude_m[:n][ok])[0, 1]
    assert r > 0.88


def _one_side(wf: Waterfall, port: bool) -> Waterfall:
    """The waterfall with one side mirrored onto the other (that side's own track)."""
    s = wf.samples_per_side
    near_first = wf.intensity[:, :s][:, ::-1] if port else wf.intensity[:, s:]
    img = np.concatenate([near_first[:, ::-1], near_first], axis=1)
    return dataclasses.replace(wf, intensity=img)


@pytest.mark.shared_data
def test_humminbird_depth_field_is_deeper_where_both_sides_return_early(shared_data):
    """Pings 1,000-1,400, where r against the depth field collapses: where the depth
    field lies more than 0.5 m below the track, port alone and starboard alone give the
    same first return (median within 2 samples): an echo at the same range on both sides
    comes from below the sonar, not from a fish or an object off to one side, so the
    track is right about the first return and the sounder reports a deeper bottom."""
    rec = _humminbird(str(shared_data / "humminbird" / "test.DAT"))
    sl = slice(1000, 1400)
    wf = dataclasses.replace(
        rec.waterfall,
        intensity=rec.waterfall.intensity[sl],
        time_s=rec.waterfall.time_s[sl],
        slant_range_m=rec.waterfall.slant_range_m[sl],
        frequency_hz=rec.waterfall.frequency_hz[sl],
        sound_velocity_m_s=rec.waterfall.sound_velocity_m_s[sl],
        nav={},
    )
    dr = float(np.median(wf.sample_spacing_m()))
    both = track_bottom(wf).altitude_m
    deeper = np.isfinite(both) & (rec.nav.altitude_m[sl] - both > 0.5)
    assert deeper.sum() > 100
    for port in (True, False):
        side = track_bottom(_one_side(wf, port)).altitude_m
        assert np.nanmedian(np.abs(side - both)[deeper]) <= 2 * dr


def test_early_return_on_both_sides_is_the_track(rng):
    """Analytic: a return 2.5x the water column starting 1 m nearer than the seabed (8x)
    on both sides (an object below the sonar, as in Humminbird pings 1,000-1,400): its
    edge (log 2.5) is weaker than the seabed's step behind it (log 3.2) but above 0.6 of
    it, so the track follows the first return (within 2 samples), not the strongest."""
    wf, alt = _synthetic(rng, p=120)
    s = wf.samples_per_side
    k = np.arange(s)[None, :]
    rows = np.arange(40, 80)
    raised = (k >= np.round((alt[rows] - 1.0) / DR)[:, None]) & (
        k < np.round(alt[rows] / DR)[:, None]
    )
    img = wf.intensity.copy()
    both = np.concatenate([raised[:, ::-1], raised], axis=1)
    img[40:80] = np.where(both, img[40:80] * 2.5, img[40:80])
    bt = track_bottom(dataclasses.replace(wf, intensity=img))
    inner = slice(45, 75)  # away from the along-track smoothing at the ends
    assert bt.found[inner].all()
    assert np.percentile(np.abs(bt.altitude_m[inner] - (alt[inner] - 1.0)), 95) <= 2 * DR
    assert np.percentile(np.abs(bt.altitude_m[90:] - alt[90:]), 95) <= 2 * DR


def test_edge_score_equals_the_direct_window_means(rng):
    """Second implementation: the cumulative-sum score against explicit window means."""
    from slam.frontend.bottom_track import _edge_score

    x, w = rng.normal(size=(4, 37)), 5
    ref = np.zeros_like(x)
    for k in range(w, x.shape[1] - w + 1):
        ref[:, k] = x[:, k : k + w].mean(axis=1) - x[:, k - w : k].mean(axis=1)
    np.testing.assert_allclose(_edge_score(x, w), ref, atol=1e-12)
    assert not _edge_score(x[:, :7], w).any()  # rows shorter than two windows: no edge


def test_seabed_region_is_past_the_track_and_falls_back_on_images(rng):
    """A recording: the seabed starts at the bottom track's pick on both sides. A bare
    image (no slant range): the threshold rule of normalization.seabed_mask."""
    from slam.frontend.bottom_track import seabed_region
    from slam.frontend.normalization import seabed_mask
    from slam.io.waterfall import waterfall_from_image

    wf, alt = _synthetic(rng, p=60)
    m = seabed_region(wf)
    s = wf.samples_per_side
    k = np.round(alt / DR).astype(int)
    for i in (5, 30, 55):
        assert abs(int(np.argmax(m[i, s:])) - k[i]) <= 2
        assert np.array_equal(m[i, :s], m[i, s:][::-1])
    img = waterfall_from_image(wf.intensity)
    np.testing.assert_array_equal(seabed_region(img), seabed_mask(img))
