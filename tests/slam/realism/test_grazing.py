"""Texture against grazing angle (slam.realism.grazing): a synthetic waterfall whose seabed
is K-distributed with a known law 1/ν = (sin θc / sin θg)^p recovers θc and p; the real
Scotsman's first half gives texture that grows as grazing falls."""

from __future__ import annotations

import numpy as np
import pytest

from slam.realism.grazing import fit_grazing_texture, tile_grazing_moments

RANGE_M, S, P, H = 30.0, 1024, 512, 5.0


def _k_waterfall(knee_deg: float, p: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    r = (np.arange(S) + 0.5) * RANGE_M / S
    sin_g = np.clip(H / r, 0.0, 1.0)
    inv_nu = np.minimum((np.sin(np.deg2rad(knee_deg)) / sin_g) ** p, 50.0)
    sides = []
    for _ in range(2):
        nu = np.broadcast_to(1.0 / inv_nu, (P, S))
        tex = rng.gamma(nu, 1.0 / nu)
        side = tex * rng.standard_exponential((P, S))
        side[:, r < H] = 1e-4 * rng.standard_exponential((P, int((r < H).sum())))
        sides.append(side)
    return np.concatenate([sides[0][:, ::-1], sides[1]], axis=1)


def test_known_law_is_recovered():
    img = _k_waterfall(9.0, 6.0)
    g, m2 = tile_grazing_moments(img, np.full(P, H), RANGE_M)
    fit = fit_grazing_texture(g, m2)
    assert fit.m2_ref == pytest.approx(2.0, abs=0.15)  # exponential speckle, no texture
    assert fit.knee_deg == pytest.approx(9.0, abs=1.5)
    assert fit.exponent == pytest.approx(6.0, rel=0.35)


def test_pure_speckle_has_no_law():
    img = _k_waterfall(0.5, 6.0)  # ν enormous everywhere: Rayleigh
    g, m2 = tile_grazing_moments(img, np.full(P, H), RANGE_M)
    with pytest.raises(ValueError, match=r"grazing|exponent"):
        fit_grazing_texture(g, m2)


def test_bad_altitude_shape_is_named():
    with pytest.raises(ValueError, match="altitude_m"):
        tile_grazing_moments(np.ones((32, 128)), np.ones(5), RANGE_M)


def test_scotsman_first_half_texture_grows_as_grazing_falls(shared_data):
    from slam.realism.recordings import load_recording

    rec = load_recording(shared_data / "xtf" / "scotsman-iver2.xtf")
    half = rec.pings(0, 230)
    g, m2 = tile_grazing_moments(half.intensity, half.altitude_m, half.slant_range_m)
    fit = fit_grazing_texture(g, m2)
    # texture shape 1 somewhere between 5 and 15 degrees, growing steeply below 20
    assert 5.0 < fit.knee_deg < 15.0 and fit.exponent > 2.0
