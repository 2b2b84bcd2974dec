"""Resampling: the count of each particle follows from the weights alone.

Independent expectations: systematic resampling places N evenly spaced points (spacing 1/N)
in the cumulative-weight interval of each particle, whose length is N·w_i, so every count is
floor(N·w_i) or ceil(N·w_i) (|count − N·w_i| < 1); stratified resampling draws one point per
stratum, so |count − N·w_i| < 2; both are unbiased (E[count] = N·w_i).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from slam.estimators.resampling import (
    effective_sample_size,
    normalize_log_weights,
    stratified_resample,
    systematic_resample,
)

weights_strategy = arrays(
    np.float64,
    st.integers(1, 200),
    elements=st.one_of(st.just(0.0), st.floats(1e-6, 1e3)),
).filter(lambda w: w.sum() > 0)


def _counts(idx, n):
    return np.bincount(idx, minlength=n)


@settings(max_examples=200, deadline=None)
@given(w=weights_strategy, seed=st.integers(0, 2**32 - 1))
def test_systematic_counts_within_one_of_n_times_weight(w, seed):
    n = w.size
    idx = systematic_resample(w, np.random.default_rng(seed))
    assert idx.shape == (n,)
    assert np.all((idx >= 0) & (idx < n))
    expected = n * w / w.sum()
    counts = _counts(idx, n)
    assert np.all(np.abs(counts - expected) < 1.0 + 1e-9)
    assert np.all(counts[w == 0] == 0), "a zero-weight particle was copied"


@settings(max_examples=200, deadline=None)
@given(w=weights_strategy, seed=st.integers(0, 2**32 - 1))
def test_stratified_counts_within_two_of_n_times_weight(w, seed):
    n = w.size
    idx = stratified_resample(w, np.random.default_rng(seed))
    counts = _counts(idx, n)
    assert np.all(np.abs(counts - n * w / w.sum()) < 2.0 + 1e-9)
    assert np.all(counts[w == 0] == 0)


@pytest.mark.parametrize("resample", [systematic_resample, stratified_resample])
def test_resampling_is_unbiased_mean_count_equals_n_w(resample):
    """Average count over 4000 draws equals N·w_i within 5 standard errors (each count is
    within 2 of N·w_i, so its standard deviation is below 2)."""
    rng = np.random.default_rng(7)
    w = rng.random(20) ** 3
    w /= w.sum()
    draws = 4000
    total = np.zeros(20)
    for _ in range(draws):
        total += _counts(resample(w, rng), 20)
    np.testing.assert_allclose(total / draws, 20 * w, atol=5 * 2 / np.sqrt(draws))


def test_resampling_uses_only_the_generator_given():
    w = np.array([0.1, 0.2, 0.3, 0.4])
    a = systematic_resample(w, np.random.default_rng(3))
    np.random.seed(0)  # noqa: NPY002 - the global RNG must not matter
    b = systematic_resample(w, np.random.default_rng(3))
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    "w, match",
    [
        (np.array([]), "non-empty"),
        (np.array([[0.5, 0.5]]), "1-D"),
        (np.array([0.5, np.nan]), "finite"),
        (np.array([0.5, -0.1]), ">= 0"),
        (np.array([0.0, 0.0]), "positive sum"),
    ],
)
def test_bad_weights_rejected(w, match):
    with pytest.raises(ValueError, match=match):
        systematic_resample(w, np.random.default_rng(0))


def test_log_weights_far_below_zero_do_not_underflow():
    """Linear weights exp(-1e5) are all 0.0 in float64; the log-sum-exp form keeps their ratios."""
    lw = np.array([-1e5, -1e5 - np.log(2.0), -1e5 - np.log(4.0)])
    assert np.all(np.exp(lw) == 0.0)
    w, log_norm = normalize_log_weights(lw)
    np.testing.assert_allclose(w, np.array([4.0, 2.0, 1.0]) / 7.0)
    np.testing.assert_allclose(log_norm, -1e5 + np.log(7.0 / 4.0))
    with pytest.raises(ValueError, match="all -inf"):
        normalize_log_weights(np.full(3, -np.inf))


def test_effective_sample_size_extremes():
    """N_eff = N for uniform weights and 1 for a single non-zero weight (Kish)."""
    assert effective_sample_size(np.ones(50)) == pytest.approx(50.0)
    assert effective_sample_size(np.eye(1, 50)[0]) == pytest.approx(1.0)
