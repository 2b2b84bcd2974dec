"""The water column and the receiver: volume reverberation, sea-surface return, first
surface multipath, ambient and electronic noise, receiver gain, ADC bit depth and clipping.

Levels in dB re 1 µPa² (intensities), ranges in m, angles in rad. Formulas:

* Volume reverberation (Urick 1983, *Principles of Underwater Sound*, eq. 8.5): a range
  cell of depth Δr holds V = r² Ψ Δr, Ψ the equivalent two-way beam solid angle (≈ the
  product of the two −3 dB widths), so I_v = SL · s_v · Ψ Δr · r⁻² · 10^(−2αr/10).
* Sea-surface backscatter: Chapman & Harris (1962, JASA 34(10) 1592),
  S_s = 3.3 β log10(θ/30°) − 42.4 log10 β + 2.6, β = 158 (v f^{1/3})^(−0.58), v wind in
  knots, f in Hz, θ grazing in degrees. Fitted below 6 kHz: at side-scan frequencies it is
  an extrapolation (a level to calibrate), clipped to [−70, −20] dB.
* Ambient noise: Knudsen wind noise NL = 44 + 23 log10(SS + 1) − 17 log10(f/kHz) dB/Hz
  (Urick 1983, fig. 7.5 fit) plus Mellen (1952) thermal noise −15 + 20 log10(f/kHz) dB/Hz;
  over the bandwidth B = c/(2δr), minus the receive directivity index DI = 10 log10(4π/Ψ).
* First surface multipath: the seabed echo at ground range g, altitude h, transducer
  depth d also returns via one surface bounce; the path down–surface (mirror source at
  height h + 2d) is l₂ = √(g² + (h + 2d)²), so it arrives at slant range (l₁ + l₂)/2 with
  the extra spreading (l₁/l₂)² and the surface loss.
* Recorder gain (``tvg_reference = "bottom"``): the TVG r^n·10^(2αr/10) held at its
  value at the first bottom return (slant range = altitude over a flat seabed) for the
  water column, :func:`sim.sonar.acoustics.bottom_held_tvg`.
"""

from __future__ import annotations

import numpy as np

from sim.sonar.acoustics import beam_pattern, bottom_held_tvg, tvg_gain


def volume_reverberation(r, sl_db, sv_db, psi, bin_width, alpha_db_m):
    """Mean volume reverberation intensity (µPa²) per range bin at ranges r (m)."""
    r = np.maximum(np.asarray(r, float), 0.1)
    lvl = 10.0 ** ((sl_db + sv_db) / 10.0) * psi * bin_width
    return lvl / (r * r) * 10.0 ** (-0.2 * alpha_db_m * r)


def chapman_harris_db(grazing, wind_mps, frequency_hz):
    """Sea-surface backscattering strength (dB) at grazing angle(s) (rad); see module."""
    v_kn = wind_mps / 0.514444
    beta = 158.0 * (v_kn * frequency_hz ** (1.0 / 3.0)) ** -0.58
    th = np.clip(np.rad2deg(grazing), 0.1, 90.0)
    s = 3.3 * beta * np.log10(th / 30.0) - 42.4 * np.log10(beta) + 2.6
    return np.clip(s, -70.0, -20.0)


def ambient_noise_db(frequency_hz, sea_state, bandwidth_hz, psi):
    """Ambient noise level in the receiver band after the directivity index, dB re µPa²."""
    fk = frequency_hz / 1e3
    wind = 44.0 + 23.0 * np.log10(sea_state + 1.0) - 17.0 * np.log10(fk)
    thermal = -15.0 + 20.0 * np.log10(fk)
    dens = 10.0 * np.log10(10.0 ** (wind / 10.0) + 10.0 ** (thermal / 10.0))
    di = 10.0 * np.log10(4.0 * np.pi / psi)
    return float(dens + 10.0 * np.log10(bandwidth_hz) - di)


