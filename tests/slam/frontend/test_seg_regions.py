"""Algorithm 2 morphology chain and region properties against hand-computed cases and
second implementations (scikit-image / SciPy)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage
from skimage.measure import label, regionprops
from skimage.morphology import remove_small_objects

from slam.frontend.segmentation import (
    Region,
    RegionFilter,
    bridge,
    bridge_lut,
    extract_regions,
    fill_holes,
    morphology_chain,
    remove_small_components,
)


def test_bridge_lut_has_119_patterns():
    """GNU Octave's image package documents 119 3×3 patterns that make bwmorph 'bridge'
    set a 0 pixel to 1 (MATLAB-compatible); the table built from the rule has 119 too."""
    lut = bridge_lut()
    centre_on = ((np.arange(512) >> 4) & 1).astype(bool)
    assert lut[centre_on].all()
    assert int(lut[~centre_on].sum()) == 119


def test_bridge_hand_cases():
    """Two pixels separated by one gap are joined; touching pixels are left alone; two
    same-side corners are not bridged (MATLAB's exception)."""
    gap = np.array([[1, 0, 1]], np.uint8)
    assert bridge(gap).tolist() == [[1, 1, 1]]
    touching = np.array([[1, 1, 0]], np.uint8)
    assert bridge(touching).tolist() == [[1, 1, 0]]
    diag = np.array([[1, 0, 0], [0, 0, 0], [0, 0, 1]], np.uint8)
    assert bridge(diag)[1, 1] == 1
    corners = np.zeros((3, 3), np.uint8)
    corners[0, 0] = corners[0, 2] = 1
    # the centre pixel (1,1) sees two same-side corners: not bridged; (0,1) sees them as
    # left/right neighbours: bridged
    out = bridge(corners)
    assert out[1, 1] == 0 and out[0, 1] == 1


def test_remove_small_matches_skimage(rng):
    """bwareaopen with 8-connectivity = skimage remove_small_objects(min_size=a,
    connectivity=2) (which keeps components with >= a pixels)."""
    m = rng.random((120, 130)) > 0.7
    ours = remove_small_components(m, 6).astype(bool)
    ref = remove_small_objects(m, max_size=5, connectivity=2)
    assert np.array_equal(ours, ref)


def test_fill_holes_matches_scipy(rng):
    """imfill 'holes' (4-connected background) = scipy binary_fill_holes with the
    4-connected structure."""
    m = rng.random((90, 80)) > 0.55
    ours = fill_holes(m).astype(bool)
    ref = ndimage.binary_fill_holes(m, structure=ndimage.generate_binary_structure(2, 1))
    assert np.array_equal(ours, ref)


def test_fill_holes_ring():
    m = np.zeros((9, 9), np.uint8)
    m[2:7, 2:7] = 1
    m[4, 4] = 0
    assert fill_holes(m).sum() == 25


def test_chain_removes_small_dilates_once_or_twice():
    """A 10×10 square survives a = 30 and grows by one ring per dilation; a 5-pixel spot
    is removed."""
    m = np.zeros((40, 40), np.uint8)
    m[10:20, 10:20] = 1
    m[30:31, 30:35] = 1
    one = morphology_chain(m, 30, 1)
    two = morphology_chain(m, 30, 2)
    assert one.sum() == 12 * 12 and two.sum() == 14 * 14
    assert one[30, 30] == 0


def test_region_props_match_skimage_regionprops(rng):
    """Area, centroid, bbox and axis lengths equal scikit-image's regionprops."""
    m = ndimage.binary_dilation(rng.random((70, 90)) > 0.93, iterations=2)
    regions, labels = extract_regions(m)
    ref = regionprops(label(m, connectivity=2))
    assert len(regions) == len(ref)
    ours = sorted(regions, key=lambda r: r.centroid_rc)
    ref = sorted(ref, key=lambda r: tuple(r.centroid))
    for a, b in zip(ours, ref, strict=True):
        assert a.area_px == b.area
        assert a.centroid_rc == pytest.approx(tuple(b.centroid), abs=1e-9)
        assert a.bbox == tuple(b.bbox)
        assert a.major_axis_px == pytest.approx(b.axis_major_length, rel=1e-6, abs=1e-9)
        assert a.minor_axis_px == pytest.approx(b.axis_minor_length, rel=1e-6, abs=1e-6)
    assert labels.max() == len(regions)


def test_region_filter_area_shape_count():
    """A filter keeps regions by area, elongation and the largest-first count limit."""

    def reg(label, area, major, minor):
        return Region(label, area, (0.0, 0.0), (0, 0, 1, 1), major, minor)

    regs = (reg(1, 50, 10, 9), reg(2, 500, 60, 10), reg(3, 5000, 90, 80), reg(4, 300, 20, 18))
    f = RegionFilter(min_area_px=40, max_area_px=1000, max_elongation=4.0)
    assert [r.label for r in f.apply(regs)] == [1, 4]
    top1 = RegionFilter(max_count=1)
    assert [r.label for r in top1.apply(regs)] == [3]
    assert RegionFilter().is_identity
    assert reg(5, 10, 5, 0).elongation == math.inf
    with pytest.raises(ValueError, match="max_elongation"):
        RegionFilter(max_elongation=0.5)
    with pytest.raises(ValueError, match="max_area_px"):
        RegionFilter(min_area_px=10, max_area_px=5)
