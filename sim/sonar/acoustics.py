"""Acoustic model: seawater absorption, spreading, backscatter, beam patterns, speckle,
noise, time-varying gain and display compression.

Hand-written because no installed library provides them: the formulas are the published
ones cited on each function. Levels in dB re 1 µPa; intensities linear in µPa².
"""

from __future__ import annotations

import numpy as np

from sim.sonar.config import AcousticConfig, WaterLike


def _depth_limits(
    frequency_hz: float,
) -> tuple[tuple[float, float], tuple[float, float], tuple[float, float]]:
    # Francois & Garrison (1982) reliability limits as summarised by NPL ("Calculation of
    # absorption of sound in seawater"): 10–500 kHz (MgSO4 dominated): −2 < T < 22 °C,
    # 30 < S < 35 ppt, 0 < D < 3.5 km; above 500 kHz (pure water dominated): 0 < T < 30 °C,
    # 0 < S < 40 ppt, 0 < D < 10 km.
    if frequency_hz > 500e3:
        return (0.0, 30.0), (0.0, 40.0), (0.0, 10000.0)
    return (-2.0, 22.0), (30.0, 35.0), (0.0, 3500.0)


def _check(name: str, value: float, lo: float, hi: float, model: str, extra: str = "") -> None:
    v = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(v)) or np.any(v < lo) or np.any(v > hi):
        raise ValueError(
            f"{name} = {value!r} is outside the {model} absorption model's validity range "
            f"[{lo}, {hi}]{extra}"
        )


def absorption_francois_garrison(
    frequency_hz: float | np.ndarray,
    temperature_c: float,
    salinity_psu: float,
    depth_m: float,
    ph: float = 8.0,
    sound_speed: float | None = None,
) -> np.ndarray:
    """Seawater absorption α in dB/m, Francois & Garrison (1982), JASA 72(3) 896 and 72(6) 1879.

    Sum of boric acid, magnesium sulphate and pure-water relaxations. Valid 100 Hz – 1 MHz;
    temperature/salinity/depth limits depend on frequency (see ``_depth_limits``); outside
    them a ``ValueError`` names the field and the allowed range. ``sound_speed`` defaults to
    the paper's c = 1412 + 3.21 T + 1.19 S + 0.0167 D.
    """
    f_hz = np.asarray(frequency_hz, dtype=float)
    _check("frequency_hz", frequency_hz, 100.0, 1.0e6, "Francois–Garrison")
    fmax = float(np.max(f_hz))
    (tlo, thi), (slo, shi), (dlo, dhi) = _depth_limits(fmax)
    extra = f" at {fmax / 1e3:g} kHz (use absorption_model='ainslie_mccolm' for a wider range)"
    _check("temperature_c", temperature_c, tlo, thi, "Francois–Garrison", extra)
    _check("salinity_psu", salinity_psu, slo, shi, "Francois–Garrison", extra)
    _check("depth", depth_m, dlo, dhi, "Francois–Garrison", extra)
    _check("ph", ph, 7.0, 9.0, "Francois–Garrison")
    T, S, D = float(temperature_c), float(salinity_psu), float(depth_m)
    f = f_hz / 1e3  # kHz
    c = 1412.0 + 3.21 * T + 1.19 * S + 0.0167 * D if sound_speed is None else float(sound_speed)
    theta = 273.0 + T
    # boric acid
    a1 = 8.86 / c * 10.0 ** (0.78 * ph - 5.0)
    f1 = 2.8 * np.sqrt(S / 35.0) * 10.0 ** (4.0 - 1245.0 / theta)
    # magnesium sulphate
    a2 = 21.44 * S / c * (1.0 + 0.025 * T)
    p2 = 1.0 - 1.37e-4 * D + 6.2e-9 * D * D
    f2 = 8.17 * 10.0 ** (8.0 - 1990.0 / theta) / (1.0 + 0.0018 * (S - 35.0))
    # pure water
    p3 = 1.0 - 3.83e-5 * D + 4.9e-10 * D * D
    if T <= 20.0:
        a3 = 4.937e-4 - 2.59e-5 * T + 9.11e-7 * T**2 - 1.50e-8 * T**3
    else:
        a3 = 3.964e-4 - 1.146e-5 * T + 1.45e-7 * T**2 - 6.5e-10 * T**3
    f2sq = f * f
    alpha_db_km = (
        a1 * f1 * f2sq / (f1 * f1 + f2sq) + a2 * p2 * f2 * f2sq / (f2 * f2 + f2sq) + a3 * p3 * f2sq
    )
    return alpha_db_km / 1000.0


