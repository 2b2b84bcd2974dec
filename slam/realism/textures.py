"""Intensity and LBP-texture histograms of the seabed, and distances between histograms.

Both histograms are gain-invariant: intensities are taken in dB *re the median seabed
intensity* of the same side.

* Intensity histogram: dB re median over [-40, +30) dB in 0.5-dB bins (values outside go
  to the end bins), seabed samples only.
* LBP histogram: ``skimage.feature.local_binary_pattern(P=8, R=1, method="uniform")``
  (10 codes) on the dB image quantized to 0.25-dB steps as uint8 over [-40, +23.75] dB re
  median (LBP is invariant to monotone maps, quantization only avoids float ties), counted
  on seabed samples whose 3 × 3 neighbourhood is all seabed.

Distances (``p`` = reference/real, ``q`` = simulated; both normalized, 1e-10 added to every
bin before the KL): KL(p‖q) in nats, the Jensen–Shannon *distance* (square root of the
divergence, base 2, in [0, 1]) and the earth mover's distance over the bin centres (dB
for intensity, LBP code for texture).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import binary_erosion
from scipy.spatial.distance import jensenshannon
from scipy.stats import entropy, wasserstein_distance
from skimage.feature import local_binary_pattern

INTENSITY_EDGES_DB = np.arange(-40.0, 30.0 + 0.25, 0.5)
LBP_POINTS, LBP_RADIUS = 8, 1
LBP_BINS = LBP_POINTS + 2
_EPS = 1e-10


def _db_re_median(intensity: np.ndarray, seabed: np.ndarray) -> np.ndarray:
    med = float(np.median(intensity[seabed]))
    return 10.0 * np.log10(intensity / med)


def intensity_histogram(intensity: np.ndarray, seabed: np.ndarray) -> np.ndarray:
    """Normalized histogram of seabed dB re median (positive, floored intensity)."""
    if not seabed.any():
        raise ValueError("intensity_histogram: no seabed sample")
    db = _db_re_median(intensity, seabed)[seabed]
    db = np.clip(db, INTENSITY_EDGES_DB[0], INTENSITY_EDGES_DB[-1] - 1e-9)
    h, _ = np.histogram(db, bins=INTENSITY_EDGES_DB)
    return h / h.sum()


def lbp_histogram(intensity: np.ndarray, seabed: np.ndarray) -> np.ndarray:
    """Normalized histogram of the 10 uniform LBP codes over the interior of the seabed."""
    db = _db_re_median(intensity, seabed)
    q = np.clip(np.rint((db + 40.0) * 4.0), 0, 255).astype(np.uint8)
    codes = local_binary_pattern(q, LBP_POINTS, LBP_RADIUS, method="uniform")
    inner = binary_erosion(seabed, structure=np.ones((3, 3), bool), border_value=0)
    if not inner.any():
        raise ValueError("lbp_histogram: no interior seabed sample")
    h = np.bincount(codes[inner].astype(np.int64), minlength=LBP_BINS)[:LBP_BINS]
    return h / h.sum()


@dataclass(frozen=True)
class HistogramDistances:
    kl: float
    js: float
    emd: float


def histogram_distances(p: np.ndarray, q: np.ndarray, centres: np.ndarray) -> HistogramDistances:
    """KL(p‖q) (nats), Jensen–Shannon distance (base 2) and earth mover's distance between
    two histograms over the same bins with the given bin centres."""
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    if p.shape != q.shape or p.shape != np.shape(centres):
        raise ValueError(
            f"histogram shapes differ: {p.shape}, {q.shape}, centres {np.shape(centres)}"
        )
    if not (p.sum() > 0 and q.sum() > 0) or (p < 0).any() or (q < 0).any():
        raise ValueError("histograms must be non-negative with a positive sum")
    p, q = p / p.sum(), q / q.sum()
    return HistogramDistances(
        kl=float(entropy(p + _EPS, q + _EPS)),
        js=float(jensenshannon(p, q, base=2)),
        emd=float(wasserstein_distance(centres, centres, p, q)),
    )


def intensity_centres() -> np.ndarray:
    return (INTENSITY_EDGES_DB[:-1] + INTENSITY_EDGES_DB[1:]) / 2.0


def lbp_centres() -> np.ndarray:
    return np.arange(LBP_BINS, dtype=np.float64)
