"""The compiled front-end passes (slam/frontend/segmentation/kernels.py) against the
OpenCV and NumPy calls they replace: N_a against ``cv2.Canny`` on the same gradients and
``cv2.connectedComponentsWithStats``, the small-component removal against the component
areas, hole filling against ``cv2.floodFill``, the moment sums against ``np.bincount``;
on random masks of every density and size, on synthetic side-scan images and on real
SDVD tiles."""

from __future__ import annotations

import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from slam.frontend.segmentation import get_preset, load_gray8
from slam.frontend.segmentation.kernels import (
    GRAD_SCALE,
    fill_holes_u8,
    otsu_from_hist,
    remove_small_components_u8,
    second_moment_sums,
    small_edge_objects,
)
from slam.frontend.segmentation.methods import _above, smoothed_gradients
from slam.frontend.segmentation.otsu import gray_histogram, otsu_threshold, power_law

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
from bench_frontend import synthetic_sss


def _opencv_n_a(dx, dy, high, low_ratio, a_px) -> int:
    """N_a by OpenCV on the same gradients: int16 scaling, Canny, component areas."""
    mmax = cv2.minMaxLoc(cv2.magnitude(dx, dy))[1]
    if mmax <= 0.0:
        return 0
    s = GRAD_SCALE / mmax
    dxi = cv2.multiply(dx, s, dtype=cv2.CV_16S)
    dyi = cv2.multiply(dy, s, dtype=cv2.CV_16S)
    e = cv2.Canny(dxi, dyi, low_ratio * high * GRAD_SCALE, high * GRAD_SCALE, L2gradient=True)
    _, _, stats, _ = cv2.connectedComponentsWithStats((e > 0).astype(np.uint8), connectivity=8)
    return int(np.count_nonzero(stats[1:, cv2.CC_STAT_AREA] < a_px))


def _opencv_remove_small(m, a_px):
    _, labels, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= a_px
    keep[0] = False
    return keep.astype(np.uint8)[labels]


def _opencv_fill_holes(m):
    padded = np.pad(m, 1)
    cv2.floodFill(padded, None, (0, 0), 2, flags=4)
    return (padded[1:-1, 1:-1] != 2).astype(np.uint8)


def test_n_a_equals_opencv_on_random_masks(rng):
    for _ in range(150):
        h, w = (int(v) for v in rng.integers(1, 90, 2))
        m = (rng.random((h, w)) < rng.uniform(0.0, 1.0)).astype(np.uint8)
        high = float(rng.choice([0.1, 0.13, 0.33, rng.uniform(0.05, 1.0)]))
        a = int(rng.integers(1, 40))
        dx, dy = smoothed_gradients(m)
        assert small_edge_objects(dx, dy, high, 0.4, a) == _opencv_n_a(dx, dy, high, 0.4, a)


@pytest.mark.parametrize(
    ("shape", "preset"), [((400, 400), "high-res-sss"), ((228, 417), "low-res-sss")]
)
def test_n_a_equals_opencv_on_synthetic_sss(shape, preset, rng):
    p = get_preset(preset)
    y = power_law(synthetic_sss(shape, rng), p.power_c, p.power_r)
    for t in (otsu_threshold(y), otsu_threshold(y) + 20):
        dx, dy = smoothed_gradients(_above(y, t), p.gaussian_sigma, p.gaussian_ksize)
        n_a = small_edge_objects(dx, dy, p.canny_high, p.canny_low_ratio, p.a_px)
        assert n_a == _opencv_n_a(dx, dy, p.canny_high, p.canny_low_ratio, p.a_px)
        assert n_a > 0


def test_n_a_of_an_empty_image_is_zero():
    dx, dy = smoothed_gradients(np.zeros((20, 30), np.uint8))
    assert small_edge_objects(dx, dy, 0.33, 0.4, 30) == 0


def test_morphology_kernels_equal_opencv_on_random_masks(rng):
    for _ in range(300):
        h, w = (int(v) for v in rng.integers(1, 70, 2))
        m = (rng.random((h, w)) < rng.uniform(0.0, 1.0)).astype(np.uint8)
        a = int(rng.integers(2, 30))
        assert np.array_equal(remove_small_components_u8(m, a), _opencv_remove_small(m, a))
        assert np.array_equal(fill_holes_u8(m), _opencv_fill_holes(m))


