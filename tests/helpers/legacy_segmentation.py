"""The improved Otsu TSM front end as it was before the OpenCV-speed rewrite (issue 16
item 3), kept verbatim as a second implementation: the tests check that today's
:func:`slam.frontend.segmentation.improved_otsu` gives the same thresholds, N_a, masks and
regions, and ``undersea bench frontend`` times both in one run."""

from __future__ import annotations

import cv2
import numpy as np

from slam.frontend.segmentation import Region, SegmentationParams
from slam.frontend.segmentation.otsu import (
    gray_histogram,
    otsu_threshold,
    otsu_threshold_hist,
    power_law,
)
from slam.frontend.segmentation.regions import bridge_lut

_GRAD_SCALE = 16000.0
_DIFF_X = np.array([[-0.5, 0.5], [-0.5, 0.5]], dtype=np.float32)
_DIFF_Y = np.array([[-0.5, -0.5], [0.5, 0.5]], dtype=np.float32)
_SQUARE3 = np.ones((3, 3), dtype=np.uint8)
_BIT_WEIGHTS = (2 ** np.arange(9, dtype=np.int16)).reshape(3, 3)


def _cc_stats(m):
    return cv2.connectedComponentsWithStatsWithAlgorithm(m, 8, cv2.CV_32S, cv2.CCL_BBDT)


def _as_u8(mask):
    m = np.asarray(mask)
    if m.dtype == np.uint8:
        return (m > 0).astype(np.uint8) if m.max(initial=0) > 1 else np.ascontiguousarray(m)
    return np.ascontiguousarray(m != 0, dtype=np.uint8)


def canny_edges(binary, high, low_ratio=0.4, sigma=0.5, ksize=3):
    f = np.asarray(binary, dtype=np.float32)
    g = cv2.GaussianBlur(f, (ksize, ksize), sigma, borderType=cv2.BORDER_REPLICATE)
    dx = cv2.filter2D(g, cv2.CV_32F, _DIFF_X, anchor=(0, 0), borderType=cv2.BORDER_REPLICATE)
    dy = cv2.filter2D(g, cv2.CV_32F, _DIFF_Y, anchor=(0, 0), borderType=cv2.BORDER_REPLICATE)
    mag = cv2.magnitude(dx, dy)
    mmax = float(mag.max())
    if mmax <= 0.0:
        return np.zeros(f.shape, dtype=np.uint8)
    scale = _GRAD_SCALE / mmax
    dxi = np.rint(dx * scale).astype(np.int16)
    dyi = np.rint(dy * scale).astype(np.int16)
    return cv2.Canny(dxi, dyi, low_ratio * high * _GRAD_SCALE, high * _GRAD_SCALE, L2gradient=True)


def count_small_contours(edges, a_px):
    e = np.asarray(edges)
    if not e.any():
        return 0
    _, _, stats, _ = _cc_stats(e if e.dtype == np.uint8 else (e > 0).astype(np.uint8))
    return int(np.count_nonzero(stats[1:, cv2.CC_STAT_AREA] < a_px))


def remove_small_components(mask, a_px):
    m = _as_u8(mask)
    if a_px <= 1:
        return m
    _n, labels, stats, _ = _cc_stats(m)
    keep = stats[:, cv2.CC_STAT_AREA] >= a_px
    keep[0] = False
    if keep[1:].all():
        return m
    return keep.astype(np.uint8)[labels]


def bridge(mask):
    m = _as_u8(mask)
    code = cv2.filter2D(
        m, cv2.CV_16S, _BIT_WEIGHTS.astype(np.float32), borderType=cv2.BORDER_CONSTANT
    )
    return bridge_lut().view(np.uint8)[code]


def fill_holes(mask):
    m = _as_u8(mask)
    h, w = m.shape
    padded = np.zeros((h + 2, w + 2), dtype=np.uint8)
    padded[1:-1, 1:-1] = m
    cv2.floodFill(padded, None, (0, 0), 2, flags=4)
    return (padded[1:-1, 1:-1] != 2).astype(np.uint8)


def morphology_chain(mask, a_px, dilate_iterations=1):
    m = remove_small_components(mask, a_px)
    if not m.any():
        return m
    m = bridge(m)
    if dilate_iterations > 0:
        m = cv2.dilate(m, _SQUARE3, iterations=int(dilate_iterations))
    return fill_holes(m)


def extract_regions(mask):
    m = _as_u8(mask)
    n, labels, stats, centroids = _cc_stats(m)
    if n <= 1:
        return (), labels
    flat = np.flatnonzero(m)
    lab = labels.ravel()[flat]
    rows, cols = np.divmod(flat, m.shape[1])
    area = stats[:, cv2.CC_STAT_AREA].astype(np.float64)
    area_div = np.maximum(area, 1.0)
    cx = centroids[:, 0]
    cy = centroids[:, 1]
    dx = cols - cx[lab]
    dy = rows - cy[lab]
    sxx = np.bincount(lab, weights=dx * dx, minlength=n) / area_div
    syy = np.bincount(lab, weights=dy * dy, minlength=n) / area_div
    sxy = np.bincount(lab, weights=dx * dy, minlength=n) / area_div
    half_tr = 0.5 * (sxx + syy)
    disc = np.sqrt(np.maximum(0.25 * (sxx - syy) ** 2 + sxy**2, 0.0))
    lam1 = half_tr + disc
    lam2 = np.maximum(half_tr - disc, 0.0)
    major = 4.0 * np.sqrt(lam1)
    minor = 4.0 * np.sqrt(lam2)
    x0 = stats[:, cv2.CC_STAT_LEFT]
    y0 = stats[:, cv2.CC_STAT_TOP]
    bw = stats[:, cv2.CC_STAT_WIDTH]
    bh = stats[:, cv2.CC_STAT_HEIGHT]
    regions = tuple(
        Region(
            label=k,
            area_px=int(area[k]),
            centroid_rc=(float(cy[k]), float(cx[k])),
            bbox=(int(y0[k]), int(x0[k]), int(y0[k] + bh[k]), int(x0[k] + bw[k])),
            major_axis_px=float(major[k]),
            minor_axis_px=float(minor[k]),
        )
        for k in range(1, n)
    )
    return regions, labels


def legacy_improved_otsu(gray8: np.ndarray, p: SegmentationParams) -> dict:
    """Thresholds, N_a, binary, mask, labels and regions of the pre-rewrite pipeline for a
    non-constant ``uint8`` image."""
    y = power_law(gray8, p.power_c, p.power_r)
    t = otsu_threshold(y)
    b = y > t
    edges = canny_edges(b, p.canny_high, p.canny_low_ratio, p.gaussian_sigma, p.gaussian_ksize)
    n_a = count_small_contours(edges, p.a_px)
    t_star = t
    if n_a > p.n_max:
        ts, _ = otsu_threshold_hist(gray_histogram(y), lo=t + 1) if t < 255 else (t, 0.0)
        t_star = ts if ts > t else t
        b = y > t_star
    mask = morphology_chain(b, p.a_px, p.dilate_iterations)
    regions, labels = extract_regions(mask)
    return {
        "threshold": t,
        "threshold_star": t_star,
        "n_small_contours": n_a,
        "edges": edges,
        "binary": b,
        "mask": mask.astype(bool),
        "labels": labels,
        "regions": regions,
    }