def surface_return(r, depth, sl_db, wind_mps, freq, beam_along, bin_width, alpha_db_m, beam):
    """Mean sea-surface reverberation (µPa²) per bin at ranges r for a transducer at
    ``depth`` m below the surface; ``beam(elevation)`` two-way beam gain at an elevation
    above horizontal (rad). Zero where r < depth."""
    r = np.asarray(r, float)
    out = np.zeros_like(r)
    ok = r > max(depth, 0.05)
    if not ok.any():
        return out
    rr = r[ok]
    graz = np.arcsin(np.clip(depth / rr, 0.0, 1.0))
    sig = 10.0 ** (chapman_harris_db(graz, wind_mps, freq) / 10.0)
    area = rr * beam_along * bin_width / np.maximum(np.cos(graz), 0.05)
    sl = 10.0 ** (sl_db / 10.0)
    out[ok] = sl * beam(graz) * sig * area / rr**4 * 10.0 ** (-0.2 * alpha_db_m * rr)
    return out


def surface_multipath(mean, r, altitude, depth, loss_db, alpha_db_m, beam_ratio):
    """Intensity (rows, bins) of the first surface-bounce copy of the seabed echo ``mean``
    (rows, bins) at ranges r (bins,) for a flat seabed at ``altitude`` and a transducer at
    ``depth``; ``beam_ratio(g)``: one-way beam gain towards the surface image over the
    direct one for ground range g. Energy of each bin moves to its multipath range."""
    out = np.zeros_like(mean)
    if not (np.isfinite(altitude) and altitude > 0 and depth > 0):
        return out
    g2 = r * r - altitude * altitude
    ok = np.flatnonzero(g2 > 0)
    if ok.size == 0:
        return out
    l1 = r[ok]
    l2 = np.sqrt(g2[ok] + (altitude + 2.0 * depth) ** 2)
    rm = 0.5 * (l1 + l2)
    dr = r[1] - r[0]
    idx = np.floor((rm - (r[0] - 0.5 * dr)) / dr).astype(np.int64)
    inside = (idx >= 0) & (idx < r.size)
    fac = (l1 / l2) ** 2 * 10.0 ** (-(loss_db + alpha_db_m * (l2 - l1)) / 10.0)
    fac = fac * beam_ratio(np.sqrt(g2[ok]))
    for row in range(mean.shape[0]):  # two sides (rows), not per sample
        e = mean[row, ok] * fac
        out[row] = np.bincount(idx[inside], e[inside], minlength=r.size)
    return out


def two_way_beam(vbw, depression, kind, sidelobe_db):
    """beam(elevation) → two-way vertical beam gain of a side-scan transducer whose axis is
    ``depression`` rad below horizontal (elevation positive up)."""

    def beam(elev):
        return beam_pattern(np.asarray(elev) + depression, vbw, kind, sidelobe_db) ** 2

    return beam


def digitise(intensity, gain_db, bit_depth, full_scale_db):
    """Receiver gain, then an amplitude ADC of ``bit_depth`` bits whose full scale is
    ``full_scale_db`` dB re µPa²: amplitude counts floor(√(I/I_fs)·(2ᵇ − 1)) clipped to
    2ᵇ − 1, returned as intensity (µPa²) again. bit_depth 0: gain only."""
    x = intensity * 10.0 ** (gain_db / 10.0)
    if bit_depth <= 0:
        return x
    fs = 10.0 ** (full_scale_db / 10.0)
    top = float(2**bit_depth - 1)
    counts = np.minimum(np.floor(np.sqrt(x / fs) * top), top)
    return (counts / top) ** 2 * fs


def ping_tvg(tvg, altitude, rz, alpha_db_m, mode):
    """The TVG curve (S,) of one ping: ``tvg`` (the transducer-referenced curve, returned
    as is when ``rz.tvg_reference`` is "transducer" or the altitude is unknown) or, with
    "bottom", that curve held at its value at slant range ``altitude`` (m)."""
    if rz.tvg_reference != "bottom" or not (np.isfinite(altitude) and altitude > 0):
        return tvg
    at_bottom = float(tvg_gain(np.array([float(altitude)]), alpha_db_m, mode, rz.tvg_n)[0])
    return bottom_held_tvg(tvg, at_bottom)
