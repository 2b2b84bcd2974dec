"""The transmit pulse and ring-down in the first samples of each ping
(sim.sonar.transmit_pulse): closed-form profile, saturation length through the sonar's
own ADC, alternating pulses and their echo delay, off = unchanged, bad values."""

from __future__ import annotations

import numpy as np
import pytest

from sim.sonar import preset
from sim.sonar.effects import RealismConfig
from sim.sonar.transmit_pulse import (
    TransmitPulse,
    delay_samples,
    leak_profile,
    pulse_lengths_from_recording,
    video_filter,
)

DR = 40.0 / 1000  # bin width of the 40-m, 1000-sample sonar below, m


def _sss(scene, **over):
    return scene.sidescan(
        preset("deepeye680d_realistic", max_range=40.0, samples_per_side=1000, **over)
    )


def _port_near_first(ping) -> np.ndarray:
    s = ping.intensity.size // 2
    return ping.intensity[:s][::-1]


def test_ring_down_energy_is_the_closed_form_integral():
    """Drive level up to r_p; past it the ring-down's energy ∫ I dr = 10^((L+D)/10)·ℓ."""
    r = np.arange(0.0, 5.0, 1e-4) + 0.5e-4
    lvl, pulse, d, ell = 150.0, 0.2, -30.0, 0.07
    prof = leak_profile(r, lvl, pulse, d, ell)
    assert np.all(prof[r <= pulse] == 10.0 ** (lvl / 10.0))
    energy = np.sum(prof[r > pulse]) * 1e-4
    assert energy == pytest.approx(10.0 ** ((lvl + d) / 10.0) * ell, rel=2e-3)


def test_saturated_samples_span_the_pulse_through_the_sonars_adc(flat_scene):
    """Drive above the ADC's full scale, ring-down starting below it: exactly the samples
    whose centres lie inside c·τ/2 clip, in every ping (checked in the water column: the
    seabed is 10 m = 250 samples away)."""
    pulse = 0.2  # m: bin centres 0.02 … 0.18 → 5 samples
    son = _sss(
        flat_scene,
        transmit_level_db=200.0,
        transmit_pulse_m=pulse,
        transmit_ringdown_db=-80.0,
        transmit_ringdown_m=0.05,
    )
    rng = np.random.default_rng(3)
    for _ in range(3):
        near = _port_near_first(son.ping(flat_scene.data, rng))[:200]
        top = np.flatnonzero(near >= 0.999 * near.max())
        assert top.tolist() == list(range(int(pulse / DR + 0.5)))
        assert near[int(pulse / DR + 0.5)] < 0.5 * near.max()


def test_alternate_pings_alternate_the_pulse_and_shift_their_echoes():
    """Two pulse extents: the saturated run alternates 5, 2, 5, … samples, and the echo of
    the short-pulse pings moves nearer by the difference (3 samples), measured by the
    lag that maximises the correlation of consecutive pings (independent of the code)."""
    r = (np.arange(400) + 0.5) * 0.02
    rz = RealismConfig(
        transmit_level_db=300.0,
        transmit_pulse_m=0.1,
        transmit_pulse_alt_m=0.04,
        transmit_ringdown_db=-200.0,
        transmit_ringdown_m=0.01,
    )
    pulse = TransmitPulse(rz, r)
    rng = np.random.default_rng(0)
    echo = rng.exponential(size=(1, 400))  # one frozen seabed, the same in every ping
    pings = [pulse(echo.copy())[0] for _ in range(4)]
    runs = [int(np.argmax(p < 1e29)) for p in pings]
    assert runs == [5, 2, 5, 2]
    a, b = pings[0][50:350], pings[1]
    lags = list(range(-6, 7))
    corr = [np.corrcoef(a, b[50 + k : 350 + k])[0, 1] for k in lags]
    assert lags[int(np.argmax(corr))] == -3