def test_fill_holes_nested_rings_and_diagonal_gaps():
    m = np.zeros((11, 11), np.uint8)
    m[1:10, 1:10] = 1
    m[2:9, 2:9] = 0
    m[3:8, 3:8] = 1
    m[4:7, 4:7] = 0  # hole inside a ring inside a hole
    d = np.eye(5, dtype=np.uint8)[::-1] | np.eye(5, dtype=np.uint8)  # 8-connected "X"
    out = fill_holes_u8(m)
    assert out[2:9, 2:9].all() and out[0].sum() == 0  # both holes filled, outside kept
    assert np.array_equal(fill_holes_u8(d), _opencv_fill_holes(d))


def test_second_moment_sums_equal_bincount(rng):
    """Both summation orders: inside each bounding box (a few regions) and over the
    whole image (a frame whose box is the image, so the boxes cover more than it)."""
    m = (rng.random((120, 150)) < 0.3).astype(np.uint8)
    framed = m.copy()
    framed[0, :] = framed[-1, :] = framed[:, 0] = framed[:, -1] = 1
    few = np.zeros_like(m)
    few[10:40, 20:90] = m[10:40, 20:90] | (rng.random((30, 70)) < 0.5)
    for img in (framed, few):
        n, labels, stats, cen = cv2.connectedComponentsWithStats(img, connectivity=8)
        sums = second_moment_sums(labels, cen[:, 0], cen[:, 1], n, stats)
        _assert_bincount(img, labels, cen, n, sums)


def _assert_bincount(m, labels, cen, n, sums):
    sxx, syy, sxy = sums
    flat = np.flatnonzero(m)
    lab = labels.ravel()[flat]
    rows, cols = np.divmod(flat, m.shape[1])
    dx, dy = cols - cen[lab, 0], rows - cen[lab, 1]
    assert np.array_equal(sxx, np.bincount(lab, weights=dx * dx, minlength=n))
    assert np.array_equal(syy, np.bincount(lab, weights=dy * dy, minlength=n))
    assert np.array_equal(sxy, np.bincount(lab, weights=dx * dy, minlength=n))


def test_kernels_equal_opencv_on_real_sdvd_tiles(shared_data):
    files = sorted((shared_data / "sdvd" / "positive" / "images").iterdir())[:12]
    assert files, "no SDVD tiles"
    p = get_preset("sdvd")
    for f in files:
        y = power_law(load_gray8(f), p.power_c, p.power_r)
        assert otsu_from_hist(gray_histogram(y)) == otsu_threshold(y)
        b = _above(y, otsu_threshold(y))
        dx, dy = smoothed_gradients(b, p.gaussian_sigma, p.gaussian_ksize)
        n_a = small_edge_objects(dx, dy, p.canny_high, p.canny_low_ratio, p.a_px)
        assert n_a == _opencv_n_a(dx, dy, p.canny_high, p.canny_low_ratio, p.a_px)
        assert np.array_equal(
            remove_small_components_u8(b, p.a_px), _opencv_remove_small(b, p.a_px)
        )
        assert np.array_equal(fill_holes_u8(b), _opencv_fill_holes(b))


def test_otsu_from_hist_equals_opencv(rng):
    for t in range(600):
        h, w = (int(v) for v in rng.integers(1, 60, 2))
        if t % 3 == 0:
            img = rng.integers(0, 256, (h, w))
        elif t % 3 == 1:
            img = rng.normal(rng.uniform(0, 255), rng.uniform(1, 60), (h, w))
        else:
            img = rng.rayleigh(rng.uniform(5, 60), (h, w))
        img = np.clip(img, 0, 255).astype(np.uint8)
        assert otsu_from_hist(gray_histogram(img)) == otsu_threshold(img)
    y = power_law(synthetic_sss((932, 1920), rng))
    assert otsu_from_hist(gray_histogram(y)) == otsu_threshold(y)
