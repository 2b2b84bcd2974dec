"""Bottom tracking of a side-scan waterfall: the first seabed return of every ping.

Over a seabed below the sonar, the first echo on both sides comes from straight below
(nadir), at slant range = altitude. Between the transmit pulse and that echo lies the
water column: dark on survey sonars, speckled with noise, fish and suspended sediment on
recreational units. The tracker:

1. works on the log intensity averaged over ``smooth_pings × smooth_m`` (speckle and
   isolated water-column targets are shorter than the seabed step);
2. scores every sample k as a step edge, ``mean(log I[k : k+w]) − mean(log I[k−w : k])``
   with w = ``edge_m`` in samples, on port and starboard, and adds the two scores — the
   nadir return is at the same range on both sides, a fish or a wreck usually is not;
3. takes the *first* sample after the blanking range ``blank_m`` whose score reaches
   ``first_fraction`` of the ping's best score (the first return, not the strongest: a
   strong target further out must not capture the track), then the peak of that edge's
   score within the next w samples (the step itself);
4. marks a ping "no bottom" (nan) when its best score is below ``min_contrast`` or below
   ``min_z`` robust standard deviations of its own scores (no step stands out of the
   speckle: lost bottom, out of range, or a file with no water column at all);
5. rejects picks more than ``max_jump_m`` from the running median of ``median_pings``
   picks (a multiple or a school of fish), which also become nan.

Each step is vectorized over all pings. The altitude is the pick's slant range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import median_filter, uniform_filter

from slam.io.waterfall import Waterfall


@dataclass(frozen=True)
class BottomTrackConfig:
    """Bottom-tracker parameters (ranges in metres of slant range).

    blank_m : ignore the first ``blank_m`` of every ping (transmit pulse, ringing).
    smooth_m, smooth_pings : averaging window along range (m) and along track (pings).
    edge_m : half-width of the step-edge score, m.
    first_fraction : the pick is the first sample scoring this fraction of the ping's best.
    min_contrast : least best score (natural-log units, both sides summed) for a bottom.
    min_z : least best score in robust standard deviations of the ping's scores (median
        absolute deviation × 1.4826): the maximum of pure speckle over a few hundred
        samples stays near 4.
    median_pings, max_jump_m : outlier rejection against the running median of picks.
    """

    blank_m: float = 0.3
    smooth_m: float = 0.1
    smooth_pings: int = 5
    edge_m: float = 0.25
    first_fraction: float = 0.6
    min_contrast: float = 0.4
    min_z: float = 4.5
    median_pings: int = 15
    max_jump_m: float = 1.0

    def __post_init__(self) -> None:
        for name in ("blank_m", "smooth_m", "edge_m", "min_contrast", "max_jump_m"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"BottomTrackConfig.{name} must be finite and >= 0, got {v}")
        if not 0 < self.first_fraction <= 1:
            raise ValueError(
                f"BottomTrackConfig.first_fraction must be in (0, 1], got {self.first_fraction}"
            )
        for name in ("smooth_pings", "median_pings"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"BottomTrackConfig.{name} must be >= 1, got {getattr(self, name)}")


@dataclass(frozen=True)
class BottomTrack:
    """Result of :func:`track_bottom`.

    sample : (P,) float64, first-return sample index per side (near range = 0), nan = none.
    altitude_m : (P,) float64, slant range of the first return = altitude, m (nan = none).
    contrast : (P,) float64, the ping's best edge score (log units, both sides summed).
    z : (P,) float64, that score in robust standard deviations of the ping's scores.
    """

    sample: np.ndarray
    altitude_m: np.ndarray
    contrast: np.ndarray
    z: np.ndarray

    @property
    def found(self) -> np.ndarray:
        """(P,) bool: the ping has a bottom pick."""
        return np.isfinite(self.sample)


def _edge_score(logi: np.ndarray, w: int) -> np.ndarray:
    """(P, S) ``mean(x[k:k+w]) − mean(x[k−w:k])``, 0 where a window leaves the row."""
    p, s = logi.shape
    out = np.zeros((p, s))
    if s < 2 * w:
        return out
    c = np.zeros((p, s + 1))
    np.cumsum(logi, axis=1, out=c[:, 1:])
    mid = c[:, w : s - w + 1]  # c[k] for k = w .. s − w
    out[:, w : s - w + 1] = (c[:, 2 * w :] - 2.0 * mid + c[:, : s - 2 * w + 1]) / w
    return out


def track_bottom(wf: Waterfall, config: BottomTrackConfig | None = None) -> BottomTrack:
    """First seabed return of every ping of ``wf`` (see the module docstring)."""
    cfg = config or BottomTrackConfig()
    s = wf.samples_per_side
    spacing = wf.sample_spacing_m()
    dr = float(np.median(spacing[np.isfinite(spacing)])) if np.isfinite(spacing).any() else 0.0
    if not (np.isfinite(dr) and dr > 0):
        raise ValueError(
            f"track_bottom needs the waterfall's slant range (got sample spacing {dr} m); "
            "an image without range metadata cannot be bottom-tracked in metres"
        )
    img = np.asarray(wf.intensity, dtype=np.float64)
    floor = max(float(np.percentile(img[img > 0], 1)) if np.any(img > 0) else 1.0, 1e-6)
    win = (max(1, int(cfg.smooth_pings)), max(1, round(cfg.smooth_m / dr)))
    w = max(2, round(cfg.edge_m / dr))
    score = np.zeros((img.shape[0], s))
    for side in (img[:, :s][:, ::-1], img[:, s:]):  # both near range first
        logi = np.log(np.maximum(side, floor))
        score += _edge_score(uniform_filter(logi, size=win, mode="nearest"), w)
    blank = min(s - 1, round(cfg.blank_m / dr))
    score[:, :blank] = 0.0
    best = score.max(axis=1)
    hit = score >= cfg.first_fraction * best[:, None]
    first = np.argmax(hit, axis=1)
    # climb to the peak of that first edge (the step itself, not where its ramp starts)
    win_idx = np.minimum(first[:, None] + np.arange(w + 1)[None, :], s - 1)
    peak = np.take_along_axis(score, win_idx, axis=1).argmax(axis=1)
    pick = (first + peak).astype(np.float64)
    med = np.median(score[:, blank:], axis=1, keepdims=True)
    noise = 1.4826 * np.median(np.abs(score[:, blank:] - med), axis=1)
    z = (best - med[:, 0]) / np.maximum(noise, 1e-12)
    pick[(best < cfg.min_contrast) | (z < cfg.min_z)] = np.nan
    pick = _reject_jumps(pick, cfg.median_pings, cfg.max_jump_m / dr)
    return BottomTrack(sample=pick, altitude_m=pick * spacing, contrast=best, z=z)


def _reject_jumps(pick: np.ndarray, window: int, max_jump: float) -> np.ndarray:
    """nan where a pick is more than ``max_jump`` samples from the running median of the
    finite picks around it (window ``window`` pings)."""
    ok = np.isfinite(pick)
    if ok.sum() < 3:
        return pick
    idx = np.flatnonzero(ok)
    med = median_filter(pick[ok], size=max(1, int(window)), mode="nearest")
    out = pick.copy()
    out[idx[np.abs(pick[ok] - med) > max_jump]] = np.nan
    return out


def water_column_mask(wf: Waterfall, track: BottomTrack) -> np.ndarray:
    """(P, 2S) bool, True on the water column (nearer than the first return) on both
    sides; pings without a bottom pick are all False (nothing masked, nothing invented)."""
    s = wf.samples_per_side
    first = np.where(track.found, track.sample, 0.0)
    near = np.arange(s)[None, :] < first[:, None]
    return np.concatenate([near[:, ::-1], near], axis=1)


def seabed_region(wf: Waterfall) -> np.ndarray:
    """(P, 2S) bool, True on the seabed (from each ping's first return outward, both
    sides): the complement of :func:`water_column_mask` of the bottom track when the
    waterfall has a slant range; a bare image (no range metadata) falls back to
    :func:`slam.frontend.normalization.seabed_mask` (a threshold on each row's 90th
    percentile)."""
    spacing = wf.sample_spacing_m()
    if np.isfinite(spacing).any() and float(np.nanmedian(spacing)) > 0:
        return ~water_column_mask(wf, track_bottom(wf))
    from slam.frontend.normalization import seabed_mask

    return seabed_mask(wf)


def fill_track(track: BottomTrack) -> np.ndarray:
    """(P,) altitude with the gaps linearly interpolated between the nearest picks (ends
    held); raises ValueError when no ping has a pick."""
    alt = track.altitude_m
    ok = np.isfinite(alt)
    if not ok.any():
        raise ValueError("bottom track: no ping has a first return; cannot fill the altitude")
    k = np.arange(alt.size)
    return np.interp(k, k[ok], alt[ok])
