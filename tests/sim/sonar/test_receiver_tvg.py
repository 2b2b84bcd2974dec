"""The TVG's spreading law r^n (RealismConfig.tvg_exponent): n = 3 ("30 log R") is the r⁴
TVG divided by r on every sample of the same seeded ping; None keeps r⁴ bit for bit."""

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
