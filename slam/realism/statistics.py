"""Realism statistics of one side-scan waterfall (definitions in docs/realism.md).

Input: a waterfall ``(pings, 2·S)`` of *linear intensity after TVG* (port on the left, far
range at column 0; starboard on the right), amplitude = √intensity. Each side is analysed
near range first. All statistics are ratios or correlations, so they do not depend on the
units or the overall gain of the recording.

Seabed patches: non-overlapping 16 × 16 (pings × samples) tiles on a grid anchored at ping
0 / sample 0 of the side, kept when every sample is seabed (≥ ``guard`` samples past the
first bottom return), positive and below the clip level, and the four 8 × 8 quadrant mean
intensities lie within ``homogeneity_db`` of each other. Per-patch values are combined by
the median over patches.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import uniform_filter1d

from slam.realism.bottom import BottomTrack, first_bottom_return
from slam.realism.textures import intensity_histogram, lbp_histogram


@dataclass(frozen=True)
class RealismConfig:
    """How the statistics are taken.

    patch            : patch side, pings = samples (16).
    guard            : samples skipped after the first bottom return (seabed starts there)
                       and before it (water column ends there).
    homogeneity_db   : max spread of the four quadrant mean intensities of a patch, dB.
    dr_percentiles   : (low, high) percentiles of intensity for the dynamic range.
    floor_db         : intensities are floored at this level re the seabed-profile peak
                       before any dB (exact zeros of a simulator stay finite), dB.
    min_patches      : fewer seabed patches than this on a side is an error ("no seabed").
    min_bottom_fraction : fewer pings with a bottom than this fraction is an error.
    full_scale       : clip level of the recording; None = the waterfall's maximum.
    """

    patch: int = 16
    guard: int = 8
    homogeneity_db: float = 3.0
    dr_percentiles: tuple[float, float] = (1.0, 99.0)
    floor_db: float = -120.0
    min_patches: int = 8
    min_bottom_fraction: float = 0.5
    full_scale: float | None = None

    def __post_init__(self) -> None:
        if self.patch < 4 or self.patch % 2:
            raise ValueError(f"RealismConfig.patch must be even and >= 4, got {self.patch}")
        if self.guard < 0:
            raise ValueError(f"RealismConfig.guard must be >= 0, got {self.guard}")
        lo, hi = self.dr_percentiles
        if not 0.0 <= lo < hi <= 100.0:
            raise ValueError(
                f"RealismConfig.dr_percentiles must be 0 <= lo < hi <= 100, got {lo, hi}"
            )
        if self.homogeneity_db <= 0:
            raise ValueError(f"RealismConfig.homogeneity_db must be > 0, got {self.homogeneity_db}")


@dataclass(frozen=True)
class SideStatistics:
    """Statistics of one side (port or starboard); nan where undefined (see docs)."""

    cv_amplitude: float
    db_std: float
    lag1_range: float
    lag1_ping: float
    water_column_db: float  # median water-column intensity re seabed-profile peak, dB
    dynamic_range_db: float
    saturation: float
    headroom_db: float  # 10·log10(clip level / P99 of the side's intensity), dB (>= 0)
    n_patches: int
    bottom_fraction: float
    texture_tile_db: float  # seabed texture at the patch scale (tile_texture_db), dB
    far_range_db: float  # far-range seabed level re seabed-profile peak (far_range_level), dB
    hist_intensity: np.ndarray = field(repr=False)
    hist_lbp: np.ndarray = field(repr=False)

    SCALARS = (
        "cv_amplitude",
        "db_std",
        "lag1_range",
        "lag1_ping",
        "water_column_db",
        "dynamic_range_db",
        "saturation",
        "headroom_db",
        "n_patches",
        "bottom_fraction",
        "texture_tile_db",
        "far_range_db",
    )

    def scalars(self) -> dict[str, float]:
        return {k: float(getattr(self, k)) for k in self.SCALARS}


@dataclass(frozen=True)
class WaterfallStatistics:
    port: SideStatistics
    starboard: SideStatistics

    def sides(self) -> dict[str, SideStatistics]:
        return {"port": self.port, "starboard": self.starboard}


def split_sides(intensity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(P, 2S) waterfall → (port, starboard), each (P, S) near range first."""
    img = np.asarray(intensity, dtype=np.float64)
    if img.ndim != 2 or img.shape[1] % 2:
        raise ValueError(f"waterfall must be 2-D with an even width, got shape {img.shape}")
    s = img.shape[1] // 2
    return img[:, :s][:, ::-1], img[:, s:]


