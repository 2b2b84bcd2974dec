"""Image quality metrics for intensity normalization (thesis Ch. 4.1.4–4.1.5).

* :func:`ssim` — Structural Similarity (eqs. 4.7–4.11) through
  ``skimage.metrics.structural_similarity`` (no re-implementation).
* :func:`siqem` — Sonar Image Quality assessment Metric (eqs. 4.12–4.13), written here
  (no library has it): split the image into M×N patches, μ_mn = patch mean,
  C_mn = max over the 8-neighbour patches k of (μ_mn − μ_k) / μ_mn (Weber contrast),
  SIQEM = mean of C_mn. Lower is better (more uniform illumination).

SIQEM is scale invariant (a ratio), so raw, DCP and MIRA images compare directly.
"""

from __future__ import annotations

import numpy as np

from slam.io.images import as_grey_float


def ssim(a: np.ndarray, b: np.ndarray, *, data_range: float | None = None) -> float:
    """SSIM between two equally shaped grey images (scikit-image, 7×7 window defaults).

    ``data_range`` defaults to the joint max − min of both images. Raises ValueError on
    shape mismatch, images smaller than 7×7, or a zero data range (both constant and equal
    → returns 1.0 instead, the documented result for identical constant patches).
    """
    from skimage.metrics import structural_similarity

    x = as_grey_float(a, name="a").astype(np.float64)
    y = as_grey_float(b, name="b").astype(np.float64)
    if x.shape != y.shape:
        raise ValueError(f"SSIM images must have the same shape, got {x.shape} and {y.shape}")
    if min(x.shape) < 7:
        raise ValueError(f"SSIM needs images of at least 7×7 pixels, got {x.shape}")
    if data_range is None:
        data_range = float(max(x.max(), y.max()) - min(x.min(), y.min()))
    if data_range <= 0:
        if np.array_equal(x, y):
            return 1.0
        raise ValueError(f"SSIM data_range must be > 0, got {data_range}")
    return float(structural_similarity(x, y, data_range=data_range))


def patch_means(
    image: np.ndarray, patch: tuple[int, int], mask: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(M, N) patch means over non-overlapping ``patch`` = (rows, cols) tiles (the partial
    last row/column of tiles is dropped) and the (M, N) fraction of each tile inside
    ``mask`` (all ones without a mask)."""
    img = as_grey_float(image, name="image").astype(np.float64)
    ph, pw = int(patch[0]), int(patch[1])
    if ph < 1 or pw < 1:
        raise ValueError(f"patch must be positive (rows, cols), got {patch}")
    m, n = img.shape[0] // ph, img.shape[1] // pw
    if m < 2 or n < 2:
        raise ValueError(
            f"SIQEM needs at least 2×2 patches: image {img.shape} with patch {patch} gives {m}×{n}"
        )
    tiles = img[: m * ph, : n * pw].reshape(m, ph, n, pw)
    mu = tiles.mean(axis=(1, 3))
    if mask is None:
        frac = np.ones_like(mu)
    else:
        mk = np.asarray(mask, dtype=bool)
        if mk.shape != img.shape:
            raise ValueError(f"mask shape {mk.shape} differs from image shape {img.shape}")
        frac = mk[: m * ph, : n * pw].reshape(m, ph, n, pw).mean(axis=(1, 3))
    return mu, frac


def siqem_map(
    mu: np.ndarray, valid: np.ndarray | None = None, *, absolute: bool = False
) -> np.ndarray:
    """C_mn of eq. 4.12 for a grid of patch means (NaN where undefined).

    Neighbours are the 8-connected patches inside the grid (and ``valid``). A patch with
    μ ≤ 0 or no valid neighbour gets NaN. ``absolute=True`` uses |μ_mn − μ_k| (a variant;
    the thesis prints the signed difference, the default).
    """
    mu = np.asarray(mu, dtype=np.float64)
    ok = np.ones(mu.shape, bool) if valid is None else np.asarray(valid, bool)
    padded = np.pad(np.where(ok, mu, np.nan), 1, constant_values=np.nan)
    m, n = mu.shape
    diffs = []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == 0 and dc == 0:
                continue
            nb = padded[1 + dr : 1 + dr + m, 1 + dc : 1 + dc + n]
            diffs.append(mu - nb)
    d = np.stack(diffs)
    if absolute:
        d = np.abs(d)
    has_nb = np.any(np.isfinite(d), axis=0)
    dmax = np.max(np.where(np.isfinite(d), d, -np.inf), axis=0)
    good = ok & has_nb & (mu > 0)
    return np.where(good, dmax / np.where(good, mu, 1.0), np.nan)


def siqem(
    image: np.ndarray,
    *,
    patch: tuple[int, int] = (32, 32),
    mask: np.ndarray | None = None,
    min_coverage: float = 0.5,
    absolute: bool = False,
) -> float:
    """SIQEM of eqs. 4.12–4.13 (lower = more uniform).

    Parameters
    ----------
    image : 2-D grey image (any positive scale).
    patch : patch size in pixels (rows, cols); the thesis does not state one.
    mask : optional boolean image of the pixels to evaluate (e.g. seabed only, excluding
        the water column); patches with less than ``min_coverage`` of their pixels inside
        are left out, as are patches with mean ≤ 0.
    absolute : see :func:`siqem_map`.

    Raises ValueError when no patch is usable (e.g. an all-zero image); a constant
    positive image gives 0.0.
    """
    mu, frac = patch_means(image, patch, mask)
    c = siqem_map(mu, frac >= min_coverage, absolute=absolute)
    if not np.any(np.isfinite(c)):
        raise ValueError(
            "SIQEM undefined: no patch with positive mean and a valid neighbour "
            "(all-zero image or empty mask?)"
        )
    return float(np.nanmean(c))