def test_off_returns_the_input_unchanged_and_seeded_runs_stay_bit_identical(box_scene):
    """transmit_level_db None: the hook hands back the very array (no copy, no arithmetic);
    on: two runs with the same seed give the same bytes."""
    x = np.ones((2, 10))
    assert TransmitPulse(RealismConfig(), np.arange(10.0)).__call__(x) is x
    assert TransmitPulse(None, np.arange(10.0))(x) is x
    on = dict(transmit_level_db=190.0, transmit_pulse_alt_m=0.02)

    def run():
        son = _sss(box_scene, **on)
        rng = np.random.default_rng(11)
        return [son.ping(box_scene.data, rng).intensity.tobytes() for _ in range(3)]

    assert run() == run()


def test_video_filter_gives_white_input_the_exponential_range_correlation():
    """A one-pole filter of white noise has the autocorrelation a^k (AR(1)), a =
    exp(−Δr/ℓ_v); checked on the amplitude of 200 × 4000 white samples."""
    rng = np.random.default_rng(2)
    x = rng.normal(10.0, 1.0, size=(200, 4000))
    a = float(np.exp(-0.02 / 0.05))
    y = np.sqrt(video_filter(x * x, a))[:, 50:]
    d = y - y.mean()
    acf = [np.mean(d[:, k:] * d[:, : d.shape[1] - k]) / np.mean(d * d) for k in (1, 2, 3)]
    assert acf == pytest.approx([a, a * a, a**3], abs=0.01)
    assert float(y.mean()) == pytest.approx(10.0, abs=0.01)  # unit DC gain


def test_video_filter_switched_on_through_the_config():
    r = (np.arange(100) + 0.5) * 0.02
    x = np.ones((2, 100))
    x[:, 50] = 4.0
    out = TransmitPulse(RealismConfig(video_filter_m=0.05), r)(x)
    assert out is not x and np.argmax(out[0]) == 50 and out[0, 51] > 1.0  # causal tail
    assert np.allclose(out[:, :50], 1.0)


def test_delay_repeats_the_edge_sample():
    x = np.arange(6.0)[None, :]
    assert delay_samples(x, 2).tolist() == [[0, 0, 0, 1, 2, 3]]
    assert delay_samples(x, -2).tolist() == [[2, 3, 4, 5, 5, 5]]


def test_pulse_lengths_from_a_recording_with_known_runs():
    side = np.full((6, 50), 10.0)
    side[0::2, :5] = 255.0
    side[1::2, :2] = 255.0
    side[:, 30] = 255.0  # a saturated echo later in the ping is not the pulse
    assert pulse_lengths_from_recording(side, 255.0, 0.02) == pytest.approx((0.1, 0.04))
    with pytest.raises(ValueError, match="sample_m"):
        pulse_lengths_from_recording(side, 255.0, 0.0)


def test_humminbird_recording_pulse_lengths(shared_data):
    """Port of the Humminbird recording (first half, 8-bit levels L stored as L²): the
    unit alternates a 5- and a 2-sample pulse (0.094 / 0.038 m at 1.88 cm per sample)."""
    from sim.cli.realism_io import load_humminbird

    rec = load_humminbird(shared_data / "humminbird" / "test.DAT")
    s = rec.intensity.shape[1] // 2
    first = rec.intensity[: rec.n_pings // 2]
    dr = rec.slant_range_m / s
    port = first[:, :s][:, ::-1]
    even, odd = pulse_lengths_from_recording(port, 255.0**2, dr)
    assert (even / dr, odd / dr) == (5.0, 2.0)


@pytest.mark.parametrize(
    "field, value",
    [
        ("transmit_level_db", float("nan")),
        ("transmit_pulse_m", -0.1),
        ("transmit_pulse_alt_m", 20.0),
        ("transmit_ringdown_db", 3.0),
        ("transmit_ringdown_m", 0.0),
        ("video_filter_m", -1.0),
    ],
)
def test_bad_values_name_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        RealismConfig(**{field: value})
    with pytest.raises(ValueError, match=field):
        preset("deepeye680d_realistic", **{field: value})
