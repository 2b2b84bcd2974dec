"""Grey-level histogram, the power-law transform and Otsu thresholds (eqs. 3.1–3.11).

Convention for every threshold in this package: a threshold ``t`` is an 8-bit grey level
and the foreground (object) is ``image > t``; the thesis reports ``t / 255``.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

__all__ = [
    "gray_histogram",
    "otsu_threshold",
    "otsu_threshold_hist",
    "power_law",
    "power_law_lut",
]


def gray_histogram(gray8: np.ndarray) -> np.ndarray:
    """Counts ``n_i`` of the 256 grey levels of a ``uint8`` image, shape (256,), float64."""
    hist = cv2.calcHist([gray8], [0], None, [256], [0, 256])
    return hist.ravel().astype(np.float64)


@lru_cache(maxsize=16)
def _power_law_lut_cached(c: float, r: float) -> np.ndarray:
    x = np.arange(256, dtype=np.float64)
    y = np.clip(np.rint(c * x**r), 0, 255).astype(np.uint8)
    y.setflags(write=False)
    return y


def power_law_lut(c: float = 0.1, r: float = 1.415) -> np.ndarray:
    """Look-up table of eq. 3.11, ``y = c · x^r`` on 8-bit levels, rounded and clipped to
    [0, 255] (with c = 0.1, r = 1.415 level 255 maps to 254)."""
    return _power_law_lut_cached(float(c), float(r))


def power_law(gray8: np.ndarray, c: float = 0.1, r: float = 1.415) -> np.ndarray:
    """Apply the power-law transform (eq. 3.11) to a ``uint8`` image."""
    return cv2.LUT(gray8, power_law_lut(c, r))


def otsu_threshold_hist(hist: np.ndarray, lo: int = 0) -> tuple[int, float]:
    """Otsu's threshold restricted to grey levels ``[lo, 255]`` (eqs. 3.1–3.10).

    With ``lo = T + 1`` this is the reference's constrained re-threshold T*; with ``lo = 0``
    it is the traditional Otsu threshold. Vectorized with cumulative sums over the
    histogram (the reference defines this computation; no library restricts Otsu to a
    grey-level range, so it is written here and tested against a direct loop over eqs.
    3.1–3.10).

    Parameters
    ----------
    hist : (256,) counts n_i of grey levels 0..255.
    lo   : lowest grey level taken into account (eq. 3.1 sums i = lo..255).

    Returns
    -------
    (t, sigma_b2) : t maximizes the between-class variance σ_B² = ω0 ω1 (u0 − u1)² over
        ``lo <= t <= 255`` (class C0 = [lo, t], C1 = [t+1, 255]); the first maximum wins
        (as in OpenCV and scikit-image). When no split has σ_B² > 0 (fewer than two
        occupied levels in the range) the result is ``(lo - 1, 0.0)``: nothing to split,
        the caller keeps the previous threshold.
    """
    h = np.asarray(hist, dtype=np.float64).ravel()
    if h.shape != (256,):
        raise ValueError(f"hist: shape {h.shape}, need (256,) grey-level counts")
    if not (0 <= int(lo) <= 255):
        raise ValueError(f"lo={lo!r}: must be a grey level in [0, 255]")
    lo = int(lo)
    n = h[lo:]
    total = n.sum()  # eq. 3.1
    if total <= 0:
        return lo - 1, 0.0
    p = n / total  # eq. 3.2
    levels = np.arange(lo, 256, dtype=np.float64)
    w0 = np.cumsum(p)  # eq. 3.3, ω0(t) for t = lo..255
    m0 = np.cumsum(p * levels)  # ω0 u0
    u_m = m0[-1]  # eq. 3.5, total mean
    w1 = 1.0 - w0
    # eq. 3.8 in the form (u_M ω0 − ω0 u0)² / (ω0 ω1) = ω0 ω1 (u0 − u1)²
    num = (u_m * w0 - m0) ** 2
    den = w0 * w1
    valid = (w0 > 0) & (w1 > 1e-12)
    sigma_b = np.zeros_like(w0)
    np.divide(num, den, out=sigma_b, where=valid)
    best = int(np.argmax(sigma_b))  # eq. 3.10, first maximum
    if sigma_b[best] <= 0.0:
        return lo - 1, 0.0
    return lo + best, float(sigma_b[best])


def otsu_threshold(gray8: np.ndarray) -> int:
    """Traditional Otsu threshold of a ``uint8`` image with OpenCV (``THRESH_OTSU``).

    Foreground is ``gray8 > t``. A constant image gives ``t = 0`` from OpenCV; callers
    treat single-level images separately (they have no regions).
    """
    t, _ = cv2.threshold(gray8, 0, 255, cv2.THRESH_BINARY | cv2.THRESH_OTSU)
    return int(t)
