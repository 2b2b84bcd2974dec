"""The sediment law's low-grazing knee: off leaves σ bit for bit; on, it is the closed-form
factor 1 / (1 + (sin θk / sin θg)^m) on every hit (Lambert above the knee, sin^(2+m) below)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.sonar.effects import RealismConfig
from sim.sonar.sediment import SedimentField, low_grazing_factor

MU = 10 ** (-27 / 10)


def test_factor_is_one_half_at_the_knee_and_a_power_law_below_it():
    knee, m = 15.0, 4.0
    s_k = np.sin(np.deg2rad(knee))
    assert low_grazing_factor(s_k, knee, m) == pytest.approx(0.5)
    assert low_grazing_factor(1.0, knee, m) == pytest.approx(1.0 / (1.0 + s_k**4))
    low = np.sin(np.deg2rad(np.array([1.0, 2.0])))
    # far below the knee: (sin θg / sin θk)^m, so a factor 2 in sin θg is 2^m
    f = low_grazing_factor(low, knee, m)
    assert f[1] / f[0] == pytest.approx((low[1] / low[0]) ** m, rel=0.01)


def _hits(n=400, seed=3):
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(-50, 50, (n, 2)), np.zeros(n)])
    graz = np.deg2rad(rng.uniform(3.0, 80.0, n))
    dirs = np.column_stack([np.cos(graz), np.zeros(n), -np.sin(graz)])
    normal = np.tile([0.0, 0.0, 1.0], (n, 1))
    return pts, normal, dirs, np.sin(graz)


def test_knee_on_scales_each_hit_by_the_factor_and_off_is_bit_identical():
    pts, normal, dirs, sin_g = _hits()
    base = RealismConfig(ripple_slope=0.0)
    off = SedimentField(base, MU).sigma_over_mu(pts, normal, dirs)
    again = SedimentField(RealismConfig(ripple_slope=0.0), MU).sigma_over_mu(pts, normal, dirs)
    assert np.array_equal(off, again)
    from dataclasses import replace

    on_cfg = replace(base, low_grazing_knee_deg=12.0, low_grazing_exponent=3.0)
    on = SedimentField(on_cfg, MU).sigma_over_mu(pts, normal, dirs)
    expect = off / (1.0 + (np.sin(np.deg2rad(12.0)) / sin_g) ** 3.0)
    assert np.allclose(on, expect, rtol=1e-9)


@pytest.mark.parametrize(
    "kw, name",
    [
        (dict(low_grazing_knee_deg=0.1), "low_grazing_knee_deg"),
        (dict(low_grazing_knee_deg=75.0), "low_grazing_knee_deg"),
        (dict(low_grazing_exponent=0.0), "low_grazing_exponent"),
    ],
)
def test_bad_knee_values_are_named(kw, name):
    with pytest.raises(ValueError, match=name):
        RealismConfig(**kw)


def _flat_sand(**kw):
    base = dict(frac_mud=0.0, frac_sand=1.0, frac_gravel=0.0, texture_db=0.0)
    return RealismConfig(ripple_slope=0.0, k_clutter=False, **{**base, **kw})


def test_micro_slope_facets_have_the_rms_slope_and_are_world_fixed():
    rng = np.random.default_rng(5)
    xy = rng.uniform(-200, 200, (20000, 2))
    up = np.tile([0.0, 0.0, 1.0], (xy.shape[0], 1))
    f = SedimentField(_flat_sand(micro_slope_deg=3.0, micro_slope_cell_m=0.2), MU)
    n = f.micro_slope_normal(xy, up)
    slope = -n[:, :2] / n[:, 2:]
    assert np.std(slope, axis=0) == pytest.approx([np.tan(np.deg2rad(3.0))] * 2, rel=0.05)
    # two hits in one 0.2-m facet share its tilt; off leaves the normal untouched
    same = np.floor(xy / 0.2) * 0.2 + 0.05
    assert np.allclose(f.micro_slope_normal(same, up), f.micro_slope_normal(same + 0.1, up))
    assert SedimentField(_flat_sand(), MU).micro_slope_normal(xy, up) is up


@pytest.mark.parametrize("grazing_deg", [10.0, 40.0])
def test_micro_slopes_modulate_lambert_as_its_log_slope_predicts(grazing_deg):
    """Rays in the x–z plane see the facet slope along x: to first order
    ln σ changes by d ln(sin² θg)/dθg · δ = 2 δ / tan θg, so std(ln σ) = 2 tan(δ_rms)/tan θg
    (small δ): five times larger at 10° than at 40°."""
    rng = np.random.default_rng(9)
    m = 20000
    pts = np.column_stack([rng.uniform(-200, 200, (m, 2)), np.zeros(m)])
    g = np.deg2rad(grazing_deg)
    dirs = np.tile([np.cos(g), 0.0, -np.sin(g)], (m, 1))
    up = np.tile([0.0, 0.0, 1.0], (m, 1))
    on = SedimentField(_flat_sand(micro_slope_deg=0.5), MU).sigma_over_mu(pts, up, dirs)
    off = SedimentField(_flat_sand(), MU).sigma_over_mu(pts, up, dirs)
    expect = 2.0 * np.tan(np.deg2rad(0.5)) / np.tan(g)
    assert np.std(np.log(on / off)) == pytest.approx(expect, rel=0.1)
