"""Artefact masks: burned-in annotations, no-echo areas and the first-return edge, on
hand-built images with known answers and on the real SDVD tiles and Scotsman XTF."""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from slam.frontend.segmentation import load_gray8, load_mask
from slam.frontend.segmentation.artefacts import (
    annotation_mask,
    drop_first_return_edge,
    first_return_edge_mask,
    mask_annotations,
    no_echo_mask,
    regions_outside,
)
from slam.frontend.segmentation.fragments import merge_fragments


def seabed(rng, shape=(128, 128), level=50.0):
    return np.clip(rng.normal(level, 12.0, shape), 0, 255).astype(np.uint8)


def draw_scale_bar(img, r0=20, c0=70):
    """A black 14 x 34 box with white "10M" text and a white tick line below it, flanked
    by black, as the SDVD tiles carry."""
    img[r0 : r0 + 14, c0 : c0 + 34] = 3
    cv2.putText(img, "10M", (c0 + 3, r0 + 11), cv2.FONT_HERSHEY_PLAIN, 0.7, 255, 1)
    img[r0 + 14 : r0 + 34, c0 + 13 : c0 + 18] = 2
    img[r0 + 14 : r0 + 34, c0 + 15] = 255
    return (slice(r0, r0 + 34), slice(c0, c0 + 34))


def test_scale_bar_masked_object_with_shadow_kept(rng):
    """The scale bar's strokes are masked (>= 95 % of its bright pixels; the box around
    them too); a bright 6 x 10 object with a dark shadow on one side (a real target's
    look) and bright speckle on seabed are not."""
    img = seabed(rng)
    box = draw_scale_bar(img)
    img[80:86, 30:40] = 250  # object
    img[80:86, 14:30] = 5  # its shadow, far range to the left
    img[100, 100] = img[60, 20] = 255  # speckle
    m = annotation_mask(img)
    strokes = (img >= 200) & np.zeros_like(img, bool)
    strokes[box] = img[box] >= 200
    assert m[strokes].mean() >= 0.95
    assert m[20:34, 70:104].mean() >= 0.7  # most of the text box
    assert not m[78:88, 28:42].any()
    assert not m[100, 100] and not m[60, 20]
    out, m2 = mask_annotations(img)
    assert np.array_equal(m, m2)
    assert np.all(out[m] == np.median(img[~m][img[~m] > 0]).astype(np.uint8))
    assert np.array_equal(out[~m], img[~m])


def test_no_echo_mask_and_region_suppression(rng):
    """A zero-padded band of 30 rows is no-echo (grown by the margin); a 5 x 5 dark
    shadow is not; a region touching the band is dropped, one far from it kept."""
    img = seabed(rng)
    img[-30:, :] = 0
    img[40:45, 40:45] = 0
    m = no_echo_mask(img, margin_px=3)
    assert m[-33:, :].all() and not m[:-33, :].any()
    labels = np.zeros(img.shape, np.int32)
    labels[90:96, 10:20] = 1  # touches row 95 (inside the grown band)
    labels[20:26, 60:70] = 2
    regions, labels = merge_fragments(labels, 0)
    kept = regions_outside(regions, labels, m)
    assert [r.label for r in kept] == [2] or [r.centroid_rc[0] for r in kept] == [22.5]


def test_merge_fragments_bridges_gaps_up_to_gap_px():
    """Fragments 4 px apart merge with gap 4, not with gap 3; the merged region keeps the
    fragment pixels only (area 2 × 20, centroid their mean, bbox the union)."""
    lab = np.zeros((30, 40), np.int32)
    lab[10:14, 5:10] = 1  # cols 5..9
    lab[10:14, 14:19] = 2  # cols 14..18: 4 background columns between
    regs3, _ = merge_fragments(lab, 3)
    assert len(regs3) == 2
    regs4, merged = merge_fragments(lab, 4)
    assert len(regs4) == 1
    r = regs4[0]
    assert r.area_px == 40 and r.bbox == (10, 5, 14, 19)
    assert r.centroid_rc == pytest.approx((11.5, 11.5))
    assert int(merged.max()) == 1 and int((merged > 0).sum()) == 40


