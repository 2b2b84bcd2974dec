"""Objects cut by the tile edge: the data frame of a zero-padded tile, Algorithm 2 on the
reflected binary image against the whole object processed then cut, and the detection
chain's ``frame_padding`` / ``reflect_px`` options on hand-built tiles."""

from __future__ import annotations

import numpy as np
import pytest

from slam.frontend.segmentation.detector import DetectorConfig, detect
from slam.frontend.segmentation.regions import extract_regions, morphology_chain
from slam.frontend.segmentation.tile_edges import (
    algorithm2_reflected,
    data_frame,
    shift_regions,
    touches_edge,
)


def test_data_frame_excludes_zero_padding_rows_and_columns():
    img = np.full((100, 120), 40, np.uint8)
    img[70:, :] = 0
    img[:, :9] = 1  # <= level 2: padding too
    img[30, 5] = 0  # a dark pixel inside the padded columns changes nothing
    rows, cols = data_frame(img)
    assert (rows.start, rows.stop, cols.start, cols.stop) == (0, 70, 9, 120)
    rows, cols = data_frame(np.zeros((5, 7), np.uint8))
    assert (rows.start, rows.stop, cols.start, cols.stop) == (0, 5, 0, 7)
    with pytest.raises(ValueError, match="level=300"):
        data_frame(img, level=300)


def disc(shape, centre_rc, radius):
    r, c = np.ogrid[: shape[0], : shape[1]]
    return (r - centre_rc[0]) ** 2 + (c - centre_rc[1]) ** 2 <= radius**2


@pytest.mark.parametrize("side", ["left", "top"])
def test_reflected_algorithm2_equals_whole_object_cut(side):
    """A ring (outer radius 12, inner 8) and a 4 x 5 blob, both symmetric about column 40
    of a wide image: Algorithm 2 on the whole image, then the columns from 40 on, equals
    Algorithm 2 with reflection on the tile cut at column 40 (the mirror line is the
    edge pixel), and the ring's hole is filled. Plain Algorithm 2 on the cut tile leaves
    the half-hole open to the edge (its 8-radius half-disc not filled) and drops the cut
    blob (4 x 3 = 12 px < a = 14)."""
    h, w, a = 90, 120, 14
    whole = disc((h, w), (30, 40), 12) & ~disc((h, w), (30, 40), 8)
    whole[70:74, 38:43] = True
    hole = disc((h, w), (30, 40), 7)

    def tile(a):  # the tile: columns from 40 on (rows from 40 on for "top")
        return a[:, 40:] if side == "left" else np.ascontiguousarray(a.T[40:, :])

    cut = tile(whole)
    ref = tile(morphology_chain(whole.astype(np.uint8), a, 1))
    hole = tile(hole)
    regions, labels = algorithm2_reflected(cut, a, 1, 16)
    assert np.array_equal(labels > 0, ref > 0)
    assert (labels[hole] > 0).all()
    plain_regions, plain = extract_regions(morphology_chain(cut.astype(np.uint8), a, 1))
    assert not (plain[hole] > 0).all()
    assert len(regions) == 2 and len(plain_regions) == 1
    assert touches_edge(regions, labels.shape).all()


def test_reflection_zero_is_algorithm2_and_bad_width_named():
    rng = np.random.default_rng(3)
    b = rng.random((60, 70)) > 0.7
    regions, labels = algorithm2_reflected(b, 14, 1, 0)
    ref_regions, ref = extract_regions(morphology_chain(b.astype(np.uint8), 14, 1))
    assert regions == ref_regions and np.array_equal(labels, ref)
    with pytest.raises(ValueError, match="reflect_px=-2"):
        algorithm2_reflected(b, 14, 1, -2)
    with pytest.raises(ValueError, match="reflect_px=-1"):
        DetectorConfig(reflect_px=-1)


def padded_tile(rng):
    """Seabed (level 50) on rows 0–179 of a 256 x 256 tile, rows 180–255 zero padding;
    a bright 10 x 16 object (level 230) on rows 172–179, cut by the end of the data; an
    irregular no-echo patch (a water-column shadow, level 0) inside the data at rows
    40–69, cols 150–189, with a bright 6 x 6 rim touching it."""
    img = np.clip(rng.normal(50, 6, (256, 256)), 3, 255).astype(np.uint8)
    img[180:, :] = 0
    img[172:180, 60:76] = 230
    img[40:70, 150:190] = 0
    img[34:40, 160:166] = 230
    return img


def test_frame_padding_keeps_object_cut_by_the_padding(rng):
    """Rules only (no classifier): by default the object cut by the zero padding touches
    that no-echo area and is dropped; with ``frame_padding`` it is detected, centred on its
    visible pixels (row 175.5, col 67.5 before the 3 x 3 dilation, which adds one row
    above: row 175) in the whole tile's coordinates. The rim touching the no-echo patch
    inside the data is dropped either way."""
    img = padded_tile(rng)
    cfg = DetectorConfig(classifier=None, max_count=0, merge_gap_px=0)
    near = [r for r in detect(img, cfg).landmarks if r.centroid_rc[0] > 150]
    assert near == []
    res = detect(img, cfg.with_(frame_padding=True))
    assert res.labels.shape == img.shape and res.gray8.shape == img.shape
    near = [r for r in res.landmarks if r.centroid_rc[0] > 150]
    assert len(near) == 1
    r0, c0 = near[0].centroid_rc
    assert r0 == pytest.approx(175.0, abs=0.6) and c0 == pytest.approx(67.5, abs=0.6)
    assert near[0].bbox[2] == 180
    assert not any(
        30 <= r.centroid_rc[0] <= 72 and 148 <= r.centroid_rc[1] <= 192 for r in res.landmarks
    )
    assert res.labels[res.labels > 0].size == sum(r.area_px for r in res.regions)


def test_shift_regions_moves_centroid_and_box():
    labels = np.zeros((20, 20), np.int32)
    labels[2:5, 3:9] = 1
    regions, _ = extract_regions(labels > 0)
    (r,) = shift_regions(regions, 10, -3)
    assert r.centroid_rc == pytest.approx((13.0, 2.5)) and r.bbox == (12, 0, 15, 6)
    assert r.area_px == regions[0].area_px


def test_reflection_wider_than_a_thin_frame():
    """A 5-row frame (a tile that is mostly padding) with 16 px of reflection, more than
    the frame is high: a 3 x 4 blob (12 px < a = 14) cut by the bottom edge is completed
    by its mirror (rows 2–6, 20 px) and kept; plain Algorithm 2 drops it; the output keeps
    the frame's shape."""
    b = np.zeros((5, 40), bool)
    b[2:5, 10:14] = True
    regions, labels = algorithm2_reflected(b, 14, 1, 16)
    assert labels.shape == (5, 40) and len(regions) == 1 and regions[0].bbox[2] == 5
    assert algorithm2_reflected(b, 14, 1, 0)[0] == ()


def test_detect_with_reflection_keeps_a_small_cut_object():
    """A flat seabed (level 50) with one bright 3 x 4 blob (12 px < a = 14) cut by the top
    edge: Algorithm 2 alone leaves no region, so the chain without reflection detects
    nothing; with ``reflect_px`` the blob, completed by its mirror, is one detection at
    the top edge."""
    img = np.full((128, 128), 50, np.uint8)
    img[0:3, 60:64] = 230
    cfg = DetectorConfig(classifier=None, max_count=0, merge_gap_px=0)
    assert detect(img, cfg).landmarks == ()
    (r,) = detect(img, cfg.with_(reflect_px=16)).landmarks
    assert r.bbox[0] == 0 and 59 <= r.centroid_rc[1] <= 64
