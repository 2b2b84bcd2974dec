"""The detection chain (improved Otsu first stage, artefact suppression, fragment merging,
learned second stage): the thesis preset reproduces improved Otsu, a hand-built tile
gives the known detections, the logistic fit recovers a known model, and on the real SDVD
held-out half the trusted detector meets the PPV and false-detection targets."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from slam.frontend.segmentation import improved_otsu
from slam.frontend.segmentation.artefacts import no_echo_mask
from slam.frontend.segmentation.detector import (
    FEATURES,
    SDVD_STAGE2,
    DetectorConfig,
    RegionClassifier,
    candidate_regions,
    detect,
    fit_region_classifier,
    get_detector,
)
from slam.frontend.segmentation.evaluation import evaluate_detector, load_sdvd
from slam.frontend.segmentation.tile_edges import seabed_histogram_mask


def test_thesis_preset_is_improved_otsu_unchanged(rng):
    """The "thesis" chain reports exactly improved Otsu's regions (size-rule preset), all
    of them as landmarks."""
    img = np.clip(rng.normal(60, 20, (200, 240)), 0, 255).astype(np.uint8)
    img[50:70, 80:110] = 240
    res = detect(img, "thesis")
    ref = improved_otsu(img, "auto")
    assert res.regions == ref.regions and res.landmarks == ref.regions
    assert np.array_equal(res.labels, ref.labels)


def tile_with_artefacts(rng):
    """Seabed, an object in two fragments 3 px apart (rows 100–111, cols 60–69 and
    73–82), a scale bar (black box with white text, a tick line below) and a zero-padded
    bottom band with a bright rim."""
    img = np.clip(rng.normal(50, 8, (256, 256)), 0, 255).astype(np.uint8)
    img[100:112, 60:70] = 235
    img[100:112, 73:83] = 235
    img[20:34, 170:204] = 3
    cv2.putText(img, "10M", (173, 31), cv2.FONT_HERSHEY_PLAIN, 0.7, 255, 1)
    img[34:54, 183:188] = 2  # the tick line below the box, flanked by black
    img[34:54, 185] = 255
    img[-40:, :] = 0
    img[-44:-40, 100:130] = 240  # bright rim on the no-echo edge
    return img


def test_hand_built_tile_one_merged_detection(rng):
    """Rules only (no classifier): the two fragments come out as one detection centred
    between them; nothing on the scale bar or on the no-echo rim. Without masking and
    suppression the scale bar and the rim are detected too."""
    img = tile_with_artefacts(rng)
    cfg = DetectorConfig(classifier=None, min_contrast_db=2.0, max_count=0)
    res = detect(img, cfg)
    assert len(res.landmarks) == 1
    r0, c0 = res.landmarks[0].centroid_rc
    assert r0 == pytest.approx(105.5, abs=1.0) and c0 == pytest.approx(71.0, abs=1.5)
    raw = detect(img, cfg.with_(mask_annotations=False, suppress_no_echo=False, merge_gap_px=0))
    rows = sorted(round(r.centroid_rc[0]) for r in raw.landmarks)
    assert len(raw.landmarks) >= 3 and rows[0] < 40 and rows[-1] > 200


def test_logistic_fit_recovers_known_model():
    """Labels drawn from a known logistic model on standardized features: the fit
    (weak penalty) recovers its weights and bias within sampling error."""
    rng = np.random.default_rng(7)
    n = 20000
    x = rng.normal(size=(n, len(FEATURES))) * 2.0 + 1.0
    w_true = np.array([1.0, -0.5, 0.8, 0.0, 0.3, -1.2, 0.5, 0.6])
    b_true = -0.7
    z = (x - 1.0) / 2.0
    p = 1.0 / (1.0 + np.exp(-(z @ w_true + b_true)))
    y = rng.random(n) < p
    clf = fit_region_classifier(x, y, l2=1e-3)
    assert np.allclose(clf.mean, 1.0, atol=0.05) and np.allclose(clf.scale, 2.0, atol=0.05)
    assert np.allclose(clf.weights, w_true, atol=0.08)
    assert clf.bias == pytest.approx(b_true, abs=0.08)


def test_classifier_probability_by_hand():
    clf = RegionClassifier(
        mean=(1.0,) * 8, scale=(2.0,) * 8, weights=(1, 0, 0, 0, 0, 0, -1, 0), bias=0.5
    )
    x = np.array([[5.0, 0, 0, 0, 0, 0, 3.0, 9.0]])
    assert clf.probability(x)[0] == pytest.approx(1 / (1 + math.exp(-(2.0 - 1.0 + 0.5))))


def test_bad_config_names_the_field():
    with pytest.raises(ValueError, match="merge_gap_px"):
        DetectorConfig(merge_gap_px=-1)
    with pytest.raises(ValueError, match="method"):
        DetectorConfig(method="magic")
    with pytest.raises(ValueError, match="threshold"):
        RegionClassifier(mean=(0,) * 8, scale=(1,) * 8, weights=(0,) * 8, bias=0, threshold=2)
    with pytest.raises(ValueError, match="detector='nope'"):
        get_detector("nope")
    with pytest.raises(ValueError, match="is_object"):
        fit_region_classifier(np.zeros((4, 8)), np.zeros(4, bool))


def test_sdvd_trusted_on_held_out_half(shared_data):
    """SDVD held-out (test) half, never used for tuning or training: the trusted detector
    keeps PPV with one true positive per effigy >= 0.5, <= 0.7 false detections per
    negative tile and a hit rate >= 0.85 (issue 14 targets), with fewer than half the
    false detections per negative tile of the previous "sdvd-contrast" filter (1.69)."""
    tiles = [t for t in load_sdvd(shared_data / "sdvd") if t.split == "test"]
    ev = evaluate_detector(tiles, get_detector("sdvd-trusted"))
    assert ev.all.ppv_object >= 0.5
    assert ev.detections_per_negative <= 0.7
    assert ev.hit_rate >= 0.85
    assert SDVD_STAGE2.threshold == get_detector("sdvd-trusted").classifier.threshold


def test_contrast_below_best_is_each_regions_contrast_minus_the_tiles_best():
    """Two squares on a flat seabed (level 50) at 150 and 100: their ring contrasts are
    10·log10(150/50) and 10·log10(100/50) dB; the last feature is 0 for the brighter and
    −10·log10(1.5) dB for the dimmer."""
    from slam.frontend.segmentation.detector import region_features
    from slam.frontend.segmentation.fragments import regions_from_labels

    img = np.full((80, 80), 50, np.uint8)
    img[10:20, 10:20] = 150
    img[50:60, 50:60] = 100
    labels = np.zeros(img.shape, np.int32)
    labels[10:20, 10:20] = 1
    labels[50:60, 50:60] = 2
    f = region_features(img, labels, regions_from_labels(labels))
    assert f.shape == (2, len(FEATURES)) and FEATURES[-1] == "contrast_below_best_db"
    assert f[0, -1] == pytest.approx(0.0)
    assert f[1, -1] == pytest.approx(-10 * math.log10(1.5), abs=0.2)
    assert f[1, -1] == pytest.approx(f[1, 2] - f[0, 2])


def saturated_tile(rng):
    """A display-saturated seabed (level 225, speckle σ 8) with a dark object (level 120,
    rows 100–115, cols 60–79) and a zero-padded right band (cols 230–255)."""
    img = np.clip(rng.normal(225, 8, (256, 256)), 1, 255).astype(np.uint8)
    img[100:116, 60:80] = 120
    img[:, 230:] = 0
    return img


def test_invert_saturated_finds_a_dark_object_on_a_white_seabed(rng):
    """Rules only: on a saturated seabed the dark object is not above it, so the chain as
    is finds no region on it; with ``invert_saturated`` at 170 its one detection is the
    object's centre (107.5, 69.5), and the zero padding stays a no-echo area (no
    detection on its edge, which the inverted image would make the brightest)."""
    from slam.frontend.segmentation.artefacts import invert_saturated

    img = saturated_tile(rng)
    cfg = DetectorConfig(classifier=None, min_contrast_db=2.0, max_count=0)
    plain = detect(img, cfg)
    assert not any(
        100 <= r.centroid_rc[0] < 116 and 60 <= r.centroid_rc[1] < 80 for r in plain.landmarks
    )
    res = detect(img, cfg.with_(invert_saturated=170.0))
    assert len(res.landmarks) == 1
    r0, c0 = res.landmarks[0].centroid_rc
    assert r0 == pytest.approx(107.5, abs=1.0) and c0 == pytest.approx(69.5, abs=1.0)
    inv, flipped = invert_saturated(img, 170.0)
    assert flipped and inv[0, 240] == 0 and inv[105, 65] == 255 - 120


def test_invert_saturated_leaves_other_tiles_alone(rng):
    """Seabed level 60 < 170: the inverted-saturation chain's output equals the chain's
    (same regions, same detections); a bad level names the field."""
    from slam.frontend.segmentation.artefacts import invert_saturated

    img = np.clip(rng.normal(60, 20, (256, 256)), 0, 255).astype(np.uint8)
    img[50:70, 80:110] = 240
    a = detect(img, "sdvd-trusted")
    b = detect(img, get_detector("sdvd-trusted").with_(invert_saturated=170.0))
    assert a.landmarks == b.landmarks and np.array_equal(a.labels, b.labels)
    assert invert_saturated(img, 170.0)[1] is False
    with pytest.raises(ValueError, match="invert_saturated"):
        DetectorConfig(invert_saturated=math.nan)


def test_sdvd_saturated_on_held_out_half(shared_data):
    """SDVD held-out half: ``sdvd-saturated`` (display-saturated tiles inverted, level
    chosen on the tune half; threshold without bright ping bands) keeps the issue 14
    targets (hit rate >= 0.85, PPV one TP per effigy >= 0.5, <= 0.7 false detections per
    negative tile), hits at least every effigy ``sdvd-trusted`` hits, and gives exactly
    its detections on every tile whose seabed level is under 170 and that has no bright
    ping band."""
    tiles = [t for t in load_sdvd(shared_data / "sdvd") if t.split == "test"]
    sat, plain = get_detector("sdvd-saturated"), get_detector("sdvd-trusted")
    ev = evaluate_detector(tiles, sat)
    assert ev.all.ppv_object >= 0.5 and ev.detections_per_negative <= 0.7
    assert ev.hit_rate >= 0.85
    assert ev.positives.images_hit >= evaluate_detector(tiles, plain).positives.images_hit
    for t in tiles[::4]:
        nz = t.image[t.image > 0]
        g = candidate_regions(t.image, sat).gray8  # annotations masked
        keep = seabed_histogram_mask(g, no_echo_mask(t.image), "rows", drop_no_echo=False)
        if nz.size and np.median(nz) < 170 and keep.all():
            assert detect(t.image, sat).landmarks == detect(t.image, plain).landmarks, t.name
