"""The first stage's threshold from part of the tile (``DetectorConfig.threshold_pixels``):
improved Otsu with a histogram mask against OpenCV's Otsu on the masked pixels, the bright
edge strips of hand-built tiles, and a dim object under a bright strip's threshold."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from slam.frontend.segmentation import improved_otsu
from slam.frontend.segmentation.detector import DetectorConfig, detect
from slam.frontend.segmentation.otsu import power_law
from slam.frontend.segmentation.tile_edges import bright_edge_strips, seabed_histogram_mask


def test_masked_threshold_is_opencv_otsu_of_the_masked_pixels(rng):
    """T from ``hist_mask`` equals ``cv2.threshold(THRESH_OTSU)`` on the masked pixels of
    the power-law image alone; an all-True mask (or one selecting nothing) gives the
    thesis's result exactly."""
    img = np.clip(rng.normal(60, 25, (120, 160)), 0, 255).astype(np.uint8)
    img[:30] = np.clip(rng.normal(210, 10, (30, 160)), 0, 255).astype(np.uint8)
    keep = np.ones(img.shape, bool)
    keep[:30] = False
    y = power_law(img, 0.1, 1.415)
    want, _ = cv2.threshold(y[keep].reshape(1, -1), 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    res = improved_otsu(img, "sdvd", hist_mask=keep)
    assert res.threshold == want
    assert res.threshold < improved_otsu(img, "sdvd").threshold  # the strip raised it
    plain = improved_otsu(img, "sdvd")
    for m in (np.ones(img.shape, bool), np.zeros(img.shape, bool)):
        r = improved_otsu(img, "sdvd", hist_mask=m)
        assert (r.threshold, r.threshold_star) == (plain.threshold, plain.threshold_star)
        assert np.array_equal(r.labels, plain.labels)
    with pytest.raises(ValueError, match="hist_mask"):
        improved_otsu(img, "sdvd", hist_mask=keep[:10])


def test_bright_edge_strips_only_at_the_edges():
    """Rows 0–19 and columns 150–159 brighter than the level are strips; a bright band in
    the middle is not (it does not start at an edge), nor is a bright half larger than
    half the tile."""
    g = np.full((100, 160), 40, np.uint8)
    g[:20] = 200
    g[:, 150:] = 220
    g[50:60] = 210  # middle band
    valid = np.ones(g.shape, bool)
    s = bright_edge_strips(g, valid, 100)
    want = np.zeros(g.shape, bool)
    want[:20] = True
    want[:, 150:] = True
    assert np.array_equal(s, want)
    big = np.full((100, 160), 40, np.uint8)
    big[:70] = 200
    assert not bright_edge_strips(big, valid, 100).any()
    with pytest.raises(ValueError, match="valid"):
        bright_edge_strips(g, valid[:5], 100)


def test_seabed_mask_drops_no_echo_and_the_strip():
    g = np.full((100, 100), 50, np.uint8)
    g[:15] = 230
    ne = np.zeros(g.shape, bool)
    ne[:, 90:] = True
    m = seabed_histogram_mask(g, ne)
    assert not m[:15].any() and not m[:, 90:].any() and m[15:, :90].all()
    assert np.array_equal(seabed_histogram_mask(g, ne, strips="none"), ~ne)
    assert seabed_histogram_mask(g, np.ones(g.shape, bool)).all()  # nothing left: all


def dim_object_under_strip(rng):
    """256 x 256: seabed 30 ± 4, a bright near-range strip (rows 0–49) at 220 ± 10, and a
    dim 30 x 30 object at 100 with its centre at (200.5, 120.5)."""
    img = rng.normal(30, 4, (256, 256))
    img[:50] = rng.normal(220, 10, (50, 256))
    img[186:216, 106:136] = 100
    return np.clip(img, 0, 255).astype(np.uint8)


def test_seabed_threshold_finds_a_dim_object_under_a_bright_strip(rng):
    """Rules only: from the whole tile the threshold lies between seabed and strip, above
    the object, so no detection is on it; from the seabed (strip excluded) the object is
    above it and detected at its centre."""
    img = dim_object_under_strip(rng)
    cfg = DetectorConfig(classifier=None, min_contrast_db=2.0, max_count=0)

    def on_object(res):
        return [
            r
            for r in res.landmarks
            if abs(r.centroid_rc[0] - 200.5) < 2 and abs(r.centroid_rc[1] - 120.5) < 2
        ]

    assert not on_object(detect(img, cfg))
    assert not on_object(detect(img, cfg.with_(threshold_pixels="echo")))  # no no-echo here
    assert len(on_object(detect(img, cfg.with_(threshold_pixels="seabed")))) == 1
    with pytest.raises(ValueError, match="threshold_pixels"):
        DetectorConfig(threshold_pixels="strips")


def test_ping_band_tile_gets_a_region_on_its_effigy(shared_data):
    """A real tune tile (034600H s3 t1) whose top rows are a band of pings brighter over
    the whole swath: from every pixel the threshold leaves no candidate on the labelled
    effigy; without the band a candidate's centroid is inside its mask."""
    from script_module import load_script

    from slam.frontend.segmentation.detector import candidate_regions, get_detector
    from slam.frontend.segmentation.evaluation import load_sdvd

    inside_flags = load_script("train_sdvd_stage2").inside_flags
    name = "left_20240430034600H_sample_3_tile_1.png"
    (tile,) = [t for t in load_sdvd(shared_data / "sdvd") if t.name == name]
    cfg = get_detector("sdvd-saturated")

    def on_effigy(c):
        return int(inside_flags(tile.mask, c.regions, c.offset_rc).sum())

    assert on_effigy(candidate_regions(tile.image, cfg.with_(threshold_pixels="all"))) == 0
    assert on_effigy(candidate_regions(tile.image, cfg)) >= 1
