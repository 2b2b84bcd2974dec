"""The calibration survey: seeded runs repeat bit for bit, the receiver gain acts as a
gain (10 dB → ×10 in linear intensity below the clip), and the geometry is validated."""

from __future__ import annotations

import numpy as np
import pytest

from sim.realism.survey import RaycastSurvey, SurveySpec

SPEC = SurveySpec(altitude_m=5.0, max_range_m=20.0, samples_per_side=128, pings=32)


def test_same_overrides_same_bytes_and_gain_is_linear():
    survey = RaycastSurvey(SPEC)
    a = survey({"receiver_gain_db": -20.0})
    b = survey({"receiver_gain_db": -20.0})
    assert a.shape == (32, 256) and np.array_equal(a, b)
    c = survey({"receiver_gain_db": -10.0})
    fs = survey.full_scale({})
    ok = (a > 1e-6 * fs) & (c < 0.5 * fs)  # above the ADC's lowest steps, below the clip
    assert ok.mean() > 0.3
    assert np.median(c[ok] / a[ok]) == pytest.approx(10.0, rel=0.02)


@pytest.mark.parametrize(
    "kw, message",
    [
        (dict(altitude_m=30.0, max_range_m=20.0), "altitude_m"),
        (dict(altitude_m=5.0, max_range_m=20.0, pings=8), "pings"),
        (dict(altitude_m=5.0, max_range_m=20.0, samples_per_side=4), "samples_per_side"),
    ],
)
def test_bad_spec_is_named(kw, message):
    with pytest.raises(ValueError, match=message):
        SurveySpec(**{"samples_per_side": 128, **kw})


def test_unknown_preset_fails_early():
    with pytest.raises(ValueError, match="nope"):
        RaycastSurvey(SurveySpec(5.0, 20.0, 128, preset="nope"))


def test_legs_are_placed_segment_spacing_apart():
    """Two legs of 16 pings: the vehicle's x steps by speed / ping rate inside a leg and
    jumps to the next leg's start 30 m after the previous start; legs must divide pings."""
    two = RaycastSurvey(SurveySpec(5.0, 20.0, 128, pings=32, segments=2, segment_spacing_m=30.0))
    xs = []
    move = two.scene.move_vehicle
    two.scene.move_vehicle = lambda x, y=None, z=None: (xs.append(x), move(x, y, z))
    w = two({"receiver_gain_db": -20.0})
    assert w.shape == (32, 256) and np.all(np.isfinite(w))
    step = 1.5 / two.config({}).ping_rate_hz
    assert np.allclose(np.diff(xs[:16]), step) and np.allclose(np.diff(xs[16:]), step)
    assert xs[16] - xs[0] == pytest.approx(30.0)
    assert two.spec.extent_m == pytest.approx(30.0 + 16 * 1.5)
    with pytest.raises(ValueError, match="segments"):
        SurveySpec(5.0, 20.0, 128, pings=32, segments=3)


def test_solved_gain_is_the_simulators_gain_and_clips_the_target_fraction():
    """GainProfiledSurvey: its image equals the plain survey run with the solved gain (the
    sonar's own ADC; up to float32 rounding of the gain-free image); the gain is the dB
    mean of the two sides' own gains, so with one target the brighter side clips at least
    that fraction and the darker at most (a 32-ping leg's sides differ by ~8 dB here)."""
    from sim.realism.survey import GainProfiledSurvey

    survey = RaycastSurvey(SPEC)
    prof = GainProfiledSurvey(survey, (0.02, 0.02))
    img = prof({"texture_db": 2.0})
    gain = prof.gain_for({"texture_db": 2.0})
    ref = survey({"texture_db": 2.0, "receiver_gain_db": gain})
    fs = survey.full_scale({})
    assert np.mean(np.isclose(img, ref, rtol=1e-4, atol=1e-9 * fs)) > 0.999
    clipped = sorted(np.mean(side >= fs * (1 - 1e-9)) for side in (img[:, :128], img[:, 128:]))
    assert clipped[0] <= 0.02 + 1e-3 and clipped[1] >= 0.02 - 1e-3
    with pytest.raises(ValueError, match="clips"):
        GainProfiledSurvey(survey, (0.0, 0.01))


def test_display_mode_is_the_quantised_log_display_of_the_linear_output():
    """display_bits = 8: each sample is L² with L = round(255 · clip((10 log10 I − floor) /
    range, 0, 1)) of the linear survey's intensity I (same seed, same draws), the way a
    recreational unit stores its display and the readers square it back."""
    import dataclasses

    from sim.sonar.acoustics import compress_log

    spec = dataclasses.replace(SPEC, display_bits=8)
    ov = {"display_floor_db": 120.0, "dynamic_range_db": 60.0}
    disp = RaycastSurvey(spec)(ov)
    lin = RaycastSurvey(SPEC)(ov)
    ref = np.round(255.0 * compress_log(lin, 120.0, 60.0)) ** 2
    assert np.mean(disp == ref) > 0.999
    assert RaycastSurvey(spec).full_scale({}) == 255.0**2
    assert np.array_equal(np.sqrt(disp), np.round(np.sqrt(disp)))


def test_each_leg_flies_its_own_altitude():
    """Two legs at 4 m and 8 m: each leg's first bottom return (the detector of
    slam.realism.bottom, median over its pings) lies at its altitude over the bin width."""
    from slam.realism.bottom import first_bottom_return

    spec = SurveySpec(6.0, 20.0, 256, pings=32, segments=2, leg_altitudes_m=(4.0, 8.0))
    w = RaycastSurvey(spec)({"receiver_gain_db": -20.0})
    bin_m = 20.0 / 256
    port = w[:, :256][:, ::-1]  # near range first
    for leg, alt in enumerate((4.0, 8.0)):
        fr = first_bottom_return(port[16 * leg : 16 * leg + 16]).first_return
        assert np.nanmedian(fr) * bin_m == pytest.approx(alt, abs=4 * bin_m)
    assert [spec.leg_altitude(k) for k in (0, 1)] == [4.0, 8.0]


@pytest.mark.parametrize(
    "legs, message",
    [((4.0,), "one per leg"), ((4.0, 25.0), "leg_altitudes_m holds 25.0")],
)
def test_bad_leg_altitudes_are_named(legs, message):
    with pytest.raises(ValueError, match=message):
        SurveySpec(6.0, 20.0, 128, pings=32, segments=2, leg_altitudes_m=legs)


def test_tvg_exponent_starts_from_r4_or_the_preset_files_value(tmp_path):
    spec = SurveySpec(5.0, 20.0, 128, pings=32)
    assert RaycastSurvey(spec).start_value("tvg_exponent") == 4.0  # None = the r⁴ law
    f = tmp_path / "p.toml"
    f.write_text(
        '[sonar]\npreset = "deepeye680d_realistic"\n[sonar.overrides]\n'
        'tvg_exponent = 3.6\ntvg_reference = "bottom"\n'
    )
    survey = RaycastSurvey(SurveySpec(5.0, 20.0, 128, pings=32, preset=str(f)))
    assert survey.start_value("tvg_exponent") == 3.6
    assert survey.config({}).acoustic.realism.tvg_reference == "bottom"
