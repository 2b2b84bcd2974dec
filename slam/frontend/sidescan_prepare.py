"""Input conditioning of sonar images before segmentation: side-scan waterfall windows
(:func:`make_sss_prepare`, :func:`no_return_mask`) and FLS polar frames
(:func:`make_fls_prepare`). Linear intensity in, normalized dB out; vectorized.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy import ndimage

from slam.frontend.normalization import mira_normalize


def no_return_mask(img: np.ndarray) -> np.ndarray:
    """(P, 2S) bool: samples past the last echo of each ping side (port left, far first).

    A side-scan ping that runs past the end of the insonified seabed (the swath cut off by
    the edge of the surveyed area, a bank, the end of the recorded range) ends in a run of
    samples at the display floor (value <= 0, log-compressed or linear). That trailing run,
    counted from the far end of each side, is flagged; isolated dark samples before the
    last echo (speckle dips, shadows behind objects) are not. Vectorized over pings.
    """
    x = np.asarray(img)
    if x.ndim != 2 or x.shape[1] % 2:
        raise ValueError(f"img must be (pings, 2 x samples), got shape {x.shape}")
    s = x.shape[1] // 2
    echo = x > 0
    # per side, near -> far; the last echo index (-1: none)
    out = np.empty(x.shape, dtype=bool)
    for cols, flip in ((slice(None, s), True), (slice(s, None), False)):
        e = echo[:, cols][:, ::-1] if flip else echo[:, cols]
        last = np.where(e.any(axis=1), s - 1 - np.argmax(e[:, ::-1], axis=1), -1)
        m = np.arange(s)[None, :] > last[:, None]
        out[:, cols] = m[:, ::-1] if flip else m
    return out


#: dB span of a prepared side-scan window (re the normalized seabed level): fixed, so a
#: display of the windows can use one mapping for a whole run
PREPARED_DB = (-10.0, 20.0)


def make_sss_prepare(
    log_compressed: bool, dynamic_range_db: float, looks: int = 3, normalization: str = "mira"
):
    """The front end's input conditioning for a side-scan window, in order:

    1. back to linear intensity if the sonar log-compressed its output for display
       (x in [0, 1] spans ``dynamic_range_db``; the offset cancels in step 2);
    2. normalization -> ~1 on average seabed, by ``normalization``:
       ``"mira"`` (slam.frontend.normalization.mira_normalize, thesis Ch. 4.1: per side,
       mixed-exponential fit of the range profile, 9 pings averaged around the window's
       middle ping), or ``"column-median"``: each range sample divided by its median over
       the window's pings (the usual empirical along-track normalization; it also removes
       range-gain shapes the two exponentials cannot fit, such as a rise near nadir);
    3. the water column (slant range < altitude of that ping) and the samples past the
       last echo of a ping (:func:`no_return_mask`: a swath cut off by the end of the
       seabed) set to the seabed level 1, so the threshold separates highlights from
       seabed, not seabed from water or from no data (a large no-data block at -10 dB
       makes the window's histogram bimodal and drags the threshold into the seabed);
    4. ``looks`` x ``looks`` incoherent averaging (cv2.blur) against single-look speckle;
    5. dB (10 log10, clipped to [-10, 20] dB) for the segmentation.
    """
    if normalization not in ("mira", "column-median"):
        raise ValueError(f"normalization: got {normalization!r}; allowed: mira, column-median")

    def prepare(img: np.ndarray, altitudes: np.ndarray, slant: np.ndarray) -> np.ndarray:
        lin = (
            np.power(10.0, img * (dynamic_range_db / 10.0))
            if log_compressed
            else img.astype(np.float64)
        )
        noret = no_return_mask(img)
        if normalization == "mira":
            m = mira_normalize(lin.astype(np.float32), average=9).normalized
        else:
            m = lin / np.maximum(np.median(lin, axis=0, keepdims=True), 1e-12)
        S = m.shape[1] // 2
        wc = slant[None, :] < altitudes[:, None]  # (P, S) near -> far
        full = np.concatenate([wc[:, ::-1], wc], axis=1) | noret
        m = np.where(full, 1.0, m).astype(np.float32)
        if looks > 1:
            m = cv2.blur(m, (looks, looks))
        assert m.shape[1] == 2 * S
        lo, hi = (10.0 ** (v / 10.0) for v in PREPARED_DB)
        return (10.0 * np.log10(np.clip(m, lo, hi))).astype(np.float32)

    return prepare


def make_fls_prepare(
    log_compressed: bool,
    dynamic_range_db: float,
    looks: int = 5,
    window: int = 15,
    floor: float = 0.02,
):
    """Conditioning of an FLS polar frame (bins, beams) before segmentation: linear
    intensity; each cell divided by the median of its ``window`` x ``window`` neighbourhood
    (a local background estimate: the seabed's level changes with range and grazing angle
    across the fan, so a per-range normalization is not enough; scipy.ndimage); cells
    without a return (display value <= ``floor``) set to the background level 1;
    ``looks`` x ``looks`` averaging against speckle; dB for the segmentation."""

    def prepare(img: np.ndarray) -> np.ndarray:
        x = img.astype(np.float64)
        lin = np.power(10.0, x * (dynamic_range_db / 10.0)) if log_compressed else x
        valid = x > (floor if log_compressed else floor * max(float(x.max()), 1e-30))
        if not valid.any():
            return np.zeros(x.shape, np.float32)
        fill = float(np.median(lin[valid]))
        bg = ndimage.median_filter(np.where(valid, lin, fill), size=window)
        m = np.where(valid, lin / np.maximum(bg, 1e-30), 1.0).astype(np.float32)
        if looks > 1:
            m = cv2.blur(m, (looks, looks))
        lo, hi = (10.0 ** (v / 10.0) for v in PREPARED_DB)
        return (10.0 * np.log10(np.clip(m, lo, hi))).astype(np.float32)

    return prepare
