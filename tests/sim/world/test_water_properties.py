"""Water: published check values of EOS-80 and Mackenzie (1981); validation errors."""

from __future__ import annotations

import pytest

from sim.world import Water, mackenzie_sound_speed, seawater_density


@pytest.mark.parametrize(
    "s,t,rho",
    [(0.0, 5.0, 999.96675), (35.0, 5.0, 1027.67547), (35.0, 25.0, 1023.34306)],
)
def test_eos80_one_atmosphere_check_values_unesco_1981(s, t, rho):
    assert seawater_density(t, s) == pytest.approx(rho, abs=2e-5)


def test_mackenzie_1981_check_value():
    assert mackenzie_sound_speed(25.0, 35.0, 1000.0) == pytest.approx(1550.744, abs=1e-3)


def test_trondheim_fjord_field_trial_sound_speed_matches_thesis_measurement():
    """Thesis: 7.69 °C, 35.07 psu, ~92 m depth, measured 1483.25 m/s (a probe reading, so
    the formula is only expected within 1 m/s)."""
    w = Water.from_ts(7.69, 35.07, reference_depth_m=92.0)
    assert w.sound_speed == pytest.approx(1483.25, abs=1.0)
    assert 1026.0 < w.density < 1028.5


def test_default_water_is_1025():
    assert Water().density == 1025.0


@pytest.mark.parametrize(
    "kw,field",
    [
        ({"density": -5.0}, "density"),
        ({"temperature_c": float("nan")}, "temperature_c"),
        ({"salinity_psu": 80.0}, "salinity_psu"),
        ({"sound_speed": 900.0}, "sound_speed"),
    ],
)
def test_bad_water_raises_naming_field(kw, field):
    with pytest.raises(ValueError, match=field):
        Water(**kw)
