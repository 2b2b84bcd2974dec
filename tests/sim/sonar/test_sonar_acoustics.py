"""Acoustic model: absorption formulas, beam patterns, validity errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.sonar.acoustics import (
    absorption_ainslie_mccolm,
    absorption_francois_garrison,
    beam_pattern,
    compress_log,
)
from sim.sonar.config import AcousticConfig, Water


@settings(max_examples=60, deadline=None)
@given(
    f=st.floats(1e3, 1e6),
    t=st.floats(0.0, 20.0),
    s=st.floats(30.0, 35.0),
    d=st.floats(0.0, 1000.0),
)
def test_francois_garrison_within_10_percent_of_ainslie_mccolm(f, t, s, d):
    """Second implementation: Ainslie & McColm (1998) publish that their simplified formula
    stays within 10 % of Francois–Garrison over 100 Hz – 1 MHz for these conditions."""
    fg = absorption_francois_garrison(f, t, s, d)
    am = absorption_ainslie_mccolm(f, t, s, d)
    assert fg > 0
    assert abs(am / fg - 1.0) < 0.10


def test_absorption_grows_with_frequency_in_sonar_band():
    """Physical law: between 10 kHz and 1 MHz α increases monotonically with frequency."""
    f = np.linspace(1e4, 1e6, 200)
    a = absorption_francois_garrison(f, 7.69, 35.0, 92.0)
    assert np.all(np.diff(a) > 0)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        (dict(frequency_hz=2e6, temperature_c=10, salinity_psu=35, depth_m=10), "frequency_hz"),
        (dict(frequency_hz=50.0, temperature_c=10, salinity_psu=35, depth_m=10), "frequency_hz"),
        (dict(frequency_hz=3.4e5, temperature_c=25, salinity_psu=35, depth_m=10), "temperature_c"),
        (
            dict(frequency_hz=3.4e5, temperature_c=10, salinity_psu=35.07, depth_m=10),
            "salinity_psu",
        ),
        (dict(frequency_hz=3.4e5, temperature_c=10, salinity_psu=35, depth_m=4000), "depth"),
    ],
)
def test_francois_garrison_rejects_outside_validity(kwargs, field):
    """Published validity limits (NPL summary of F–G 1982): outside them → ValueError naming the field."""
    with pytest.raises(ValueError, match=field):
        absorption_francois_garrison(**kwargs)


def test_francois_garrison_high_frequency_limits_are_wider():
    """Above 500 kHz the pure-water term dominates and F–G holds for 0–40 PSU, 0–30 °C."""
    a = absorption_francois_garrison(6.8e5, 25.0, 35.07, 92.0)
    assert a > 0


@pytest.mark.parametrize("kind", ["gaussian", "sinc"])
def test_beam_pattern_two_way_minus_3db_at_half_beamwidth(kind):
    """Definition of the −3 dB two-way beamwidth: b(±bw/2)² = ½, b(0) = 1."""
    bw = np.deg2rad(20.0)
    b = beam_pattern(np.array([0.0, bw / 2, -bw / 2]), bw, kind, -60.0)
    np.testing.assert_allclose(b**2, [1.0, 0.5, 0.5], rtol=2e-3)


def test_beam_pattern_floor_is_sidelobe_level():
    b = beam_pattern(np.array([np.pi / 2]), np.deg2rad(5.0), "gaussian", -20.0)
    assert b[0] == pytest.approx(0.01)


def test_log_compression_maps_floor_and_ceiling():
    """10·log10 mapping: floor → 0, floor + range → 1, clipped outside."""
    out = compress_log(np.array([1e10, 1e15, 1e20, 1e30]), 100.0, 100.0)
    np.testing.assert_allclose(out, [0.0, 0.5, 1.0, 1.0])


def test_config_errors_name_the_field():
    with pytest.raises(ValueError, match="speckle"):
        AcousticConfig(speckle="gamma")
    with pytest.raises(ValueError, match=r"water\.salinity_psu"):
        Water(salinity_psu=-1.0)
