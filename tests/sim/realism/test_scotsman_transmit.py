"""The shipped Scotsman preset's transmit pulse against the recording's first half
(pings 0–229, the calibration's fit half): the run of full-scale samples that opens every
ping, and the one-sample ring-down after it."""

from __future__ import annotations

import numpy as np
import pytest

from sim.sonar.preset_file import load_preset_file
from sim.sonar.receiver import digitise
from sim.sonar.transmit_pulse import leak_profile, pulse_lengths_from_recording

FIT = slice(0, 230)


def _shipped():
    return load_preset_file("scotsman_calibrated").config().acoustic.realism


def _leak_after_gain(rz, ranges: np.ndarray) -> np.ndarray:
    """The preset's leak through its receiver gain (ADC off), re the ADC's full scale."""
    leak = leak_profile(
        ranges,
        rz.transmit_level_db,
        rz.transmit_pulse_m,
        rz.transmit_ringdown_db,
        rz.transmit_ringdown_m,
    )
    return digitise(leak, rz.receiver_gain_db, 0, rz.full_scale_db) / 10.0 ** (
        rz.full_scale_db / 10.0
    )


def test_shipped_preset_has_one_pulse_switched_on():
    rz = _shipped()
    assert rz.transmit_level_db is not None and rz.transmit_pulse_alt_m is None
    assert rz.video_filter_m is None


def test_preset_pulse_clips_the_samples_the_recording_clips(shared_data):
    """Each side of the first half opens every ping with the same run of full-scale
    samples (no alternation); the preset's leak, on the recording's sample grid and through
    its gain, is at or over full scale on exactly those samples."""
    from slam.realism.recordings import load_recording
    from slam.realism.statistics import split_sides

    rec = load_recording(shared_data / "xtf" / "scotsman-iver2.xtf")
    first = rec.intensity[FIT]
    s = first.shape[1] // 2
    dr = rec.slant_range_m / s
    full = float(rec.intensity.max())
    runs = [pulse_lengths_from_recording(side, full, dr) for side in split_sides(first)]
    assert all(even == odd for even, odd in runs)
    n = round(runs[0][0] / dr)
    assert n > 0 and all(round(r[0] / dr) == n for r in runs)
    rz = _shipped()
    assert rz.transmit_pulse_m == pytest.approx(n * dr, abs=0.5 * dr)
    ranges = (np.arange(s) + 0.5) * dr
    rel = _leak_after_gain(rz, ranges)
    assert np.all(rel[:n] >= 1.0) and np.all(rel[n:] < 1.0)


def test_preset_ring_down_matches_the_recording(shared_data):
    """The first sample after the pulse: the recording's level over its own water column
    (median over pings of sample − median of samples 12–24), re full scale, against the
    preset's leak there through the preset's gain, within 2 dB; one sample later the leak
    is at least 8 dB lower."""
    from slam.realism.recordings import load_recording
    from slam.realism.statistics import split_sides

    rec = load_recording(shared_data / "xtf" / "scotsman-iver2.xtf")
    s = rec.intensity.shape[1] // 2
    dr = rec.slant_range_m / s
    full = float(rec.intensity.max())
    rz = _shipped()
    n = round(rz.transmit_pulse_m / dr)
    real = []
    for side in split_sides(rec.intensity[FIT]):
        wc = np.median(side[:, 12:25], axis=1)
        real.append(10.0 * np.log10(np.median(side[:, n] - wc) / full))
    ranges = (np.arange(n + 2) + 0.5) * dr
    model = 10.0 * np.log10(_leak_after_gain(rz, ranges))
    assert model[n] == pytest.approx(float(np.mean(real)), abs=2.0)
    assert model[n + 1] < model[n] - 8.0
