"""MIRA / DCP normalization and the SSIM / SIQEM metrics (thesis Ch. 4.1)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam.frontend.normalization import (
    dcp_normalize,
    first_return_index,
    fit_mixed_exponential,
    mira_normalize,
    seabed_mask,
)
from slam.frontend.quality import siqem, siqem_map, ssim
from slam.io.waterfall import waterfall_from_image

# thesis's left-side fit for ping 500 of WE3 (Ch. 4.1.2)
THESIS = {"a": 229.4, "b": -0.005883, "c": 81.63, "d": -0.001001}


def _model(z, a, b, c, d):
    return a * np.exp(b * z) + c * np.exp(d * z)


def test_mira_recovers_known_parameters_within_2_percent(rng):
    """Published parameters → synthetic 1000-sample ping with 0.5 % noise → fit."""
    z = np.arange(1000.0)
    y = _model(z, **THESIS) * (1.0 + 0.005 * rng.standard_normal(z.size))
    fit = fit_mixed_exponential(y)
    for k, v in THESIS.items():
        assert getattr(fit, k) == pytest.approx(v, rel=0.02), k


def test_mira_recovers_parameters_behind_a_water_column(rng):
    """Same ping behind 120 dark samples: the auto start skips them, the fit is unchanged."""
    z = np.arange(1000.0)
    y = _model(z, **THESIS) * (1.0 + 0.005 * rng.standard_normal(z.size))
    y[:120] = 0.5 + 0.1 * rng.random(120)
    start = first_return_index(y)
    assert 115 <= start <= 125
    fit = fit_mixed_exponential(y, start=start)
    for k, v in THESIS.items():
        assert getattr(fit, k) == pytest.approx(v, rel=0.02), k


def _decaying_waterfall(rng, pings=200, s=256, params=(THESIS, THESIS)):
    """Rayleigh-speckle seabed (unit mean) times a per-side exponential decay."""
    z = np.arange(s) * (1000.0 / s)  # decay as over 1000 samples
    speck = rng.rayleigh(scale=np.sqrt(2 / np.pi), size=(pings, 2 * s))
    port = _model(z, **params[0])[::-1]
    stbd = _model(z, **params[1])
    return speck * np.concatenate([port, stbd])[None, :], np.concatenate([port, stbd])


def test_mira_lowers_siqem_on_synthetic_decaying_waterfall(rng):
    """Decay makes neighbouring patches differ (SIQEM > 0); after MIRA the seabed is
    uniform up to speckle, so SIQEM must drop well below the raw value; the normalized mean
    is ≈ 1 (eq. 4.5 divides by the fitted model)."""
    img, _ = _decaying_waterfall(rng)
    res = mira_normalize(img, ping=100, average=9, fit_start=0)
    raw, norm = siqem(img), siqem(res.normalized)
    assert norm < 0.6 * raw
    assert res.normalized.mean() == pytest.approx(1.0, abs=0.05)


def test_mira_block_mode_follows_a_change_of_decay(rng):
    """First 100 pings decay like THESIS, the next 100 twice as fast. One model per block
    reproduces each block's true profile within 8 % (Rayleigh speckle averaged over 41 pings); one global model (fitted in the first
    half) is off by > 30 % somewhere in the second half."""
    fast = dict(THESIS, b=2 * THESIS["b"], d=2 * THESIS["d"])
    a, prof_a = _decaying_waterfall(rng, pings=100)
    b, prof_b = _decaying_waterfall(rng, pings=100, params=(fast, fast))
    img = np.vstack([a, b])
    res = mira_normalize(img, block=100, average=41, fit_start=0)
    assert len(res.port) == len(res.starboard) == 2
    np.testing.assert_array_equal(res.block_rows, [[0, 100], [100, 200]])
    z = np.arange(256.0)
    for k, prof in enumerate((prof_a, prof_b)):
        np.testing.assert_allclose(res.starboard[k](z), prof[256:], rtol=0.08)
        np.testing.assert_allclose(res.port[k](z), prof[:256][::-1], rtol=0.08)
    glob = mira_normalize(img, ping=50, average=41, fit_start=0)
    assert np.max(np.abs(glob.starboard[0](z) / prof_b[256:] - 1.0)) > 0.3


def test_seabed_mask_finds_water_column(rng):
    img, _ = _decaying_waterfall(rng, pings=10, s=200)
    img[:, 150:250] = 0.01  # 50 samples of water column on each side of nadir
    m = seabed_mask(waterfall_from_image(img))
    assert not m[:, 152:248].any()
    assert m[:, :140].all() and m[:, 260:].all()


@pytest.mark.parametrize(
    ("kwargs", "msg"),
    [
        ({"ping": 999}, "ping 999 out of range"),
        ({"block": 0}, "block"),
        ({"average": 0}, "average"),
        ({"fit_start": "x"}, "fit_start"),
    ],
)
def test_mira_bad_parameters(kwargs, msg, rng):
    img, _ = _decaying_waterfall(rng, pings=20, s=64)
    with pytest.raises(ValueError, match=msg):
        mira_normalize(img, **kwargs)


@pytest.mark.parametrize(
    ("img", "msg"),
    [
        (np.ones((10, 33)), "even width"),
        (np.full((10, 64), np.nan), "non-finite"),
        (np.zeros((0, 64)), "empty"),
        (np.ones((4, 64, 3)), "2-D"),
        (np.zeros((10, 64)), "no positive sample"),
    ],
)
def test_mira_bad_images(img, msg):
    with pytest.raises(ValueError, match=msg):
        mira_normalize(img)


def test_mira_constant_image_normalizes_to_ones():
    """Documented result: a constant waterfall is its own model (b = d = 0), Î ≡ 1."""
    res = mira_normalize(np.full((20, 64), 7.0), fit_start=0)
    np.testing.assert_allclose(res.normalized, 1.0, rtol=1e-4)


def test_siqem_matches_hand_computed_grid():
    """2×3 patch means [[1,2,4],[1,2,4]] (signed eq. 4.12): C = max(μ − μ_k)/μ →
    column 0: (1−1)/1 = 0; column 1: (2−1)/2; column 2: (4−2)/4 → mean = (0+.5+.5)/3."""
    mu = np.array([[1.0, 2.0, 4.0], [1.0, 2.0, 4.0]])
    img = np.kron(mu, np.ones((8, 8)))
    assert siqem(img, patch=(8, 8)) == pytest.approx(1.0 / 3.0)
    c = siqem_map(mu, absolute=True)  # |μ − μ_k|: patch (0,0) has neighbours 2, 1, 2 → 1
    assert c[0, 0] == pytest.approx(1.0)
    assert siqem(np.full((64, 64), 3.0)) == 0.0


def test_siqem_mask_and_errors():
    img = np.kron(np.array([[1.0, 2.0, 4.0], [1.0, 2.0, 4.0]]), np.ones((8, 8)))
    mask = np.ones_like(img, bool)
    mask[:, 16:] = False  # drop the brightest column of patches
    assert siqem(img, patch=(8, 8), mask=mask) == pytest.approx(0.25)
    with pytest.raises(ValueError, match="undefined"):
        siqem(np.zeros((64, 64)))
    with pytest.raises(ValueError, match="2×2 patches"):
        siqem(np.ones((10, 10)), patch=(8, 8))
    with pytest.raises(ValueError, match="mask shape"):
        siqem(img, patch=(8, 8), mask=np.ones((3, 3), bool))


def test_ssim_identity_and_shape_errors(rng):
    a = rng.random((32, 32))
    assert ssim(a, a) == pytest.approx(1.0)
    assert ssim(a, rng.random((32, 32))) < 0.2  # independent noise is dissimilar
    assert ssim(np.ones((8, 8)), np.ones((8, 8))) == 1.0
    with pytest.raises(ValueError, match="same shape"):
        ssim(a, a[:, :20])


def test_dcp_range_and_constant_image(rng):
    img, _ = _decaying_waterfall(rng, pings=64, s=64)
    out = dcp_normalize(img)
    assert out.shape == img.shape and out.dtype == np.float32
    assert 0.0 <= out.min() and out.max() <= 1.0
    np.testing.assert_allclose(dcp_normalize(np.full((32, 32), 5.0)), 1.0)
    with pytest.raises(ValueError, match="positive"):
        dcp_normalize(np.zeros((8, 8)))
    with pytest.raises(ValueError, match="omega"):
        dcp_normalize(img, omega=0.0)


def test_mira_block_blend_is_exact_at_block_centres_and_seamless(rng):
    """With blending, a block-centre row is divided by its own block's model (as without
    blending); rows between centres use the linear mix, so no jump at block edges."""
    fast = dict(THESIS, b=2 * THESIS["b"], d=2 * THESIS["d"])
    a, _ = _decaying_waterfall(rng, pings=100)
    b, _ = _decaying_waterfall(rng, pings=100, params=(fast, fast))
    img = np.vstack([a, b])
    hard = mira_normalize(img, block=100, average=41, fit_start=0, blend=False)
    soft = mira_normalize(img, block=100, average=41, fit_start=0)
    for r in (49, 149):
        np.testing.assert_allclose(soft.normalized[r], hard.normalized[r], rtol=1e-6)
    z = np.arange(256.0)
    mid = 0.5 * (soft.starboard[0](z) + soft.starboard[1](z))
    np.testing.assert_allclose(soft.normalized[99, 256:], img[99, 256:] / mid, rtol=0.011)


@settings(max_examples=15, deadline=None)
@given(
    a=st.floats(50, 300),
    b=st.floats(-0.008, -0.004),
    c=st.floats(20, 150),
    d=st.floats(-0.0015, -0.0003),
)
def test_mira_recovers_random_parameters(a, b, c, d):
    """Property: any well-separated pair of decays (b/d ≥ 2.7) is recovered within 2 % from
    a noise-free 1000-sample ping."""
    z = np.arange(1000.0)
    fit = fit_mixed_exponential(_model(z, a, b, c, d))
    for name, v in {"a": a, "b": b, "c": c, "d": d}.items():
        assert getattr(fit, name) == pytest.approx(v, rel=0.02), name
