"""Particle resampling as pure functions on weight arrays, plus log-weight helpers.

Hand-written (no library in the project's dependencies provides them; filterpy has the same
two routines but uses the global RNG): the standard low-variance schemes from Thrun,
Burgard and Fox, *Probabilistic Robotics* (2005), Table 4.4, and Douc, Cappé and Moulines
(2005). Every random draw comes from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "effective_sample_size",
    "normalize_log_weights",
    "stratified_resample",
    "systematic_resample",
]


def _check_weights(weights) -> np.ndarray:
    w = np.asarray(weights, dtype=float)
    if w.ndim != 1 or w.size == 0:
        raise ValueError(f"weights must be a non-empty 1-D array, got shape {w.shape}")
    if not np.all(np.isfinite(w)):
        raise ValueError(f"weights must be finite, got {w[~np.isfinite(w)][:5]} among them")
    if np.any(w < 0.0):
        raise ValueError(f"weights must be >= 0, got minimum {w.min()}")
    total = w.sum()
    if not total > 0.0:
        raise ValueError(f"weights must have a positive sum, got {total}")
    return w / total


def _draw(w: np.ndarray, positions: np.ndarray) -> np.ndarray:
    cumulative = np.cumsum(w)
    cumulative[-1] = 1.0  # guard against round-off leaving the last bin short of 1
    return np.searchsorted(cumulative, positions, side="right").astype(np.intp)


def systematic_resample(weights, rng: np.random.Generator) -> np.ndarray:
    """Systematic (low-variance) resampling.

    One uniform offset ``u ~ U[0, 1/N)``; particle ``i`` is drawn at the points
    ``u + k/N``. Particle ``i`` is copied ``floor(N w_i)`` or ``ceil(N w_i)`` times.

    Parameters
    ----------
    weights : (N,) non-negative importance weights (need not be normalized).
    rng : numpy Generator supplying the single uniform draw.

    Returns
    -------
    indexes : (N,) int, sorted indexes of the particles to keep.
    """
    w = _check_weights(weights)
    n = w.size
    positions = (rng.random() + np.arange(n)) / n
    return _draw(w, positions)


def stratified_resample(weights, rng: np.random.Generator) -> np.ndarray:
    """Stratified resampling: one uniform draw in each of the N strata ``[k/N, (k+1)/N)``.

    This is what Tim Bailey's FastSLAM 2.0 uses. Same interface as
    :func:`systematic_resample`; the count of particle ``i`` is within ±2 of ``N w_i``.
    """
    w = _check_weights(weights)
    n = w.size
    positions = (rng.random(n) + np.arange(n)) / n
    return _draw(w, positions)


def normalize_log_weights(log_weights) -> tuple[np.ndarray, float]:
    """Normalized linear weights from log weights without underflow.

    Subtracts the maximum before exponentiating (log-sum-exp), so weights whose logs are
    all far below zero (e.g. -1e5 after a huge innovation) still give a valid
    distribution instead of all zeros.

    Returns
    -------
    w : (N,) weights summing to 1.
    log_normalizer : log of the sum of the unnormalized weights.
    """
    lw = np.asarray(log_weights, dtype=float)
    if lw.ndim != 1 or lw.size == 0:
        raise ValueError(f"log_weights must be a non-empty 1-D array, got shape {lw.shape}")
    if np.any(np.isnan(lw)) or np.any(lw == np.inf):
        raise ValueError("log_weights must not contain NaN or +inf")
    m = lw.max()
    if m == -np.inf:
        raise ValueError("log_weights are all -inf: every particle has zero weight")
    e = np.exp(lw - m)
    s = e.sum()
    return e / s, float(m + np.log(s))


def effective_sample_size(weights) -> float:
    """Kish's effective sample size ``1 / sum(w_i^2)`` of normalized weights."""
    w = _check_weights(weights)
    return float(1.0 / np.sum(w * w))
