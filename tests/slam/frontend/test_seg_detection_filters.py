"""Side-scan detection filters (local contrast, far-range acoustic shadow) on synthetic
images whose highlight/shadow geometry is known, plus brute-force second implementations
of the two scores."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam.frontend.segmentation import (
    REGION_FILTERS,
    DetectionFilter,
    RegionFilter,
    extract_regions,
    get_region_filter,
    region_contrast_db,
    segment,
    segment_filtered,
    shadow_dark_level,
    shadow_fraction,
)

BG, OBJ, SHADOW = 100, 200, 20


def _scene(far_range: str = "left"):
    """128×128 seabed at 100; object A (rows 40–49, cols 70–79) at 200 with a 30-px shadow
    at 20 on its far-range side; object B (rows 90–99, cols 60–69) at 200 without one;
    object C (rows 15–24, cols 15–24) at 110 (low contrast, no shadow)."""
    g = np.full((128, 128), BG, dtype=np.uint8)
    mask = np.zeros(g.shape, dtype=bool)
    g[40:50, 70:80] = OBJ
    if far_range == "left":
        g[40:50, 40:70] = SHADOW
    else:
        g[40:50, 80:110] = SHADOW
    g[90:100, 60:70] = OBJ
    g[15:25, 15:25] = 110
    mask[40:50, 70:80] = mask[90:100, 60:70] = mask[15:25, 15:25] = True
    regions, labels = extract_regions(mask)
    by_pos = {(int(r.centroid_rc[0]), int(r.centroid_rc[1])): r.label for r in regions}
    lab = {"A": by_pos[(44, 74)], "B": by_pos[(94, 64)], "C": by_pos[(19, 19)]}
    return g, labels, regions, lab


def test_contrast_matches_closed_form():
    """Uniform object on uniform background: 10·log10((200+1)/(100+1)) dB exactly, and
    10·log10(111/101) for the faint object; the ring of A is partly shadow, so lower."""
    g, labels, _, lab = _scene()
    c = region_contrast_db(g, labels, annulus_px=7)
    assert c[lab["B"]] == pytest.approx(10 * math.log10(201 / 101), abs=1e-12)
    assert c[lab["C"]] == pytest.approx(10 * math.log10(111 / 101), abs=1e-12)
    # A's 7-px ring: (24×24 − 100) px, of which the 7×10 strip on the left is shadow
    ring_mean = ((24 * 24 - 100 - 70) * BG + 70 * SHADOW) / (24 * 24 - 100)
    assert c[lab["A"]] == pytest.approx(10 * math.log10(201 / (ring_mean + 1)), abs=1e-12)


@pytest.mark.parametrize("side", ["left", "right"])
def test_shadow_fraction_on_known_geometry(side):
    """A's 40-px strip behind it (far range) holds 30 shadow px of 40 per row -> 0.75;
    the near-range side and object B hold none -> 0; 'either' takes the larger."""
    g, labels, _, lab = _scene(side)
    other = "right" if side == "left" else "left"
    far = shadow_fraction(g, labels, side, length_px=40, dark_ratio=0.7)
    near = shadow_fraction(g, labels, other, length_px=40, dark_ratio=0.7)
    either = shadow_fraction(g, labels, "either", length_px=40, dark_ratio=0.7)
    assert far[lab["A"]] == pytest.approx(0.75)
    assert near[lab["A"]] == 0.0
    assert far[lab["B"]] == 0.0 and far[lab["C"]] == 0.0
    assert either[lab["A"]] == pytest.approx(0.75)
    assert shadow_dark_level(g, 0.7) == pytest.approx(70.0)  # 0.7 × median 100


def test_filter_keeps_highlight_with_shadow_only():
    """Contrast >= 2 dB removes C (0.41 dB); the shadow test removes B (no shadow), keeps A."""
    g, labels, regions, lab = _scene("left")
    f = DetectionFilter(min_contrast_db=2.0, shadow_min_fraction=0.5, far_range="left")
    assert [r.label for r in f.apply(regions, g, labels)] == [lab["A"]]
    contrast_only = DetectionFilter(min_contrast_db=2.0)
    assert sorted(r.label for r in contrast_only.apply(regions, g, labels)) == sorted(
        [lab["A"], lab["B"]]
    )
    # wrong far-range side: A's shadow is on the near side, so nothing passes
    wrong = DetectionFilter(min_contrast_db=2.0, shadow_min_fraction=0.5, far_range="right")
    assert wrong.apply(regions, g, labels) == ()


def test_max_count_ranks_by_contrast():
    """With max_count = 1 and rank_by='contrast' the highest-contrast region is kept: A,
    whose ring includes 70 shadow px and so has a lower mean than B's (closed forms in
    test_contrast_matches_closed_form); with max_count = 2, A and B (C is faint)."""
    g, labels, regions, lab = _scene("left")
    f = DetectionFilter(region=RegionFilter(max_count=1), rank_by="contrast")
    assert [r.label for r in f.apply(regions, g, labels)] == [lab["A"]]
    f2 = f.with_(region=RegionFilter(max_count=2))
    assert sorted(r.label for r in f2.apply(regions, g, labels)) == sorted([lab["A"], lab["B"]])


def test_segment_filtered_end_to_end_on_synthetic_image():
    """Improved Otsu + sdvd-shadow geometry with far range known: only the object with the
    shadow remains; the plain geometry filter keeps both bright objects."""
    g, _, _, _ = _scene("left")
    f = DetectionFilter(
        region=RegionFilter(max_area_px=2000, max_elongation=6.0, max_count=4),
        min_contrast_db=2.0,
        shadow_min_fraction=0.5,
        far_range="left",
    )
    res = segment_filtered(g, "kapur", "sdvd", f)
    assert len(res.landmarks) == 1
    y, x = res.landmarks[0].centroid_rc
    assert 40 <= y < 50 and 70 <= x < 80
    plain = segment_filtered(g, "kapur", "sdvd", RegionFilter(max_area_px=2000))
    assert len(plain.landmarks) >= 2


def _brute_shadow(g, labels, direction, length, ratio):
    nz = g[g > 0]
    dark = g < ratio * np.median(nz)
    n = labels.max() + 1
    cnt = np.zeros(n)
    dk = np.zeros(n)
    h, w = g.shape
    step = 1 if direction == "left" else -1  # near range is towards +step
    for r in range(h):
        for c in range(w):
            if labels[r, c]:
                continue
            for k in range(1, length + 1):
                cc = c + step * k
                if not 0 <= cc < w:
                    break
                if labels[r, cc]:
                    cnt[labels[r, cc]] += 1
                    dk[labels[r, cc]] += dark[r, c]
                    break
    return np.where(cnt > 0, dk / np.maximum(cnt, 1), 0.0)


def _brute_contrast(g, labels, annulus):
    n = labels.max() + 1
    out = np.zeros(n)
    h, w = g.shape
    # ring pixel -> highest label within Chebyshev distance `annulus` (documented rule)
    owner = np.zeros_like(labels)
    for r in range(h):
        for c in range(w):
            if labels[r, c] == 0:
                win = labels[
                    max(r - annulus, 0) : r + annulus + 1, max(c - annulus, 0) : c + annulus + 1
                ]
                owner[r, c] = win.max()
    for k in range(1, n):
        inside = g[labels == k]
        ring = g[(labels == 0) & (owner == k)]
        if inside.size and ring.size:
            out[k] = 10 * np.log10((inside.mean() + 1) / (ring.mean() + 1))
    return out


@settings(max_examples=20, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    length=st.integers(1, 12),
    side=st.sampled_from(["left", "right"]),
)
def test_scores_match_brute_force(seed, length, side):
    """Vectorized shadow fraction and ring contrast equal per-pixel loops on random
    24×24 images with random blobs."""
    rng = np.random.default_rng(seed)
    g = rng.integers(0, 256, size=(24, 24)).astype(np.uint8)
    _, labels = extract_regions(rng.random((24, 24)) < 0.08)
    np.testing.assert_allclose(
        shadow_fraction(g, labels, side, length, 0.6), _brute_shadow(g, labels, side, length, 0.6)
    )
    np.testing.assert_allclose(region_contrast_db(g, labels, 2), _brute_contrast(g, labels, 2))


def test_bad_input_raises_named_errors():
    g, labels, _, _ = _scene()
    with pytest.raises(ValueError, match="far_range"):
        shadow_fraction(g, labels, "up")
    with pytest.raises(ValueError, match="shape"):
        region_contrast_db(g, labels[:10])
    with pytest.raises(ValueError, match="shadow_min_fraction"):
        DetectionFilter(shadow_min_fraction=1.5)
    with pytest.raises(ValueError, match="rank_by"):
        DetectionFilter(rank_by="size")
    with pytest.raises(ValueError, match="annulus_px"):
        region_contrast_db(g, labels, 0)
    # passed to segment() directly (no image for the scores): a clear error
    with pytest.raises(ValueError, match="segment_filtered"):
        segment(g, "kapur", "sdvd", REGION_FILTERS["sdvd-contrast"])
    # no regions / all-zero image: documented empty results, no division by zero
    z = np.zeros((8, 8), dtype=np.uint8)
    zl = np.zeros((8, 8), dtype=np.int32)
    assert region_contrast_db(z, zl).tolist() == [0.0]
    assert shadow_fraction(z, zl).tolist() == [0.0]
    assert shadow_dark_level(z) == 0.0


def test_presets_registered_and_old_sdvd_unchanged():
    """The new presets exist; the old 'sdvd' geometry filter keeps its documented values."""
    assert get_region_filter("sdvd") == RegionFilter(
        max_area_px=2000, max_elongation=6.0, max_count=8
    )
    for name in ("sdvd-contrast", "sdvd-shadow"):
        f = REGION_FILTERS[name]
        assert isinstance(f, DetectionFilter) and f.min_contrast_db == 2.0
        assert f.region.max_area_px == 2000 and f.region.max_count == 4
    assert REGION_FILTERS["sdvd-shadow"].shadow_min_fraction == 0.1
    assert REGION_FILTERS["sdvd-shadow"].far_range == "either"
