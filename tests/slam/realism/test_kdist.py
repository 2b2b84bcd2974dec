"""K-distribution shape recovery on samples drawn from a K distribution."""

from __future__ import annotations

import numpy as np
import pytest

from slam.realism.kdist import (
    k_amplitude_cv,
    k_shape_from_log_moments,
    k_shape_from_moments,
    sample_k_intensity,
)


@pytest.mark.parametrize("nu", [0.7, 2.0, 6.0])
@pytest.mark.parametrize("looks", [1.0, 3.0])
def test_shape_recovered_from_moments_and_log_moments(nu, looks, rng):
    x = sample_k_intensity((400_000,), nu, looks, rng, mu=37.0)
    assert k_shape_from_log_moments(x, looks) == pytest.approx(nu, rel=0.08)
    assert k_shape_from_moments(x, looks) == pytest.approx(nu, rel=0.2)


def test_pure_speckle_gives_infinite_or_large_shape(rng):
    x = rng.exponential(2.0, 400_000)
    assert k_shape_from_log_moments(x) > 100
    assert k_shape_from_moments(x) > 50


def test_amplitude_cv_formula_limits_and_sampling(rng):
    """nu → ∞ with one look is Rayleigh sqrt(4/pi - 1); the formula matches a sample."""
    assert k_amplitude_cv(np.inf, 1.0) == pytest.approx(np.sqrt(4 / np.pi - 1), rel=1e-12)
    a = np.sqrt(sample_k_intensity((400_000,), 1.5, 2.0, rng))
    assert k_amplitude_cv(1.5, 2.0) == pytest.approx(a.std() / a.mean(), rel=0.01)


def test_bad_input_raises(rng):
    with pytest.raises(ValueError, match="positive"):
        k_shape_from_moments(np.array([1.0, 0.0, 2.0]))
    with pytest.raises(ValueError, match="nu > 0"):
        sample_k_intensity((3,), -1.0, 1.0, rng)