def seabed_mask(track: BottomTrack, shape: tuple[int, int], guard: int) -> np.ndarray:
    """(P, S) True on samples ≥ guard past the first bottom return."""
    k = np.arange(shape[1])[None, :]
    start = np.where(np.isfinite(track.first_return), track.first_return + guard, np.inf)
    return k >= start[:, None]


def water_column_mask(track: BottomTrack, shape: tuple[int, int], guard: int) -> np.ndarray:
    """(P, S) True between the end of the transmit pulse and ``guard`` samples before the
    first bottom return (empty for pings without bottom)."""
    k = np.arange(shape[1])[None, :]
    end = np.where(np.isfinite(track.first_return), track.first_return - guard, -np.inf)
    return (k >= (track.blank_end + guard)[:, None]) & (k < end[:, None])


def _tiles(a: np.ndarray, n: int) -> np.ndarray:
    """(P, S) → (T, n, n) non-overlapping tiles, grid anchored at (0, 0)."""
    p, s = (a.shape[0] // n) * n, (a.shape[1] // n) * n
    t = a[:p, :s].reshape(p // n, n, s // n, n).swapaxes(1, 2)
    return t.reshape(-1, n, n)


def homogeneous_patches(
    side: np.ndarray, seabed: np.ndarray, clip: float, cfg: RealismConfig
) -> np.ndarray:
    """(T, n, n) intensity patches that satisfy the selection rules of the module."""
    n = cfg.patch
    tiles = _tiles(side, n)
    ok = _tiles(seabed & (side > 0) & (side < clip), n).all(axis=(1, 2))
    h = n // 2
    quad = tiles.reshape(-1, 2, h, 2, h).mean(axis=(2, 4)).reshape(-1, 4)
    with np.errstate(divide="ignore", invalid="ignore"):
        spread = 10.0 * np.log10(quad.max(axis=1) / quad.min(axis=1))
    ok &= np.isfinite(spread) & (spread <= cfg.homogeneity_db)
    return tiles[ok]


def patch_cv(amplitude: np.ndarray) -> np.ndarray:
    """(T, n, n) → (T,) coefficient of variation std/mean (ddof=1)."""
    a = amplitude.reshape(amplitude.shape[0], -1)
    return a.std(axis=1, ddof=1) / a.mean(axis=1)


def patch_lag1(values: np.ndarray, axis: int) -> np.ndarray:
    """(T, n, n) → (T,) Pearson correlation between neighbours one step apart along
    ``axis`` (1 = pings, 2 = range), the patch mean removed; nan for a constant patch."""
    d = values - values.mean(axis=(1, 2), keepdims=True)
    a = np.take(d, np.arange(d.shape[axis] - 1), axis=axis)
    b = np.take(d, np.arange(1, d.shape[axis]), axis=axis)
    num = (a * b).sum(axis=(1, 2))
    den = np.sqrt((a * a).sum(axis=(1, 2)) * (b * b).sum(axis=(1, 2)))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)


def seabed_profile_peak(side: np.ndarray, track: BottomTrack, smooth: int) -> float:
    """Peak of the mean seabed profile: intensity averaged over pings at the same number of
    samples past the first bottom return, smoothed over ``smooth`` samples; only offsets
    seen by at least half of the pings with a bottom count."""
    rows = np.flatnonzero(np.isfinite(track.first_return))
    if rows.size == 0:
        return float("nan")
    s = side.shape[1]
    b = track.first_return[rows].astype(np.int64)
    idx = b[:, None] + np.arange(s)[None, :]
    valid = idx < s
    vals = np.where(valid, np.take_along_axis(side[rows], np.minimum(idx, s - 1), axis=1), 0.0)
    count = valid.sum(axis=0)
    keep = count >= max(1, rows.size // 2)
    prof = vals[:, keep].sum(axis=0) / count[keep]
    if prof.size == 0:
        return float("nan")
    return float(uniform_filter1d(prof, min(smooth, prof.size), mode="nearest").max())


def tile_texture_db(side: np.ndarray, seabed: np.ndarray, n: int) -> float:
    """Seabed texture at the patch scale, dB: the spread of the n × n tile-mean intensities
    of the seabed, in dB, once each range band's (tile column's) median is removed (the
    range profile: beam pattern, TVG, grazing angle), as 1.4826 · MAD over the tiles (a
    robust std, so a wreck's few tiles do not count). Every tile wholly on the seabed with
    positive samples counts, homogeneous or not (the homogeneity test of the speckle rows
    removes exactly this texture); range bands with fewer than two such tiles are left
    out. Pure speckle (exponential intensity, independent samples) gives
    10/ln10 · √ψ₁(n²) ≈ 4.34/n dB; a texture constant over each tile with a std of σ dB
    adds σ in quadrature. nan when fewer than 8 tiles count."""
    tiles = _tiles(side, n)
    cols = side.shape[1] // n
    ok = _tiles(seabed & (side > 0), n).all(axis=(1, 2)).reshape(-1, cols)
    with np.errstate(divide="ignore"):
        db = 10.0 * np.log10(tiles.mean(axis=(1, 2))).reshape(-1, cols)
    ok &= (ok.sum(axis=0) >= 2)[None, :]
    if ok.sum() < 8:
        return float("nan")
    keep = ok.any(axis=0)  # range bands with tiles (no all-nan median)
    db, ok = db[:, keep], ok[:, keep]
    band = np.nanmedian(np.where(ok, db, np.nan), axis=0)
    d = (db - band[None, :])[ok]
    return float(1.4826 * np.median(np.abs(d - np.median(d))))


def far_range_level(side: np.ndarray, seabed: np.ndarray, peak: float) -> float:
    """Far-range seabed level, dB: 10·log10 of the median seabed intensity over the outer
    quarter of the side (samples ≥ 3S/4: the lowest grazing angles) over the seabed-profile
    peak. It falls as the altitude falls when the seabed law falls faster than the
    spreading/area terms at low grazing (docs/realism.md). nan without far seabed."""
    far = seabed.copy()
    far[:, : (3 * side.shape[1]) // 4] = False
    if not far.any() or not peak > 0:
        return float("nan")
    return float(10.0 * np.log10(max(float(np.median(side[far])), 1e-300) / peak))


def _nanmedian(x: np.ndarray) -> float:
    """Median of the finite values (constant patches have no correlation); nan if none."""
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else float("nan")


def side_statistics(
    side: np.ndarray,
    clip: float,
    cfg: RealismConfig,
    name: str = "side",
    first_return: np.ndarray | None = None,
) -> SideStatistics:
    """Statistics of one side (P, S) of linear intensity, near range first.

    ``first_return`` (P,) sample indices (nan = none) replaces the detector, e.g. from a
    recording's altitude (``first_return_from_altitude``).
    Raises ValueError naming the side when it has too few pings/samples or no seabed.
    """
    side = np.nan_to_num(np.asarray(side, dtype=np.float64), nan=0.0)
    p, s = side.shape
    if p < 2 * cfg.patch or s < 4 * cfg.patch:
        raise ValueError(
            f"{name}: recording too short: {p} pings x {s} samples per side, need at least "
            f"{2 * cfg.patch} pings and {4 * cfg.patch} samples"
        )
    if first_return is None:
        track = first_bottom_return(side)
    else:
        fr = np.asarray(first_return, dtype=np.float64)
        if fr.shape != (p,):
            raise ValueError(f"{name}: first_return must have shape ({p},), got {fr.shape}")
        track = BottomTrack(first_return=np.floor(fr), blank_end=np.zeros(p))
    if track.found_fraction < cfg.min_bottom_fraction:
        raise ValueError(
            f"{name}: no seabed: a first bottom return was found on {track.found_fraction:.0%} "
            f"of the pings (need {cfg.min_bottom_fraction:.0%})"
        )
    seabed = seabed_mask(track, side.shape, cfg.guard)
    patches = homogeneous_patches(side, seabed, clip, cfg)
    if patches.shape[0] < cfg.min_patches:
        raise ValueError(
            f"{name}: no seabed: {patches.shape[0]} homogeneous {cfg.patch}x{cfg.patch} seabed "
            f"patches (need {cfg.min_patches})"
        )
    amp = np.sqrt(patches)
    peak = seabed_profile_peak(side, track, cfg.patch)
    floor = peak * 10.0 ** (cfg.floor_db / 10.0)
    floored = np.maximum(side, floor)
    wc = water_column_mask(track, side.shape, cfg.guard)
    wc_db = 10.0 * np.log10(np.median(floored[wc]) / peak) if wc.any() else float("nan")
    lo, hi = np.percentile(floored, cfg.dr_percentiles)
    hi_raw = max(float(np.percentile(side, cfg.dr_percentiles[1])), clip * 1e-30)
    return SideStatistics(
        cv_amplitude=float(np.median(patch_cv(amp))),
        db_std=float(np.median(np.std(10.0 * np.log10(patches), axis=(1, 2), ddof=1))),
        lag1_range=_nanmedian(patch_lag1(amp, axis=2)),
        lag1_ping=_nanmedian(patch_lag1(amp, axis=1)),
        water_column_db=float(wc_db),
        dynamic_range_db=float(10.0 * np.log10(hi / lo)),
        saturation=float(np.mean(side >= clip)),
        headroom_db=float(10.0 * np.log10(clip / min(hi_raw, clip))),
        n_patches=int(patches.shape[0]),
        bottom_fraction=track.found_fraction,
        texture_tile_db=tile_texture_db(side, seabed, cfg.patch),
        far_range_db=far_range_level(floored, seabed, peak),
        hist_intensity=intensity_histogram(floored, seabed),
        hist_lbp=lbp_histogram(floored, seabed),
    )


def clip_level(intensity: np.ndarray, full_scale: float | None) -> float:
    """The saturation level: ``full_scale`` when given, else the waterfall's maximum
    (within 1e-6 relative, so values equal to the maximum up to rounding count)."""
    if full_scale is not None:
        if not full_scale > 0:
            raise ValueError(f"full_scale must be > 0, got {full_scale}")
        return float(full_scale) * (1.0 - 1e-6)
    m = float(np.nanmax(intensity))
    if not m > 0:
        raise ValueError(f"waterfall holds no positive intensity (max {m})")
    return m * (1.0 - 1e-6)


def first_return_from_altitude(
    altitude_m: np.ndarray, slant_range_m: float, samples_per_side: int
) -> np.ndarray:
    """(P,) first-return sample index of a flat seabed under the sonar: altitude over the
    range per sample (nan where the altitude is not positive or beyond the range)."""
    a = np.asarray(altitude_m, dtype=np.float64)
    if not slant_range_m > 0:
        raise ValueError(f"slant_range_m must be > 0, got {slant_range_m}")
    idx = a / slant_range_m * samples_per_side
    return np.where((a > 0) & (idx < samples_per_side), idx, np.nan)


def waterfall_statistics(
    intensity: np.ndarray,
    cfg: RealismConfig = RealismConfig(),
    first_return: np.ndarray | None = None,
) -> WaterfallStatistics:
    """Statistics of both sides of a (P, 2S) linear-intensity waterfall; ``first_return``
    (P,) optionally gives the first bottom return (both sides) instead of the detector."""
    port, stbd = split_sides(intensity)
    if not np.isfinite(intensity).any():
        raise ValueError("waterfall holds no finite sample")
    if np.nanmin(intensity) < 0:
        raise ValueError(
            f"waterfall intensity must be >= 0 (linear intensity), min is {np.nanmin(intensity)}"
        )
    clip = clip_level(intensity, cfg.full_scale)
    return WaterfallStatistics(
        port=side_statistics(port, clip, cfg, "port", first_return),
        starboard=side_statistics(stbd, clip, cfg, "starboard", first_return),
    )


def seabed_reference(intensity: np.ndarray, guard: int = 8) -> float:
    """Median seabed intensity of a waterfall, both sides (a gain reference for display:
    images in dB re this level share one scale whatever the recording's gain)."""
    vals = []
    for side in split_sides(intensity):
        track = first_bottom_return(side)
        vals.append(side[seabed_mask(track, side.shape, guard)])
    v = np.concatenate(vals)
    v = v[v > 0]
    if v.size == 0:
        raise ValueError("no positive seabed sample to take a reference level from")
    return float(np.median(v))
