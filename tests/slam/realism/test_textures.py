"""Histogram distances against closed forms, and the LBP histogram on known textures."""

from __future__ import annotations

import numpy as np
import pytest

from slam.realism.textures import (
    LBP_BINS,
    histogram_distances,
    intensity_centres,
    intensity_histogram,
    lbp_histogram,
)


def test_identical_histograms_are_at_distance_zero():
    p = np.array([0.2, 0.5, 0.3])
    d = histogram_distances(p, p * 7, np.arange(3.0))
    assert d.kl == pytest.approx(0.0, abs=1e-9) and d.js == pytest.approx(0.0, abs=1e-7)
    assert d.emd == pytest.approx(0.0, abs=1e-12)


def test_disjoint_and_shifted_histograms():
    """Disjoint supports: JS distance 1 (base 2). A unit mass moved by 3 bins of width 0.5:
    EMD 1.5. Two-bin KL by hand."""
    d = histogram_distances(np.array([1.0, 0, 0, 0]), np.array([0, 0, 0, 1.0]), np.arange(4) * 0.5)
    assert d.js == pytest.approx(1.0, abs=1e-6)
    assert d.emd == pytest.approx(1.5)
    d2 = histogram_distances(np.array([0.5, 0.5]), np.array([0.9, 0.1]), np.arange(2.0))
    assert d2.kl == pytest.approx(0.5 * np.log(0.5 / 0.9) + 0.5 * np.log(0.5 / 0.1), rel=1e-6)


def test_intensity_histogram_is_the_log_exponential_law(rng):
    """Exponential intensity in dB re its median ln2: density of 10 log10(I/ln2)."""
    x = rng.exponential(1.0, (300, 300))
    h = intensity_histogram(x, np.ones_like(x, bool))
    c = intensity_centres()
    i = np.log(2) * 10 ** (c / 10)  # intensity at bin centre
    pdf = np.exp(-i) * i * np.log(10) / 10 * 0.5  # dI/ddB × bin width
    np.testing.assert_allclose(h, pdf, atol=3e-3)


def test_lbp_histogram_of_a_flat_image_is_all_one_code_and_differs_from_noise(rng):
    """A constant image gives code P (all neighbours >= centre) only; white noise spreads
    over all codes; their JS distance is large."""
    mask = np.ones((64, 64), bool)
    flat = lbp_histogram(np.full((64, 64), 5.0), mask)
    assert flat.shape == (LBP_BINS,) and flat[8] == pytest.approx(1.0)
    noise = lbp_histogram(rng.exponential(1.0, (64, 64)), mask)
    assert (noise > 0).sum() == LBP_BINS
    assert histogram_distances(flat, noise, np.arange(LBP_BINS * 1.0)).js > 0.5