#: positive tiles that carry a "10 M" scale bar (checked by eye)
SCALE_BAR_TILES = (
    "left_20240429094643H_sample_1_tile_17.png",
    "left_20240429101938H_sample_1_tile_1.png",
    "left_20240429102030L_sample_1_tile_1.png",
    "left_20240429102030L_sample_2_tile_5.png",
)


def test_real_sdvd_scale_bars_masked_effigies_not(shared_data):
    """On the real positive tiles: the tiles known to carry a scale bar get a mask of at
    least 300 px (the box is 15 x 57 px), and no mask covers more than 5 % of an effigy."""
    d = shared_data / "sdvd" / "positive"
    for f in sorted((d / "images").iterdir()):
        img = load_gray8(f)
        eff = load_mask(d / "masks" / f.name, img.shape)
        m = annotation_mask(img)
        assert (m & eff).sum() <= 0.05 * eff.sum(), f.name
        if f.name in SCALE_BAR_TILES:
            assert m.sum() >= 300, f.name


def test_scotsman_first_return_edge(shared_data):
    """Real XTF: the symmetric detections at ping 442 (slant 3.94 m port, 3.96 m
    starboard; the pipeline's spurious landmark) fall on the first-return edge; the wreck's
    detections (starboard, ping 230 at 7.90 m and ping 278 at 12.50 m) and the seabed blob
    at ping 414 do not. The edge sits at the water column's end: past the first return the
    median level is several times the water column's."""
    from slam.io.xtf import read_xtf

    wf = read_xtf(shared_data / "xtf" / "scotsman-iver2.xtf")
    mask = first_return_edge_mask(wf)
    assert mask.shape == wf.intensity.shape
    dets = [
        SimpleNamespace(ping=230, side="starboard", slant_range=7.905),
        SimpleNamespace(ping=278, side="starboard", slant_range=12.498),
        SimpleNamespace(ping=414, side="starboard", slant_range=13.422),
        SimpleNamespace(ping=442, side="port", slant_range=3.936),
        SimpleNamespace(ping=442, side="starboard", slant_range=3.960),
    ]
    kept = drop_first_return_edge(dets, wf)
    assert [(d.ping, d.side) for d in kept] == [
        (230, "starboard"),
        (278, "starboard"),
        (414, "starboard"),
    ]
    s = wf.samples_per_side
    stbd = wf.intensity[:, s:].astype(float)
    inside = mask[:, s:]
    water = np.median(stbd[:, 10:60])
    past = np.median(stbd[~inside])
    assert past > 3.0 * water


def test_first_return_edge_from_altitude_by_hand():
    """Slant 0.1 m per sample; altitude 1.0 m -> the first 10 samples (centres 0.05..0.95 m)
    are water, plus max(8, ceil(0.3 * 10) = 3) = 8 samples of margin: 18 per side."""
    from slam.frontend.segmentation.artefacts import first_return_edge_from_altitude

    slant = (np.arange(50) + 0.5) * 0.1
    m = first_return_edge_from_altitude(np.array([1.0, 3.0]), slant)
    assert m.shape == (2, 100)
    assert m[0, 50:].sum() == 18 and m[0, 50:68].all() and m[0, :50].sum() == 18
    assert m[1, 50:].sum() == 30 + 9  # 30 water samples + ceil(0.3 * 30)
    assert np.array_equal(m[:, :50], m[:, 50:][:, ::-1])
    with pytest.raises(ValueError, match="margin_fraction"):
        first_return_edge_from_altitude(np.ones(2), slant, margin_fraction=2.0)


def test_mirrored_across_nadir_pairs_only_opposite_sides_at_one_range():
    from slam.frontend.segmentation.artefacts import mirrored_across_nadir

    ping = np.array([10, 11, 10, 50, 50, 80])
    port = np.array([True, False, False, True, True, False])
    slant = np.array([4.0, 4.2, 9.0, 6.0, 6.0, 6.0])
    # 0/1: opposite sides, 1 ping apart, 5 % apart; 3/4 same side; 5 alone (30 pings away)
    assert mirrored_across_nadir(ping, port, slant).tolist() == [True, True, False, False, False, False]
    with pytest.raises(ValueError, match="sizes"):
        mirrored_across_nadir(ping, port, slant[:2])
