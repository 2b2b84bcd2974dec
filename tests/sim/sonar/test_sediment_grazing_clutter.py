"""Low-grazing clutter (RealismConfig.grazing_clutter_deg): off leaves σ bit for bit; on,
each hit is scaled by a world-fixed unit-mean gamma texture whose shape ν follows the
closed form 1/ν = (sin θc / sin θg)^p — checked against the gamma law's own moments
(mean 1, variance 1/ν) over many clutter cells at one grazing angle."""

from __future__ import annotations

import numpy as np
import pytest

from sim.sonar.effects import RealismConfig
from sim.sonar.sediment import SedimentField, low_grazing_texture

MU = 10 ** (-27 / 10)


def _hits_at(grazing_deg: float, n: int = 40000, seed: int = 5):
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(-200, 200, (n, 2)), np.zeros(n)])
    g = np.deg2rad(grazing_deg)
    dirs = np.tile([np.cos(g), 0.0, -np.sin(g)], (n, 1))
    normal = np.tile([0.0, 0.0, 1.0], (n, 1))
    return pts, normal, dirs


def test_inverse_shape_is_one_at_the_knee_and_a_power_law_below():
    assert low_grazing_texture(np.sin(np.deg2rad(11.0)), 11.0, 8.0) == pytest.approx(1.0)
    s = np.sin(np.deg2rad(np.array([20.0, 10.0])))
    v = low_grazing_texture(s, 11.0, 8.0)
    assert v[1] / v[0] == pytest.approx((s[0] / s[1]) ** 8.0)


@pytest.mark.parametrize("grazing", [9.0, 12.0, 14.0])
def test_texture_has_unit_mean_and_gamma_variance(grazing):
    pts, normal, dirs = _hits_at(grazing)
    base = dict(ripple_slope=0.0, k_clutter=False, texture_db=0.0, frac_mud=0.0, frac_gravel=0.0)
    off = SedimentField(RealismConfig(**base), MU).sigma_over_mu(pts, normal, dirs)
    cfg = RealismConfig(**base, grazing_clutter_deg=11.0, grazing_clutter_exponent=6.0)
    on = SedimentField(cfg, MU).sigma_over_mu(pts, normal, dirs)
    tex = on / off
    inv_nu = (np.sin(np.deg2rad(11.0)) / np.sin(np.deg2rad(grazing))) ** 6.0
    # distinct clutter cells only (hits in one 6-cm cell share a value): 40000 hits over
    # 400 m x 400 m are almost all in distinct cells
    n = tex.size
    assert tex.mean() == pytest.approx(1.0, abs=4 * np.sqrt(inv_nu / n) + 0.01)
    assert tex.var() == pytest.approx(inv_nu, rel=0.15)


def test_off_is_bit_identical():
    pts, normal, dirs = _hits_at(12.0, n=500)
    a = SedimentField(RealismConfig(), MU).sigma_over_mu(pts, normal, dirs)
    b = SedimentField(RealismConfig(grazing_clutter_deg=None), MU).sigma_over_mu(pts, normal, dirs)
    assert np.array_equal(a, b)


def test_bad_grazing_clutter_is_named():
    with pytest.raises(ValueError, match="grazing_clutter_deg"):
        RealismConfig(grazing_clutter_deg=0.0)
