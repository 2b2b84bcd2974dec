"""The transmit pulse in the receiver: the transducer's own transmission and its ring-down
leaking into the first samples of every ping; and the receiver's post-detection (video)
low-pass filter.

A side-scan transmits and receives on the same transducer (mono-static). While it
transmits, the receiver sees the drive itself, many orders above any echo, and after the
drive stops the transducer keeps ringing and the saturated receiver recovers, so the
first samples of every ping are at (or near) full scale, decaying over the pulse length
plus the ring-down. This is why sonars blank (or show as a bright band) the first
c·τ/2 of range; the ring-down of a mono-static transducer is the limit on its minimum
range (Texas Instruments, *PGA460 Ultrasonic Module Hardware and Software Optimization*,
SLAA732A, 2017/2021, §4.4 "Passive Tuning": "ringing-decay time of mono-static
configurations"; the direct blast of active sonar: L. R. Riddle, *Introduction to Active
Sonar*, OpenStax CNX m14548). The Humminbird recording in ``../shared/data/humminbird``
shows it in every ping: samples 0–1 at 255 in every ping, 0–4 (port) / 0–5 (starboard)
in every other ping (the unit alternates two pulse lengths), then a decay of about 20 dB
over the next 15 samples (docs/realism.md).

Model, per ping and side, added to the echo intensity after the TVG and before the
receiver gain and the ADC (so the ADC or the display clips it like the real receiver),
with r the slant range of a sample's centre (m), r_p the pulse's range extent c·τ/2 (m)
and ℓ the ring-down length (m)::

    I_tx(r) = 10^(L/10)                             for r ≤ r_p   (the drive)
    I_tx(r) = 10^((L + D)/10) · exp(−(r − r_p)/ℓ)   for r > r_p   (the ring-down)

L = ``transmit_level_db`` (dB re 1 µPa², the scale of the echo after TVG: e.g. 40 dB
over the ADC's full scale saturates it); D = ``transmit_ringdown_db`` (≤ 0): when the drive
stops, what is left is the transducer's free ringing, D below the drive. Units that alternate two pulse lengths use
``transmit_pulse_alt_m`` on every other ping (the first ping uses ``transmit_pulse_m``),
and the echoes of those pings are recorded later by the difference of the two pulse
extents (rounded to whole samples): a receiver that integrates the echo over its pulse
(the causal matched filter of a rectangular pulse peaks at the pulse's end) delays each
echo by its own pulse length. The Humminbird recording shows exactly that: consecutive
pings correlate best (0.5) at a range offset of 3 samples, alternating in sign, the
difference of its 5- and 2-sample pulses; at zero offset they correlate 0.13–0.2.
The ring-down is an exponential in intensity: a resonator of quality factor Q decays as
exp(−2πf t/Q) in energy, ℓ = c·Q/(4πf) in range; the receiver's recovery from saturation
lengthens it in practice, hence a fitted ℓ rather than one derived from Q.

Video filter: analogue side-scan receivers smooth the detected envelope with a low-pass
(an RC stage) before the ADC or the display; a single pole of time constant T gives, per
sample of spacing Δr, y_k = a·y_{k−1} + (1 − a)·x_k on the amplitude x = √I with
a = exp(−Δr/ℓ_v), ℓ_v = c·T/2 = ``video_filter_m`` (None = off), so white input comes
out with the exponential autocorrelation a^|k| along range. The Humminbird recording's
range autocorrelation of amplitude falls like that (0.62, 0.35, 0.23, 0.15 at lags 1–4 on
the port side of the first half; the ray-cast speckle's Gaussian range cell alone gives
0.54, 0.10, −0.01), which is also what made its LBP texture differ (docs/realism.md).

:func:`pulse_lengths_from_recording` derives r_p from a recording: the run of full-scale
samples at the start of each ping times the recording's sample spacing.

Fields (mixed into :class:`sim.sonar.effects.RealismConfig`, so presets and scenario
files set them like any realism field); ``transmit_level_db = None`` (the default) turns
the model off and leaves every output bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from sim.sonar.validate import check_optional_range, check_range


@dataclass(frozen=True)
class TransmitPulseFields:
    """Transmit-pulse fields of a sonar's realism config (see the module).

    transmit_level_db: level of the leaked transmission, dB re 1 µPa² after TVG (None =
    off); transmit_pulse_m: its range extent c·τ/2, m; transmit_pulse_alt_m: the extent
    on every other ping for units that alternate two pulses (None = one pulse);
    transmit_ringdown_db: level of the ring-down's start re the drive, dB (<= 0);
    transmit_ringdown_m: e-folding range of the ring-down intensity, m;
    video_filter_m: range constant ℓ_v = c·T/2 of the receiver's one-pole video filter,
    m (None = off)."""

    transmit_level_db: float | None = None
    transmit_pulse_m: float = 0.05
    transmit_pulse_alt_m: float | None = None
    transmit_ringdown_db: float = 0.0
    transmit_ringdown_m: float = 0.05
    video_filter_m: float | None = None

    def __post_init__(self) -> None:
        check_optional_range("transmit_level_db", self.transmit_level_db, 0.0, 400.0)
        check_range("transmit_pulse_m", self.transmit_pulse_m, 0.0, 10.0)
        check_optional_range("transmit_pulse_alt_m", self.transmit_pulse_alt_m, 0.0, 10.0)
        check_range("transmit_ringdown_db", self.transmit_ringdown_db, -200.0, 0.0)
        check_range("transmit_ringdown_m", self.transmit_ringdown_m, 1e-4, 10.0)
        check_optional_range("video_filter_m", self.video_filter_m, 1e-4, 10.0)


def leak_profile(ranges, level_db: float, pulse_m: float, ringdown_db: float, ringdown_m: float):
    """I_tx (S,) at slant ranges ``ranges`` (m), µPa² (formula in the module)."""
    r = np.asarray(ranges, dtype=np.float64)
    ring = 10.0 ** ((level_db + ringdown_db) / 10.0) * np.exp(-(r - pulse_m) / ringdown_m)
    return np.where(r <= pulse_m, 10.0 ** (level_db / 10.0), ring)


class TransmitPulse:
    """``pulse(samples) -> samples``: one ping's samples (rows, S) after TVG through the
    video filter, then delayed (alternate pulses) and with the transmit leak added (the
    leak profile is the one seen at the receiver's output, as fitted to a recording, so it
    is not filtered again); holds the ping count for alternating
    pulses. Both off (``transmit_level_db`` and ``video_filter_m`` None): returns its input
    unchanged (the same array)."""

    def __init__(self, rz, ranges: np.ndarray):
        self.profiles: tuple[np.ndarray, ...] = ()
        self.delays: tuple[int, ...] = (0,)
        self.count = 0
        self.pole: float | None = None
        if rz is None:
            return
        r = np.asarray(ranges, dtype=np.float64)
        step = float(r[1] - r[0]) if r.size > 1 else 1.0
        if rz.video_filter_m is not None:
            self.pole = float(np.exp(-step / rz.video_filter_m))
        if rz.transmit_level_db is None:
            return
        pulses = (rz.transmit_pulse_m,)
        if rz.transmit_pulse_alt_m is not None:
            pulses += (rz.transmit_pulse_alt_m,)
            self.delays = (0, round((rz.transmit_pulse_alt_m - rz.transmit_pulse_m) / step))
        self.profiles = tuple(
            leak_profile(
                r, rz.transmit_level_db, p, rz.transmit_ringdown_db, rz.transmit_ringdown_m
            )
            for p in pulses
        )

    def __call__(self, samples: np.ndarray) -> np.ndarray:
        out = samples
        if self.pole is not None:
            out = video_filter(out, self.pole)
        if self.profiles:
            k = self.count % len(self.profiles)
            self.count += 1
            out = delay_samples(out, self.delays[k]) + self.profiles[k][None, :]
        return out


def video_filter(samples: np.ndarray, pole: float) -> np.ndarray:
    """One-pole low-pass along range (last axis) of the amplitude √I, returned as intensity:
    y_k = a·y_{k−1} + (1 − a)·x_k, started at y_0 = x_0 (a = ``pole``)."""
    x = np.sqrt(np.maximum(samples, 0.0))
    y = lfilter([1.0 - pole], [1.0, -pole], x, axis=-1, zi=pole * x[..., :1])[0]
    return y * y


def delay_samples(samples: np.ndarray, n: int) -> np.ndarray:
    """(rows, S) samples delayed by ``n`` samples along range (n < 0: advanced); the
    samples shifted in repeat the edge sample (the leak covers the near end)."""
    if n == 0:
        return samples
    idx = np.clip(np.arange(samples.shape[-1]) - n, 0, samples.shape[-1] - 1)
    return samples[..., idx]


def pulse_lengths_from_recording(side: np.ndarray, full_scale: float, sample_m: float):
    """(pulse m of even pings, pulse m of odd pings) of one side (P, S) of a recording,
    near range first: the median run of samples at ``full_scale`` (or above) from sample
    0 of each ping, times the sample spacing ``sample_m`` (m)."""
    a = np.asarray(side)
    if a.ndim != 2 or a.shape[0] < 2:
        raise ValueError(f"side has shape {a.shape}; need (pings >= 2, samples)")
    if not sample_m > 0:
        raise ValueError(f"sample_m = {sample_m}; must be > 0")
    clipped = a >= full_scale
    run = np.where(clipped.all(axis=1), a.shape[1], np.argmin(clipped, axis=1))
    return tuple(float(np.median(run[k::2])) * sample_m for k in (0, 1))