def absorption_ainslie_mccolm(
    frequency_hz: float | np.ndarray,
    temperature_c: float,
    salinity_psu: float,
    depth_m: float,
    ph: float = 8.0,
) -> np.ndarray:
    """Seawater absorption α in dB/m, Ainslie & McColm (1998), JASA 103(3) 1671.

    Simplified Francois–Garrison, within 10 % of it for 100 Hz – 1 MHz, −6 < T < 35 °C,
    5 < S < 50 PSU, 7.7 < pH < 8.3, 0 < D < 7 km.
    """
    _check("frequency_hz", frequency_hz, 100.0, 1.0e6, "Ainslie–McColm")
    _check("temperature_c", temperature_c, -6.0, 35.0, "Ainslie–McColm")
    _check("salinity_psu", salinity_psu, 5.0, 50.0, "Ainslie–McColm")
    _check("depth", depth_m, 0.0, 7000.0, "Ainslie–McColm")
    _check("ph", ph, 7.7, 8.3, "Ainslie–McColm")
    f = np.asarray(frequency_hz, dtype=float) / 1e3
    T, S, z = float(temperature_c), float(salinity_psu), float(depth_m) / 1000.0
    f1 = 0.78 * np.sqrt(S / 35.0) * np.exp(T / 26.0)
    f2 = 42.0 * np.exp(T / 17.0)
    ff = f * f
    a = (
        0.106 * f1 * ff / (f1 * f1 + ff) * np.exp((ph - 8.0) / 0.56)
        + 0.52 * (1.0 + T / 43.0) * (S / 35.0) * f2 * ff / (f2 * f2 + ff) * np.exp(-z / 6.0)
        + 0.00049 * ff * np.exp(-(T / 27.0 + z / 17.0))
    )
    return a / 1000.0


def absorption_db_per_m(
    frequency_hz: float, water: WaterLike, depth_m: float, model: str = "francois_garrison"
) -> float:
    """α (dB/m) for ``water`` (duck-typed, see :class:`sim.sonar.config.WaterLike`) at a depth."""
    ph = float(getattr(water, "ph", 8.0))
    if model == "francois_garrison":
        return float(
            absorption_francois_garrison(
                frequency_hz,
                water.temperature_c,
                water.salinity_psu,
                depth_m,
                ph,
                water.sound_speed,
            )
        )
    if model == "ainslie_mccolm":
        return float(
            absorption_ainslie_mccolm(
                frequency_hz, water.temperature_c, water.salinity_psu, depth_m, ph
            )
        )
    raise ValueError(
        f"absorption_model = {model!r}; allowed: 'francois_garrison', 'ainslie_mccolm'"
    )


def two_way_loss_linear(r: np.ndarray, alpha_db_m: float) -> np.ndarray:
    """Two-way transmission factor 10^(−2·TL/10) with TL = 20·log10 r + α r (spherical
    spreading + absorption): r⁻⁴ · 10^(−2 α r / 10). r in m (≥ 1e-3 enforced)."""
    r = np.maximum(r, 1e-3)
    return r**-4 * 10.0 ** (-0.2 * alpha_db_m * r)


def lambert_backscatter(cos_incidence: np.ndarray, mu_linear: np.ndarray | float) -> np.ndarray:
    """Lambert's law: backscattering cross-section per unit area σ = μ cos²(θ_inc)
    (θ_inc from the surface normal), linear."""
    c = np.clip(cos_incidence, 0.0, 1.0)
    return mu_linear * c * c


def beam_pattern(angle: np.ndarray, beamwidth: float, kind: str, sidelobe_db: float) -> np.ndarray:
    """One-way intensity beam pattern b(angle) ∈ (0, 1], −3 dB two-way at ±beamwidth/2.

    angle and beamwidth in rad (angle off the beam axis). "gaussian": exp(−a²/(2σ²)) with
    b(bw/2)² = ½; "sinc": sinc²(k·a) of a uniform line array, k set for the −3 dB two-way
    width; "rect": 1 inside ±bw/2, floor outside. All floored at ``sidelobe_db``.
    """
    a = np.asarray(angle, dtype=float)
    half = 0.5 * beamwidth
    floor = 10.0 ** (sidelobe_db / 10.0)
    if kind == "gaussian":
        # two-way b² = exp(-a²/σ²) = 1/2 at a = half → σ² = half² / ln 2
        b = np.exp(-0.5 * np.log(2.0) * (a / half) ** 2)
    elif kind == "sinc":
        # two-way sinc⁴(x) = 1/2 at x = 0.318917 (np.sinc(x) = sin(πx)/(πx))
        b = np.sinc(0.318917 * a / half) ** 2
    elif kind == "rect":
        b = (np.abs(a) <= half).astype(float)
    else:
        raise ValueError(f"beam_pattern = {kind!r}; allowed: 'gaussian', 'sinc', 'rect'")
    return np.maximum(b, floor)


