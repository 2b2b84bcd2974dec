"""Maximum entropy thresholding (Kapur, Sahoo & Wong 1985), the reference's strongest baseline.

Neither scikit-image nor OpenCV implements Kapur's method, so it is written here,
vectorized over the 256-bin histogram with cumulative sums, and tested against a direct
double loop.

For a threshold ``t`` (background C0 = [0, t], object C1 = [t+1, 255]) with normalized
histogram ``p_i``, ``P0 = Σ_{i<=t} p_i`` and ``P1 = 1 − P0``, the class entropies are

    H0(t) = −Σ_{i<=t} (p_i/P0) ln(p_i/P0) = ln P0 − (Σ_{i<=t} p_i ln p_i) / P0
    H1(t) = −Σ_{i>t}  (p_i/P1) ln(p_i/P1) = ln P1 − (Σ_{i>t}  p_i ln p_i) / P1

and the threshold maximizes ``H0 + H1`` over the ``t`` with both classes non-empty (the
first maximum wins). Natural logarithms; ``0 · ln 0 = 0``.
"""

from __future__ import annotations

import numpy as np

from .otsu import gray_histogram

__all__ = ["kapur_entropy_curve", "kapur_threshold", "kapur_threshold_hist"]


def kapur_entropy_curve(hist: np.ndarray) -> np.ndarray:
    """Total entropy ``H0(t) + H1(t)`` for t = 0..255 (nats); ``-inf`` where a class is empty."""
    h = np.asarray(hist, dtype=np.float64).ravel()
    if h.shape != (256,):
        raise ValueError(f"hist: shape {h.shape}, need (256,) grey-level counts")
    if (h < 0).any() or not np.isfinite(h).all():
        raise ValueError("hist: counts must be finite and >= 0")
    total = h.sum()
    if total <= 0:
        raise ValueError("hist: all counts are zero (empty image)")
    p = h / total
    plogp = np.zeros_like(p)
    nz = p > 0
    plogp[nz] = p[nz] * np.log(p[nz])
    P0 = np.cumsum(p)
    S0 = np.cumsum(plogp)
    # Class 1 from the counts above t (exact), not from the rounded 1 − P0.
    upper_count = total - np.cumsum(h)
    P1 = upper_count / total
    S1 = S0[-1] - S0
    valid = (P0 > 0) & (upper_count > 0)
    out = np.full(256, -np.inf)
    P1v = np.where(valid, P1, 1.0)
    P0v = np.where(valid, P0, 1.0)
    H = np.log(P0v) - S0 / P0v + np.log(P1v) - S1 / P1v
    out[valid] = H[valid]
    return out


def kapur_threshold_hist(hist: np.ndarray) -> int:
    """Kapur's threshold from a (256,) histogram; foreground is ``level > t``.

    With fewer than two occupied grey levels no split exists and the highest occupied
    level is returned (so nothing is foreground).
    """
    curve = kapur_entropy_curve(hist)
    if not np.isfinite(curve).any():
        h = np.asarray(hist).ravel()
        return int(np.flatnonzero(h > 0)[-1])
    return int(np.argmax(curve))


def kapur_threshold(gray8: np.ndarray) -> int:
    """Kapur's maximum entropy threshold of a ``uint8`` image."""
    return kapur_threshold_hist(gray_histogram(gray8))
