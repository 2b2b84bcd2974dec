"""Image artefacts that are not seabed: burned-in annotations, no-echo areas, and the
first-bottom-return edge of a side-scan waterfall.

* **Burned-in annotations.** Display images exported by survey software carry overlays
  such as the SDVD tiles' "10 M" scale bar: saturated strokes (text, a tick line) drawn
  on a near-black box or flanked by near-black lines. Seabed highlights, even the
  brightest, sit among seabed-level pixels, and an object's highlight has its acoustic
  shadow on one side only. So an annotation stroke pixel is a bright pixel (>= ``bright``)
  whose ``window × window`` neighbourhood is, apart from the bright pixels, mostly
  (>= ``dark_fraction``) near-black (<= ``dark``); the annotation mask is those pixels
  grown by ``grow_px`` (the box around the text). :func:`mask_annotations` replaces the
  masked pixels with the seabed level (median of the other non-zero pixels), so no
  threshold picks them up and no contrast ring sees them.
* **No-echo areas.** Zero padding of tiles cut at the edge of a swath, and the water
  column before the first bottom return, hold no seabed echo: connected areas of
  near-zero pixels (<= ``level``) of at least ``min_area_px`` pixels. A detection touching
  one is an edge artefact (the bright rim of the first return, or speckle against black)
  rather than an object on the seabed.
* **First-return edge of a waterfall** (:func:`first_return_edge_mask`): per ping and per
  side, the first sample from nadir outward whose smoothed level reaches a fraction of
  that side's seabed level; everything from nadir to that sample plus a margin is the
  water column and its edge. The pipeline drops detections whose centroid falls inside
  (the Scotsman XTF's symmetric "landmark" at ping 442 is this edge).

All masks are ``(H, W)`` bool arrays in image pixels.
"""

from __future__ import annotations

import cv2
import numpy as np
from scipy.ndimage import median_filter

from .image import as_gray8
from .regions import Region, cc_stats

__all__ = [
    "annotation_mask",
    "first_return_edge_mask",
    "mask_annotations",
    "no_echo_mask",
    "regions_outside",
]


def annotation_mask(
    gray8: np.ndarray,
    *,
    bright: int = 200,
    dark: int = 30,
    window: int = 5,
    dark_fraction: float = 0.6,
    grow_px: int = 5,
) -> np.ndarray:
    """Pixels of burned-in annotations (module docstring), ``(H, W)`` bool."""
    if window < 3 or window % 2 == 0:
        raise ValueError(f"window={window!r}: must be an odd integer >= 3 (pixels)")
    if not 0.0 < dark_fraction <= 1.0:
        raise ValueError(f"dark_fraction={dark_fraction!r}: must be in (0, 1]")
    if not 0 <= dark < bright <= 255:
        raise ValueError(f"dark={dark!r}, bright={bright!r}: need 0 <= dark < bright <= 255")
    g = as_gray8(gray8)
    is_bright = (g >= bright).view(np.uint8)
    is_dark = (g <= dark).view(np.uint8)
    k = (window, window)
    n_bright = cv2.boxFilter(is_bright, cv2.CV_32F, k, normalize=False)
    n_dark = cv2.boxFilter(is_dark, cv2.CV_32F, k, normalize=False)
    n_other = window * window - n_bright
    core = is_bright.astype(bool) & (n_other >= window) & (n_dark >= dark_fraction * n_other)
    if grow_px > 0 and core.any():
        size = 2 * int(grow_px) + 1
        core = cv2.dilate(core.view(np.uint8), np.ones((size, size), np.uint8)).view(bool)
    return core


def mask_annotations(gray8: np.ndarray, **kwargs) -> tuple[np.ndarray, np.ndarray]:
    """``(image, mask)``: ``gray8`` with its :func:`annotation_mask` pixels set to the
    median of the other non-zero pixels (the seabed level), and that mask."""
    g = as_gray8(gray8)
    mask = annotation_mask(g, **kwargs)
    if not mask.any():
        return g, mask
    rest = g[~mask]
    rest = rest[rest > 0]
    level = int(np.median(rest)) if rest.size else 0
    out = g.copy()
    out[mask] = level
    return out, mask