def apply_speckle_noise(
    mean_intensity: np.ndarray, cfg: AcousticConfig, rng: np.random.Generator
) -> np.ndarray:
    """Received intensity per sample: coherent sum of speckled echo and receiver noise.

    With circular complex Gaussian echo and noise the intensity is exponential with mean
    S·g + N (amplitude Rayleigh); ``speckle="k"`` multiplies S by a unit-mean gamma texture
    g ~ Γ(ν, 1/ν) (K-distributed amplitude); "none" returns S + N (no draws).
    """
    noise = 10.0 ** (cfg.noise_level_db / 10.0)
    if cfg.speckle == "none":
        return mean_intensity + noise
    s = mean_intensity
    if cfg.speckle == "k":
        s = s * rng.gamma(cfg.k_shape, 1.0 / cfg.k_shape, size=s.shape)
        s += noise
    else:
        s = s + noise
    s *= rng.standard_exponential(size=s.shape)
    return s


def tvg_gain(r: np.ndarray, alpha_db_m: float, mode: str, exponent: float = 4.0) -> np.ndarray:
    """Time-varying gain compensating two-way spreading (r⁴, "40 log R") and optionally
    absorption. ``exponent`` n: r^n instead (n = 3: the "30 log R" of side-scan receivers,
    which also compensates the footprint growing as r; Blondel 2009, *The Handbook of
    Sidescan Sonar*, §4.3)."""
    r = np.maximum(r, 1.0)
    if mode == "none":
        return np.ones_like(r)
    g = r**4 if exponent == 4.0 else r**exponent
    if mode == "spreading_absorption":
        g = g * 10.0 ** (0.2 * alpha_db_m * r)
    return g


def bottom_held_tvg(tvg: np.ndarray, tvg_at_bottom: float) -> np.ndarray:
    """A TVG curve referenced to the first bottom return: the transducer-referenced curve
    ``tvg`` (non-decreasing in range) held at its value at the bottom return,
    ``tvg_at_bottom`` = tvg(r_b), for every range short of it. G(r) = tvg(max(r, r_b)):
    the water column gets the gain the recorder gives the bottom return (flat in range,
    following the altitude as r_b^n), the seabed the ordinary law. Side-scan recorders
    start their TVG ramp at the bottom track so that the water column is not amplified
    (docs/realism.md, "Recorder gain")."""
    return np.maximum(tvg, tvg_at_bottom)


def compress_log(intensity: np.ndarray, floor_db: float, dynamic_range_db: float) -> np.ndarray:
    """Display compression: 10·log10(I) mapped from [floor, floor + range] dB to [0, 1]."""
    db = np.maximum(intensity, 1e-30)
    np.log10(db, out=db)
    db *= 10.0
    db -= floor_db
    db /= dynamic_range_db
    return np.clip(db, 0.0, 1.0, out=db)


def finish_samples(
    mean_intensity: np.ndarray,
    r: np.ndarray,
    alpha_db_m: float,
    cfg: AcousticConfig,
    rng: np.random.Generator,
    tvg: np.ndarray | None = None,
) -> np.ndarray:
    """Speckle + noise, TVG, then optional log compression; returns float32 samples.

    ``tvg``: optional precomputed ``tvg_gain(r, alpha_db_m, cfg.tvg)`` (any shape that
    broadcasts against ``mean_intensity``; a sonar computes it once, not every ping);
    ``r`` is then not read.

    The default display floor is SL + 10·log10 μ − 60 dB (a seabed with reflectivity 1 after
    full TVG sits ~25 dB above it, mid-grey; the receiver noise in the water column below it) unless
    ``cfg.display_floor_db`` sets it.
    """
    inten = apply_speckle_noise(mean_intensity, cfg, rng)
    if cfg.tvg != "none":
        inten *= tvg_gain(r, alpha_db_m, cfg.tvg) if tvg is None else tvg
    if cfg.log_compression:
        floor = cfg.display_floor_db
        if floor is None:
            floor = cfg.source_level_db + cfg.lambert_mu_db - 60.0
        inten = compress_log(inten, floor, cfg.dynamic_range_db)
    return inten.astype(np.float32)
