"""Echo binning: the closed-form box splat against a brute-force overlap sum."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.sonar.echo import _coverage, _splat_energy


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 300))
def test_box_splat_equals_bruteforce_overlap(seed, n):
    """Second implementation: each cell gets Σ E·|[a,b) ∩ [k,k+1)| / (b − a); spans partly
    outside the range axis lose exactly the outside part (energy conservation)."""
    rng = np.random.default_rng(seed)
    n_bins, n_rows = 40, 3
    a = rng.uniform(-5, n_bins + 2, n)
    b = a + rng.uniform(0.5, 12, n)
    e = rng.uniform(0.1, 10, n)
    rows = rng.integers(0, n_rows, n)
    out = _splat_energy(rows, a, b, e, n_rows, n_bins)
    k = np.arange(n_bins)
    ov = (
        np.clip(np.minimum(b[:, None], k + 1.0) - np.maximum(a[:, None], k), 0, None)
        / (b - a)[:, None]
    )
    ref = np.zeros((n_rows, n_bins))
    np.add.at(ref, rows, e[:, None] * ov)
    np.testing.assert_allclose(out, ref, rtol=1e-9, atol=1e-9 * e.sum())


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_coverage_counts_spans(seed):
    """Brute force: cell k of row r is covered by the spans [s, e) of that row containing k."""
    rng = np.random.default_rng(seed)
    s = rng.integers(0, 30, 50)
    e = np.minimum(s + rng.integers(0, 8, 50), 30)
    rows = rng.integers(0, 2, 50)
    cov = _coverage(rows, s, e, 2, 30)
    k = np.arange(30)
    ref = np.stack(
        [((rows[:, None] == r) & (s[:, None] <= k) & (k < e[:, None])).sum(0) for r in (0, 1)]
    )
    np.testing.assert_array_equal(cov, ref)
