"""The shipped Humminbird preset (assets/sonars/humminbird_calibrated.toml, per side): it
loads per side, a short survey with each side's values runs, and its first samples carry
the recording's alternating 5- and 2-sample transmit pulse at the top display level."""

from __future__ import annotations

import numpy as np
import pytest

from sim.realism.survey import RaycastSurvey, SurveySpec
from sim.sonar.preset_file import SIDES, load_preset_file

NAME = "humminbird_calibrated"
RANGE_M, SAMPLES = 27.756989626394414, 1479  # the recording's slant range and samples


@pytest.fixture(scope="module")
def preset_file():
    return load_preset_file(NAME, per_side=True)


def test_per_side_preset_is_refused_for_a_scenario(preset_file):
    assert set(preset_file.side_overrides) == set(SIDES)
    with pytest.raises(ValueError, match="per-side"):
        load_preset_file(NAME)


@pytest.mark.parametrize("side", SIDES)
def test_short_survey_shows_the_recordings_transmit_pulse(preset_file, side):
    """32 pings at the recording's first-half altitude (4.3 m): the side's first samples
    sit at the top 8-bit level for 5 samples on even pings and 2 on odd ones (measured on
    the recording, tests/sim/sonar/test_transmit_pulse.py), and nowhere else in the water
    column before the seabed."""
    survey = RaycastSurvey(
        SurveySpec(4.3, RANGE_M, SAMPLES, pings=32, preset=preset_file.base, display_bits=8)
    )
    cfg_values = {**preset_file.overrides, **preset_file.side_overrides[side]}
    img = np.sqrt(survey(cfg_values))
    near = img[:, :SAMPLES][:, ::-1] if side == "port" else img[:, SAMPLES:]
    bottom = int(4.3 / (RANGE_M / SAMPLES))
    top = near[:, : bottom - 10] >= 255
    runs = np.argmin(top, axis=1)
    assert runs[0::2].tolist() == [5] * 16
    assert runs[1::2].tolist() == [2] * 16
    assert top.sum() == runs.sum()
    assert np.all(np.isfinite(img)) and img.max() <= 255