def no_echo_mask(
    gray8: np.ndarray, *, level: int = 2, min_area_px: int = 200, margin_px: int = 3
) -> np.ndarray:
    """Connected near-zero areas (<= ``level``) of at least ``min_area_px`` pixels, grown
    by ``margin_px`` (module docstring), ``(H, W)`` bool."""
    g = as_gray8(gray8)
    low = (g <= level).view(np.uint8)
    if not low.any():
        return np.zeros(g.shape, bool)
    _n, labels, stats, _ = cc_stats(low)
    big = stats[:, cv2.CC_STAT_AREA] >= min_area_px
    big[0] = False
    if not big.any():
        return np.zeros(g.shape, bool)
    m = np.take(big.view(np.uint8), labels)
    if margin_px > 0:
        size = 2 * int(margin_px) + 1
        m = cv2.dilate(m, np.ones((size, size), np.uint8))
    return m.view(bool)


def regions_outside(
    regions: tuple[Region, ...], labels: np.ndarray, suppress: np.ndarray
) -> tuple[Region, ...]:
    """The regions of the label image ``labels`` with no pixel in the bool mask
    ``suppress``."""
    if not regions or not suppress.any():
        return tuple(regions)
    hit = np.zeros(int(labels.max()) + 1, bool)
    hit[np.unique(labels[suppress])] = True
    return tuple(r for r in regions if not hit[r.label])


def first_return_edge_mask(
    waterfall: np.ndarray,
    *,
    fraction: float = 0.5,
    smooth_samples: int = 9,
    smooth_pings: int = 5,
    margin_samples: int = 8,
) -> np.ndarray:
    """Water column and first-bottom-return edge of a side-scan waterfall, bool mask.

    waterfall : (pings, 2 × samples) intensities, port on the left (far range at column
        0, nadir in the middle), starboard on the right (the field's display layout).
    fraction  : the bottom is reached where the smoothed level first reaches this fraction
        of the side's seabed level (median over the ping's outer half of that side).
    smooth_samples, smooth_pings : box smoothing along range and along track before the
        search (speckle), and a running median of the found edge over ``smooth_pings``.
    margin_samples : samples past the found edge still masked (the bright rim).

    Returns a ``(pings, 2 × samples)`` bool mask: True from nadir out to the edge plus the
    margin on both sides. A ping side that never reaches the level is masked whole.
    """
    w = np.asarray(waterfall, dtype=np.float32)
    if w.ndim != 2 or w.shape[1] < 4 or w.shape[1] % 2:
        raise ValueError(f"waterfall: shape {w.shape}, need (pings, 2 × samples) with samples >= 2")
    if not np.isfinite(w).all():
        raise ValueError("waterfall: contains NaN or inf")
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction={fraction!r}: must be in (0, 1)")
    n_ping, n_col = w.shape
    half = n_col // 2
    mask = np.zeros(w.shape, bool)
    sm = cv2.blur(
        w, (max(1, smooth_samples), max(1, smooth_pings)), borderType=cv2.BORDER_REPLICATE
    )
    for side in (0, 1):
        # columns ordered from nadir outward
        s = sm[:, :half][:, ::-1] if side == 0 else sm[:, half:]
        seabed = np.median(s[:, half // 2 :], axis=1)
        reached = s >= (fraction * seabed)[:, None]
        first = np.where(reached.any(axis=1), reached.argmax(axis=1), half)
        if smooth_pings > 1 and n_ping >= smooth_pings:
            first = median_filter(first, size=smooth_pings, mode="nearest")
        edge = np.minimum(first + int(margin_samples), half)
        inside = np.arange(half)[None, :] < edge[:, None]
        if side == 0:
            mask[:, :half] = inside[:, ::-1]
        else:
            mask[:, half:] = inside
    return mask
