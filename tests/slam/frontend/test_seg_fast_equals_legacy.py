"""The OpenCV-speed improved Otsu front end (issue 16 item 3) against the pre-rewrite
implementation kept in ``tests/helpers/legacy_segmentation.py``: the same T, T*, N_a,
Canny edges, binary image, mask, label image and regions, on synthetic side-scan images
of the thesis's three sizes, random masks of every density, and real SDVD tiles."""

from __future__ import annotations

import sys
from pathlib import Path

import legacy_segmentation as legacy
import numpy as np
import pytest

from slam.frontend.segmentation import (
    bridge,
    canny_edges,
    count_small_contours,
    extract_regions,
    fill_holes,
    get_preset,
    improved_otsu,
    load_gray8,
    remove_small_components,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
from bench_frontend import synthetic_sss


def _assert_same(img: np.ndarray, preset: str) -> None:
    p = get_preset(preset, img.shape)
    new = improved_otsu(img, p)
    old = legacy.legacy_improved_otsu(img, p)
    assert new.threshold == old["threshold"]
    assert new.threshold_star == old["threshold_star"]
    assert new.n_small_contours == old["n_small_contours"]
    assert np.array_equal(new.binary, old["binary"])
    assert np.array_equal(new.mask, old["mask"])
    assert np.array_equal(new.labels, old["labels"])
    assert new.regions == old["regions"]


@pytest.mark.parametrize(
    ("shape", "preset"),
    [((800, 800), "high-res-sss"), ((228, 417), "low-res-sss"), ((932, 1920), "fls")],
)
@pytest.mark.parametrize("seed", [0, 1])
def test_improved_otsu_same_as_legacy_on_synthetic_sss(shape, preset, seed):
    _assert_same(synthetic_sss(shape, np.random.default_rng(seed)), preset)


@pytest.mark.parametrize("density", [0.02, 0.2, 0.5, 0.8, 0.98])
def test_stages_same_as_legacy_on_random_masks(density, rng):
    m = rng.random((97, 131)) < density
    for high in (0.1, 0.33):
        e_new = canny_edges(m, high)
        assert np.array_equal(e_new, legacy.canny_edges(m, high))
        assert count_small_contours(e_new, 14) == legacy.count_small_contours(e_new, 14)
    assert np.array_equal(remove_small_components(m, 5), legacy.remove_small_components(m, 5))
    assert np.array_equal(bridge(m), legacy.bridge(m))
    assert np.array_equal(fill_holes(m), legacy.fill_holes(m))
    regions, labels = extract_regions(m)  # many regions: the whole-image moment sums
    ref_regions, ref_labels = legacy.extract_regions(m)
    assert regions == ref_regions and np.array_equal(labels, ref_labels)


def test_few_regions_moments_bit_identical(rng):
    """Up to 64 regions the second moments are summed per bounding box: the same floats
    as the whole-image sums (blobs of random shapes, some touching the border)."""
    m = np.zeros((300, 400), bool)
    for _ in range(30):
        r, c = rng.integers(0, 290), rng.integers(0, 390)
        m[r : r + rng.integers(2, 30), c : c + rng.integers(2, 30)] |= rng.random() < 0.9
    m &= rng.random(m.shape) < 0.85
    regions, _ = extract_regions(m)
    assert 0 < len(regions) <= 64
    assert regions == legacy.extract_regions(m)[0]


@pytest.mark.parametrize("dtype", [np.uint8, np.float32, np.float64])
def test_canny_same_as_legacy_on_grey_images(dtype, rng):
    img = (rng.random((120, 90)) * 255).astype(dtype)
    assert np.array_equal(canny_edges(img, 0.2), legacy.canny_edges(img, 0.2))


def test_count_small_contours_many_labels_falls_back_to_int32():
    """More than 65535 components: uint16 labels overflow, the int32 path gives the count
    (every isolated pixel is one component smaller than a = 2)."""
    e = np.zeros((600, 600), np.uint8)
    e[::2, ::2] = 255
    assert count_small_contours(e, 2) == 300 * 300


def test_improved_otsu_same_as_legacy_on_real_tiles(shared_data):
    d = shared_data / "sdvd"
    files = sorted((d / "positive" / "images").iterdir())[::15]
    files += sorted((d / "negative" / "images").iterdir())[::15]
    assert len(files) >= 10
    for f in files:
        _assert_same(load_gray8(f), "sdvd")
