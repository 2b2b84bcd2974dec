"""Realism statistics against analytic cases (Rayleigh, K, AR(1) fields, mixtures)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq
from scipy.signal import lfilter
from scipy.special import hyp2f1

from slam.realism.kdist import k_amplitude_cv, sample_k_intensity
from slam.realism.statistics import (
    RealismConfig,
    first_return_from_altitude,
    waterfall_statistics,
)

from .conftest import WC_MEAN, WC_SAMPLES, make_waterfall

P, S_SEABED = 256, 448
RAYLEIGH_CV = np.sqrt(4.0 / np.pi - 1.0)  # 0.5227
LOG_EXP_STD_DB = 10.0 / np.log(10.0) * np.pi / np.sqrt(6.0)  # 5.570 dB


def _ar1(shape, phi_pings, phi_range, rng):
    """Unit-variance Gaussian field with separable AR(1) correlation: lag-1 correlation is
    exactly phi_range along range and phi_pings across pings (stationary start)."""
    x = rng.standard_normal(shape)
    for axis, phi in ((1, phi_range), (0, phi_pings)):
        zshape = list(shape)
        zshape[axis] = 1
        zi = phi * rng.standard_normal(zshape)  # phi·y[-1], y[-1] a stationary N(0, 1) draw
        x, _ = lfilter([np.sqrt(1 - phi**2)], [1.0, -phi], x, axis=axis, zi=zi)
    return x


def test_rayleigh_speckle_cv_db_std_and_zero_correlation(rng, waterfall_factory):
    """Exponential intensity: amplitude CV sqrt(4/pi - 1), dB std pi/sqrt(6)·10/ln10,
    uncorrelated neighbours."""
    w = waterfall_factory(
        rng.exponential(1.0, (P, S_SEABED)), rng.exponential(1.0, (P, S_SEABED)), rng
    )
    for s in waterfall_statistics(w).sides().values():
        assert s.cv_amplitude == pytest.approx(RAYLEIGH_CV, rel=0.02)
        assert s.db_std == pytest.approx(LOG_EXP_STD_DB, abs=0.1)
        assert abs(s.lag1_range) < 0.02 and abs(s.lag1_ping) < 0.02
        assert s.n_patches > 0.8 * (P // 16) * (S_SEABED // 16)


def test_water_column_dynamic_range_and_saturation_match_the_mixture(rng, waterfall_factory):
    """Water column = median of Exp(WC_MEAN) re seabed mean 1; dynamic range = ratio of
    the 99th/1st percentiles of the exponential mixture; saturation = Exp tail over clip."""
    clip = 6.0  # about half of the patches hold a clipped sample and are left out
    w = waterfall_factory(
        rng.exponential(1.0, (P, S_SEABED)), rng.exponential(1.0, (P, S_SEABED)), rng
    )
    w = np.minimum(w, clip)
    stats = waterfall_statistics(w, RealismConfig(full_scale=clip))
    f_wc = WC_SAMPLES / (WC_SAMPLES + S_SEABED)

    def cdf(x):
        return f_wc * (1 - np.exp(-x / WC_MEAN)) + (1 - f_wc) * (1 - np.exp(-x))

    lo = brentq(lambda x: cdf(x) - 0.01, 1e-12, 10)
    hi = brentq(lambda x: cdf(x) - 0.99, 1e-12, 10)
    for s in stats.sides().values():
        assert s.water_column_db == pytest.approx(10 * np.log10(np.log(2) * WC_MEAN), abs=0.4)
        assert s.dynamic_range_db == pytest.approx(10 * np.log10(hi / lo), abs=0.3)
        assert s.saturation == pytest.approx((1 - f_wc) * np.exp(-clip), rel=0.2)


def test_k_distributed_amplitude_cv_matches_the_analytic_k_value(rng, waterfall_factory):
    """I.i.d. K intensity (nu = 4, one look): amplitude CV from the Gamma-function formula,
    larger than Rayleigh."""
    nu = 4.0
    sides = [sample_k_intensity((P, S_SEABED), nu, 1.0, rng) for _ in range(2)]
    stats = waterfall_statistics(waterfall_factory(*sides, rng), RealismConfig(homogeneity_db=100))
    for s in stats.sides().values():
        assert s.cv_amplitude == pytest.approx(k_amplitude_cv(nu), rel=0.03)
        assert s.cv_amplitude > RAYLEIGH_CV * 1.1


def test_lag1_correlation_of_a_separable_ar1_amplitude_field(rng, waterfall_factory):
    """A = 10 + g with g AR(1) (0.6 along range, 0.3 across pings): lag-1 amplitude
    correlations 0.6 / 0.3, minus the patch-mean bias (ρ - v)/(1 - v), v = var of the mean."""
    sides = [(10.0 + _ar1((P, S_SEABED), 0.3, 0.6, rng)) ** 2 for _ in range(2)]
    stats = waterfall_statistics(waterfall_factory(*sides, rng), RealismConfig(homogeneity_db=100))
    v = (1.6 / 0.4 / 16) * (1.3 / 0.7 / 16)  # patch-mean variance, AR(1) sums, n = 16 × 16
    for s in stats.sides().values():
        assert s.lag1_range == pytest.approx((0.6 - v) / (1 - v), abs=0.03)
        assert s.lag1_ping == pytest.approx((0.3 - v) / (1 - v), abs=0.03)


def test_lag1_correlation_of_correlated_complex_speckle(rng, waterfall_factory):
    """Complex Gaussian speckle with field correlation rho along range: amplitude
    correlation (pi/4)(2F1(-1/2,-1/2;1;rho^2) - 1)/(1 - pi/4) (Rayleigh envelope law)."""
    rho = 0.8
    sides = []
    for _ in range(2):
        re, im = (_ar1((P, S_SEABED), 0.0, rho, rng) for _ in range(2))
        sides.append(re**2 + im**2)
    stats = waterfall_statistics(waterfall_factory(*sides, rng), RealismConfig(homogeneity_db=100))
    expected = (np.pi / 4) * (hyp2f1(-0.5, -0.5, 1.0, rho**2) - 1) / (1 - np.pi / 4)
    for s in stats.sides().values():
        assert s.lag1_range == pytest.approx(expected, abs=0.04)
        assert abs(s.lag1_ping) < 0.03


@settings(max_examples=8, deadline=None)
@given(scale=st.floats(1e-6, 1e6), seed=st.integers(0, 2**16))
def test_statistics_are_invariant_to_gain(scale, seed):
    """Every statistic is a ratio or a correlation: multiplying the intensity by a gain
    changes nothing (up to rounding)."""
    rng = np.random.default_rng(seed)
    sides = [sample_k_intensity((64, 192), 3.0, 1.0, rng) for _ in range(2)]
    w = make_waterfall(*sides, rng)
    a, b = waterfall_statistics(w), waterfall_statistics(w * scale)
    for sa, sb in zip(a.sides().values(), b.sides().values(), strict=True):
        for k, v in sa.scalars().items():
            assert sb.scalars()[k] == pytest.approx(v, rel=1e-6, abs=1e-9), k
        np.testing.assert_allclose(sa.hist_lbp, sb.hist_lbp, atol=1e-3)


def test_mirroring_the_waterfall_swaps_port_and_starboard(rng, waterfall_factory):
    """Port is the mirrored left half: flipping the image left-right swaps the sides."""
    w = waterfall_factory(rng.exponential(1.0, (64, 192)), rng.gamma(3.0, 1 / 3, (64, 192)), rng)
    a, b = waterfall_statistics(w), waterfall_statistics(w[:, ::-1])
    assert a.port.scalars() == b.starboard.scalars()
    assert a.starboard.scalars() == b.port.scalars()


def test_too_short_and_no_seabed_and_negative_input_raise(rng, waterfall_factory):
    with pytest.raises(ValueError, match="too short"):
        waterfall_statistics(rng.exponential(1.0, (20, 512)))
    with pytest.raises(ValueError, match="no seabed"):
        waterfall_statistics(rng.exponential(1.0, (128, 512)))  # speckle, no water column
    with pytest.raises(ValueError, match="no seabed"):
        waterfall_statistics(np.full((128, 512), 1e-3) + rng.exponential(1e-4, (128, 512)))
    with pytest.raises(ValueError, match=">= 0"):
        w = waterfall_factory(rng.exponential(1.0, (64, 192)), rng.exponential(1.0, (64, 192)), rng)
        w[3, 5] = -1.0
        waterfall_statistics(w)
    with pytest.raises(ValueError, match="dr_percentiles"):
        RealismConfig(dr_percentiles=(99.0, 1.0))


def test_first_return_from_altitude_replaces_the_detector(rng):
    """A water column as bright as the seabed defeats the detector ("no seabed"); the
    altitude gives the split and the seabed is Rayleigh again. Index = altitude / range
    per sample."""
    p, s, wc = 96, 256, 40
    side = rng.exponential(1.0, (p, s))
    side[:, :wc] = 0.8 * rng.exponential(1.0, (p, wc)) + 0.2  # bright, not speckle
    w = np.concatenate([side[:, ::-1], rng.exponential(1.0, (p, s))], axis=1)
    w[:, s : s + wc] = side[:, :wc]
    with pytest.raises(ValueError, match="no seabed"):
        waterfall_statistics(w)
    fr = first_return_from_altitude(np.full(p, 6.0), 38.4, s)  # 6 m / 0.15 m per sample
    assert fr[0] == pytest.approx(wc)
    st = waterfall_statistics(w, first_return=fr)
    assert st.port.cv_amplitude == pytest.approx(RAYLEIGH_CV, rel=0.03)
    assert first_return_from_altitude(np.array([-1.0, 50.0]), 38.4, s).tolist() == [
        pytest.approx(np.nan, nan_ok=True),
        pytest.approx(np.nan, nan_ok=True),
    ]


def _tile_texture(rng, sigma_db, p=512):
    """Seabed of exponential speckle times a log-normal level constant over each 16 × 16
    tile of the statistics' grid (seabed starts at sample WC_SAMPLES, a tile boundary)."""
    tex = 10.0 ** (rng.normal(0.0, sigma_db, (p // 16, S_SEABED // 16)) / 10.0)
    return rng.exponential(1.0, (p, S_SEABED)) * np.kron(tex, np.ones((16, 16)))


@pytest.mark.parametrize("sigma_db", [0.0, 3.0])
def test_tile_texture_is_speckle_and_texture_in_quadrature(rng, waterfall_factory, sigma_db):
    """Tile means of 256 independent exponential samples spread by 10/ln10·√ψ₁(256)
    (0.27 dB); a level constant over each tile with std σ dB adds σ in quadrature."""
    from scipy.special import polygamma

    assert WC_SAMPLES % 16 == 0
    speckle_db = 10.0 / np.log(10.0) * np.sqrt(float(polygamma(1, 256)))
    w = waterfall_factory(_tile_texture(rng, sigma_db), _tile_texture(rng, sigma_db), rng)
    for s in waterfall_statistics(w).sides().values():
        assert s.texture_tile_db == pytest.approx(np.hypot(speckle_db, sigma_db), rel=0.1)


def test_tile_texture_ignores_a_few_bright_target_tiles(rng, waterfall_factory):
    """A +20 dB 'wreck' over 2 % of the seabed tiles leaves the robust spread within 10 %."""
    sb = [_tile_texture(rng, 2.0) for _ in range(2)]
    plain = waterfall_statistics(waterfall_factory(*sb, rng)).port.texture_tile_db
    sb[0][:48, :48] *= 100.0
    with_wreck = waterfall_statistics(waterfall_factory(*sb, rng)).port.texture_tile_db
    assert with_wreck == pytest.approx(plain, rel=0.1)


@pytest.mark.parametrize("far_level", [1.0, 0.05])
def test_far_range_level_is_the_outer_quarter_median_re_the_profile_peak(
    rng, waterfall_factory, far_level
):
    """Exponential seabed of mean 1 whose outer quarter of the side (samples ≥ 3S/4) has
    mean ``far_level``: its median is ln 2 · far_level, the profile peak 1 (to the few %
    of a 16-sample mean over the pings), so far_range_db = 10·log10(ln 2 · far_level)."""
    p = 256
    s = WC_SAMPLES + S_SEABED
    mean = np.ones(S_SEABED)
    mean[(3 * s) // 4 - WC_SAMPLES :] = far_level
    sb = [rng.exponential(1.0, (p, S_SEABED)) * mean for _ in range(2)]
    for side in waterfall_statistics(waterfall_factory(*sb, rng)).sides().values():
        assert side.far_range_db == pytest.approx(10 * np.log10(np.log(2) * far_level), abs=0.3)
