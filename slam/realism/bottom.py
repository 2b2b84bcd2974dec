"""A small first-bottom-return detector for the realism statistics.

This is deliberately simple (the full bottom tracker of the real-recordings work lives in
``slam.io``): it only has to split one side of a waterfall into *water column* (before the
first bottom return) and *seabed* (after it), robustly enough for statistics.

Per ping, on one side (samples near range first):

1. smooth the linear intensity along range (moving mean of ``smooth_samples``) and across
   pings (running median of ``smooth_pings``), then take dB;
2. threshold halfway (in dB) between the 5th and 75th percentiles of that ping's profile;
3. the *blanking end* is the first sample below the threshold (the transmit pulse at
   sample 0 is usually above it), and the *first return* the first up-crossing after it;
4. pings whose 75th − 5th percentile spread is below ``min_contrast_db`` have no bottom
   (nan), and the track is cleaned by a running median over ``track_pings`` pings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.ndimage import median_filter, uniform_filter1d


@dataclass(frozen=True)
class BottomTrack:
    """First bottom return of one side.

    first_return : (P,) float64 sample index (near range = 0) of the first bottom return,
                   nan where the ping shows no seabed.
    blank_end    : (P,) float64 first sample after the transmit pulse (0 when there is none).
    """

    first_return: np.ndarray
    blank_end: np.ndarray

    @property
    def found_fraction(self) -> float:
        """Fraction of pings with a bottom."""
        return float(np.mean(np.isfinite(self.first_return)))


def _running_nanmedian(x: np.ndarray, n: int) -> np.ndarray:
    """Running median over ``n`` (odd) values ignoring nan; nan where all are nan."""
    h = n // 2
    padded = np.pad(x, h, mode="edge")
    win = sliding_window_view(padded, n)
    out = np.full(x.shape, np.nan)
    ok = np.isfinite(win).any(axis=1)
    out[ok] = np.nanmedian(win[ok], axis=1)
    out[~np.isfinite(x)] = np.nan  # a ping without bottom stays without
    return out


def first_bottom_return(
    side: np.ndarray,
    *,
    smooth_samples: int | None = None,
    smooth_pings: int = 5,
    min_contrast_db: float = 6.0,
    track_pings: int = 9,
) -> BottomTrack:
    """Detect the first bottom return on one side.

    Parameters
    ----------
    side : (P, S) linear intensity (≥ 0), near range first (sample 0 at nadir).
    smooth_samples : along-range smoothing window, samples (default max(3, S // 128)).
    smooth_pings : across-ping running-median window, pings.
    min_contrast_db : pings whose seabed/water-column spread is below this have no bottom.
    track_pings : running-median window cleaning the track, pings (odd).

    Returns
    -------
    BottomTrack with sample indices (float, nan when not found).
    """
    x = np.asarray(side, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] < 8 or x.shape[0] < 1:
        raise ValueError(f"side must be (pings, samples) with >= 8 samples, got {x.shape}")
    p, s = x.shape
    w = smooth_samples or max(3, s // 128)
    sm = uniform_filter1d(np.maximum(np.nan_to_num(x), 0.0), w, axis=1, mode="nearest")
    sm = median_filter(sm, size=(min(smooth_pings, p), 1), mode="nearest")
    peak = float(sm.max())
    db = 10.0 * np.log10(np.maximum(sm, peak * 1e-12 if peak > 0 else 1e-30))
    lo, hi = np.percentile(db, [5.0, 75.0], axis=1)
    above = db >= ((lo + hi) / 2.0)[:, None]
    below = ~above
    has_below = below.any(axis=1)
    blank = np.where(has_below, np.argmax(below, axis=1), s)
    k = np.arange(s)[None, :]
    after = above & (k >= blank[:, None])
    has_ret = after.any(axis=1) & has_below & ((hi - lo) >= min_contrast_db)
    ret = np.where(has_ret, np.argmax(after, axis=1), -1).astype(np.float64)
    ret[~has_ret] = np.nan
    n = max(1, track_pings | 1)
    return BottomTrack(
        first_return=_running_nanmedian(ret, n),
        blank_end=np.where(has_ret, blank, 0).astype(np.float64),
    )
