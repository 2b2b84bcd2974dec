"""Kapur maximum entropy threshold: vectorized cumulative-sum version against a direct
double loop, and an analytic two-block case."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from slam.frontend.segmentation import (
    gray_histogram,
    kapur_entropy_curve,
    kapur_threshold,
    kapur_threshold_hist,
    segment,
)


def brute_force_kapur(hist: np.ndarray) -> tuple[int, list[float]]:
    """Double loop over thresholds t and grey levels i with the entropies written out:
    H0 = −Σ_{i<=t} (p_i/P0) ln(p_i/P0), H1 likewise above t; first maximum of H0 + H1."""
    total = float(sum(hist))
    p = [float(h) / total for h in hist]
    curve = []
    best_t, best_h = None, -math.inf
    for t in range(256):
        P0 = sum(p[i] for i in range(t + 1))
        if P0 <= 0 or sum(hist[t + 1 :]) == 0:
            curve.append(-math.inf)
            continue
        P1 = sum(p[i] for i in range(t + 1, 256))
        H0 = -sum((p[i] / P0) * math.log(p[i] / P0) for i in range(t + 1) if p[i] > 0)
        H1 = -sum((p[i] / P1) * math.log(p[i] / P1) for i in range(t + 1, 256) if p[i] > 0)
        curve.append(H0 + H1)
        if H0 + H1 > best_h:
            best_t, best_h = t, H0 + H1
    return best_t, curve


def test_kapur_matches_brute_force_on_sonar_like_histogram(rng):
    """Rayleigh-speckle background plus a bright object: identical threshold and entropy
    curve (to rounding) from both implementations."""
    img = np.concatenate([rng.rayleigh(35.0, 6000), rng.normal(200.0, 20.0, 400)])
    img = np.clip(np.rint(img), 0, 255).astype(np.uint8).reshape(80, 80)
    hist = gray_histogram(img)
    t_ref, curve_ref = brute_force_kapur(hist)
    assert kapur_threshold(img) == t_ref
    curve = kapur_entropy_curve(hist)
    finite = np.isfinite(curve_ref)
    assert np.array_equal(np.isfinite(curve), finite)
    np.testing.assert_allclose(curve[finite], np.asarray(curve_ref)[finite], rtol=1e-12, atol=1e-12)


def test_kapur_two_uniform_blocks_analytic():
    """Levels 10..19 and 200..209 with equal counts: every t in [19, 199] gives
    H0 = H1 = ln 10, the maximum 2 ln 10; the first maximum is t = 19."""
    hist = np.zeros(256)
    hist[10:20] = 7
    hist[200:210] = 7
    assert kapur_threshold_hist(hist) == 19
    assert kapur_entropy_curve(hist)[19] == pytest.approx(2 * math.log(10), rel=1e-12)
    assert kapur_entropy_curve(hist)[150] == pytest.approx(2 * math.log(10), rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(arrays(np.int64, 256, elements=st.integers(0, 30)))
def test_property_kapur_vectorized_equals_double_loop(hist):
    """Random histograms: same entropy curve; the chosen t reaches the brute-force maximum."""
    if hist.sum() == 0:
        with pytest.raises(ValueError, match="all counts are zero"):
            kapur_threshold_hist(hist)
        return
    t_ref, curve_ref = brute_force_kapur(hist)
    t = kapur_threshold_hist(hist)
    curve = kapur_entropy_curve(hist)
    finite = np.isfinite(np.asarray(curve_ref))
    assert np.array_equal(np.isfinite(curve), finite)
    if t_ref is None:  # a single occupied level: nothing is foreground
        assert t == int(np.flatnonzero(hist)[-1])
        return
    np.testing.assert_allclose(curve[finite], np.asarray(curve_ref)[finite], rtol=1e-9, atol=1e-12)
    assert curve_ref[t] == pytest.approx(curve_ref[t_ref], rel=1e-9, abs=1e-12)


def test_kapur_method_segments_bright_object(rng):
    """Uniform background levels 20..70 and object levels 190..240: the entropy sum is
    largest (ln 51 + ln 51) for a threshold in the gap, so the square is the foreground."""
    img = rng.integers(20, 71, (64, 64)).astype(np.uint8)
    img[20:40, 20:40] = rng.integers(190, 241, (20, 20))
    res = segment(img, "kapur", "low-res-sss")
    assert 70 <= res.threshold < 190
    assert len(res.regions) == 1
    assert res.regions[0].centroid_rc == pytest.approx((29.5, 29.5), abs=0.01)


def test_kapur_rejects_bad_histograms():
    with pytest.raises(ValueError, match="shape"):
        kapur_entropy_curve(np.ones(10))
    with pytest.raises(ValueError, match=">= 0"):
        kapur_entropy_curve(-np.ones(256))
