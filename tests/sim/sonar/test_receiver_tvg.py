"""The TVG's spreading law r^n (RealismConfig.tvg_exponent): n = 3 ("30 log R") is the r⁴
TVG divided by r on every sample of the same seeded ping; None keeps r⁴ bit for bit.
The TVG referenced to the bottom return (RealismConfig.tvg_reference = "bottom"): the
law at max(r, altitude), closed form; "transducer" (the default) keeps the old bytes."""

from __future__ import annotations

import numpy as np
import pytest

from sim.realism.survey import RaycastSurvey, SurveySpec
from sim.sonar.acoustics import tvg_gain


def test_tvg_law_is_r_to_the_n_times_absorption():
    r = np.array([0.5, 2.0, 10.0, 30.0])
    g3 = tvg_gain(r, 0.2, "spreading_absorption", 3.0)
    rr = np.maximum(r, 1.0)
    assert np.allclose(g3, rr**3 * 10 ** (0.04 * rr))
    assert np.allclose(tvg_gain(r, 0.2, "spreading_absorption"), rr**4 * 10 ** (0.04 * rr))


def test_survey_with_30_log_r_is_the_40_log_r_survey_over_r():
    spec = SurveySpec(5.0, 20.0, 128, pings=32)
    survey = RaycastSurvey(spec)
    off = {"bit_depth": 0, "receiver_gain_db": 0.0}
    a = survey(off)
    assert np.array_equal(a, survey({**off, "tvg_exponent": None}))
    b = survey({**off, "tvg_exponent": 3.0})
    r = (np.arange(128) + 0.5) * 20.0 / 128
    rr = np.maximum(np.concatenate([r[::-1], r]), 1.0)  # port far range first
    assert np.allclose(b, a / rr[None, :], rtol=1e-5)


def test_bad_tvg_exponent_is_named():
    from sim.sonar.effects import RealismConfig

    with pytest.raises(ValueError, match="tvg_exponent"):
        RealismConfig(tvg_exponent=0.5)


def test_bottom_held_tvg_is_the_law_at_max_of_range_and_bottom():
    from sim.sonar.effects import RealismConfig
    from sim.sonar.receiver import ping_tvg

    r = np.linspace(0.05, 30.0, 200)
    alpha, n, h = 0.19, 3.4, 6.3
    tvg = tvg_gain(r, alpha, "spreading_absorption", n)
    rz = RealismConfig(tvg_exponent=n, tvg_reference="bottom")
    g = ping_tvg(tvg, h, rz, alpha, "spreading_absorption")
    expect = np.where(r < h, h**n * 10 ** (0.2 * alpha * h), r**n * 10 ** (0.2 * alpha * r))
    assert np.allclose(g, expect, rtol=1e-12)
    # the water column's gain follows the altitude as h^n: doubling h adds 10·n·log10 2 dB
    g2 = ping_tvg(tvg_gain(r, 0.0, "spreading", n), 2 * h, rz, 0.0, "spreading")
    assert np.isclose(10 * np.log10(g2[0] / h**n), 10 * n * np.log10(2.0))
    off = RealismConfig(tvg_exponent=n)
    assert ping_tvg(tvg, h, off, alpha, "spreading_absorption") is tvg
    assert ping_tvg(tvg, float("nan"), rz, alpha, "spreading_absorption") is tvg


def test_survey_with_bottom_referenced_tvg_holds_the_gain_over_the_water_column():
    spec = SurveySpec(5.0, 20.0, 128, pings=32)
    survey = RaycastSurvey(spec)
    off = {"bit_depth": 0, "receiver_gain_db": 0.0}
    a = survey(off)
    assert np.array_equal(a, survey({**off, "tvg_reference": "transducer"}))
    b = survey({**off, "tvg_reference": "bottom"})
    r = (np.arange(128) + 0.5) * 20.0 / 128
    rr = np.concatenate([r[::-1], r])  # port far range first
    ratio = b / a  # the same seeded draws before TVG: only the gain differs
    beyond = rr > 5.3
    assert np.allclose(ratio[:, beyond], 1.0, rtol=1e-5)
    inside = rr < 4.7
    # held gain: ratio × r⁴·10^(2αr/10) is one constant (the gain at the bottom return)
    g_held = ratio[:, inside] * np.maximum(rr[inside], 1.0) ** 4
    spread = g_held.max() / g_held.min()
    alpha_db_m = np.log10(spread) / (0.2 * (rr[inside].max() - rr[inside].min()))
    assert alpha_db_m < 0.3  # only the absorption term (≤ 0.3 dB/m at 680 kHz) remains
    h_eff = np.median(g_held) ** 0.25
    assert 4.7 < h_eff < 5.3  # held at the altitude (the bottom return), not elsewhere


def test_bad_tvg_reference_is_named():
    from sim.sonar.effects import RealismConfig

    with pytest.raises(ValueError, match="tvg_reference"):
        RealismConfig(tvg_reference="surface")
