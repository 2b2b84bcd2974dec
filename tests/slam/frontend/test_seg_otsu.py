"""Improved Otsu TSM: thresholds against a literal implementation of eqs. 3.1–3.10, the
re-threshold on a synthetic image with known speckle and a known object, and properties
on random images."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from skimage.filters import threshold_otsu

from slam.frontend.segmentation import (
    SegmentationParams,
    canny_edges,
    count_small_contours,
    gray_histogram,
    improved_otsu,
    otsu_threshold,
    otsu_threshold_hist,
    power_law,
    power_law_lut,
    segment,
)


def brute_force_otsu(n: np.ndarray, lo: int) -> int:
    """Eqs. 3.1–3.10 written out literally: loops over T* and over grey levels, class
    means and variances from their definitions, T* = argmax σ_B² (first maximum)."""
    N = sum(float(n[i]) for i in range(lo, 256))  # (3.1)
    p = {i: float(n[i]) / N for i in range(lo, 256)}  # (3.2)
    best_t, best_sb = lo - 1, 0.0
    for ts in range(lo, 256):
        w0 = sum(p[i] for i in range(lo, ts + 1))  # (3.3)
        w1 = sum(p[i] for i in range(ts + 1, 256))
        if w0 <= 0.0 or w1 <= 0.0:
            continue
        u0 = sum(i * p[i] for i in range(lo, ts + 1)) / w0  # (3.4)
        u1 = sum(i * p[i] for i in range(ts + 1, 256)) / w1
        um = w0 * u0 + w1 * u1  # (3.5)
        s0 = sum((i - u0) ** 2 * p[i] for i in range(lo, ts + 1)) / w0  # (3.6)
        s1 = sum((i - u1) ** 2 * p[i] for i in range(ts + 1, 256)) / w1
        sw = w0 * s0 + w1 * s1  # (3.7)
        sb = w0 * (u0 - um) ** 2 + w1 * (u1 - um) ** 2  # (3.8)
        sm = sum((i - um) ** 2 * p[i] for i in range(lo, 256))  # total variance
        assert abs(sw + sb - sm) <= 1e-9 * max(sm, 1.0)  # (3.9)
        if sb > best_sb:  # (3.10)
            best_t, best_sb = ts, sb
    return best_t


def speckle_scene(rng: np.random.Generator, size: int = 400):
    """Dark noisy seabed, 400 bright 2×2 speckles (level 170) and one bright 60×90 object
    (level 245) centred at (row 200, col 250). Returns (image, object mask, speckle mask)."""
    img = np.clip(rng.normal(40.0, 12.0, (size, size)), 0, 255)
    obj = np.zeros((size, size), bool)
    obj[170:230, 205:295] = True
    speck = np.zeros((size, size), bool)
    n = 0
    while n < 400:
        r, c = rng.integers(2, size - 4, 2)
        if obj[max(r - 6, 0) : r + 8, max(c - 6, 0) : c + 8].any():
            continue
        if speck[max(r - 2, 0) : r + 4, max(c - 2, 0) : c + 4].any():
            continue
        speck[r : r + 2, c : c + 2] = True
        n += 1
    img[speck] = 170.0
    img[obj] = 245.0
    return np.rint(img).astype(np.uint8), obj, speck


SCENE_PARAMS = SegmentationParams(a_px=30, n_max=100, canny_high=0.33, name="test")


def test_power_law_lut_matches_eq_3_11():
    """y = 0.1·x^1.415 rounded: 0 -> 0, 100 -> 0.1·100^1.415 = 67.6 -> 68, 255 -> 254."""
    lut = power_law_lut(0.1, 1.415)
    assert lut[0] == 0
    assert lut[100] == round(0.1 * 100**1.415) == 68
    assert lut[255] == 254
    assert np.all(np.diff(lut.astype(int)) >= 0)


def test_speckle_rethreshold_triggers_removes_speckle_keeps_object(rng):
    """Known speckle and object: N_a exceeds N_max, T* > T lies between the speckle and the
    object levels after the power law, no landmark on speckle, one on the object."""
    img, obj, speck = speckle_scene(rng)
    res = improved_otsu(img, SCENE_PARAMS)
    y_speck = int(power_law_lut()[170])
    y_obj = int(power_law_lut()[245])
    assert res.retriggered
    assert res.n_small_contours > SCENE_PARAMS.n_max
    assert res.threshold < y_speck  # plain Otsu keeps the speckle ...
    assert y_speck <= res.threshold_star < y_obj  # ... the constrained one does not
    assert not (res.binary & speck).any()
    assert len(res.landmarks) == 1
    (reg,) = res.landmarks
    assert reg.centroid_rc == pytest.approx((199.5, 249.5), abs=0.01)
    assert reg.area_px >= obj.sum()  # dilation grows it by one pixel ring
    assert reg.bbox == (169, 204, 231, 296)


def test_speckle_scene_plain_otsu_keeps_speckle(rng):
    """Second view of the same scene: without the re-threshold (plain Otsu on the raw
    image) the 2×2 speckles are foreground, so N_a counts roughly one contour each."""
    img, _, speck = speckle_scene(rng)
    res = segment(img, "otsu", SCENE_PARAMS)
    assert res.binary[speck].all()
    edges = canny_edges(res.binary, 0.33)
    assert count_small_contours(edges, 30) >= 350


def test_thresholds_match_brute_force_eqs_3_1_to_3_10(rng):
    """T (OpenCV's Otsu) and T* (ours) equal the literal loop over eqs. 3.1–3.10 exactly."""
    img, _, _ = speckle_scene(rng)
    res = improved_otsu(img, SCENE_PARAMS)
    hist = gray_histogram(power_law(img))
    assert res.threshold == brute_force_otsu(hist, 0)
    assert res.threshold_star == brute_force_otsu(hist, int(res.threshold) + 1)
    # and the vectorized function agrees for every range start with occupied levels above it
    for lo in (0, 1, 17, int(res.threshold) + 1, 143, 200):
        assert otsu_threshold_hist(hist, lo)[0] == brute_force_otsu(hist, lo)


def test_otsu_full_range_matches_opencv_and_skimage(rng):
    """Three implementations of plain Otsu agree on a smooth bimodal image."""
    img = np.clip(
        np.concatenate([rng.normal(60, 15, 3000), rng.normal(170, 25, 1500)]), 0, 255
    ).astype(np.uint8)
    img = img.reshape(50, 90)
    t_ours, _ = otsu_threshold_hist(gray_histogram(img), 0)
    assert t_ours == otsu_threshold(img) == int(threshold_otsu(img))


def test_canny_relative_threshold_scale_invariant(rng):
    """Edges of a binary image depend only on the relative thresholds: scaling the input
    by 200 gives the same map (MATLAB's normalization by the maximum gradient)."""
    b = np.zeros((60, 60), np.float32)
    b[20:40, 15:45] = 1.0
    e1 = canny_edges(b, 0.33)
    e2 = canny_edges(b * 200.0, 0.33)
    assert np.array_equal(e1, e2)
    # a closed rectangle outline: one 8-connected contour
    n, _ = cv2.connectedComponents((e1 > 0).astype(np.uint8), connectivity=8)
    assert n - 1 == 1
    assert count_small_contours(e1, 30) == 0  # its perimeter is ~100 px
    assert count_small_contours(e1, 500) == 1


def test_no_retrigger_when_few_small_contours():
    """A clean two-level image has no small contours: T* = T and no re-threshold."""
    img = np.full((100, 100), 30, np.uint8)
    img[30:70, 30:70] = 220
    res = improved_otsu(img, SCENE_PARAMS)
    assert not res.retriggered and res.n_small_contours == 0
    assert res.threshold_star == res.threshold
    assert len(res.regions) == 1


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(arrays(np.uint8, st.tuples(st.integers(4, 40), st.integers(4, 40))))
def test_property_random_images(img):
    """Any uint8 image: thresholds in [0, 255], T* >= T, T* > T when the re-threshold ran
    and at least two grey levels lie above T, regions partition the final mask."""
    params = SegmentationParams(a_px=3, n_max=1, canny_high=0.2, name="prop")
    res = improved_otsu(img, params)
    assert 0 <= res.threshold <= 255 and 0 <= res.threshold_star <= 255
    assert res.threshold_star >= res.threshold
    y = power_law(img)
    if res.retriggered and np.unique(y[y > res.threshold]).size >= 2:
        assert res.threshold_star > res.threshold
    assert sum(r.area_px for r in res.regions) == int(res.mask.sum())
    assert np.array_equal(res.binary, y > res.threshold_star) or y.min() == y.max()


@settings(max_examples=40, deadline=None)
@given(
    arrays(np.int64, 256, elements=st.integers(0, 50)),
    st.integers(0, 254),
)
def test_property_hist_otsu_is_optimal(hist, lo):
    """On any histogram the vectorized T* reaches the brute-force maximum of σ_B² (equal
    index when the maximum is unique beyond rounding)."""
    if hist[lo:].sum() == 0:
        assert otsu_threshold_hist(hist, lo) == (lo - 1, 0.0)
        return
    t, sb = otsu_threshold_hist(hist, lo)
    t_ref = brute_force_otsu(hist, lo)
    if t_ref == lo - 1:
        assert t == lo - 1
    else:
        assert lo <= t <= 255
        # the σ_B² of both choices agree to rounding
        h = hist[lo:].astype(float)
        p = h / h.sum()
        lv = np.arange(lo, 256)

        def sigma_b(ts):
            w0 = p[: ts - lo + 1].sum()
            w1 = 1 - w0
            u0 = (lv[: ts - lo + 1] * p[: ts - lo + 1]).sum() / w0
            u1 = (lv[ts - lo + 1 :] * p[ts - lo + 1 :]).sum() / w1
            return w0 * w1 * (u0 - u1) ** 2

        assert sigma_b(t) == pytest.approx(sigma_b(t_ref), rel=1e-9)
        assert sb == pytest.approx(sigma_b(t_ref), rel=1e-9)
