"""Real side-scan tiles (SDVD effigy, ODbL): the copied tiles always, the full set of
../shared/data/sdvd when present. Expectations come from the ground-truth masks and the
issue's targets (effigy found in >= 80 % of positive tiles, PPV above max entropy)."""

from __future__ import annotations

from pathlib import Path

import pytest

from slam.frontend.segmentation import (
    get_region_filter,
    improved_otsu,
    score_result,
    segment_filtered,
)
from slam.frontend.segmentation.evaluation import evaluate, load_sdvd, sdvd_split

TILES = Path(__file__).resolve().parents[2] / "data" / "sdvd"


@pytest.fixture(scope="module")
def copied_tiles():
    return load_sdvd(TILES)


def test_copied_tiles_load_with_licence(copied_tiles):
    """4 effigy tiles with non-empty masks and 2 negatives, all from the held-out half,
    shipped with the dataset's licence and citation."""
    assert sum(t.positive for t in copied_tiles) == 4
    assert sum(not t.positive for t in copied_tiles) == 2
    assert all(t.split == "test" for t in copied_tiles)
    assert all(t.mask.any() for t in copied_tiles if t.positive)
    assert all(t.image.shape == (256, 256) for t in copied_tiles)
    assert (TILES / "LICENSE.txt").is_file() and (TILES / "CITATION.cff").is_file()


def test_improved_otsu_finds_effigy_in_copied_tiles(copied_tiles):
    """On each copied positive tile a landmark centroid lies inside the effigy mask."""
    rf = get_region_filter("sdvd")
    for t in (t for t in copied_tiles if t.positive):
        res = improved_otsu(t.image, "sdvd", rf)
        assert res.threshold_star >= res.threshold, t.name
        s = score_result(res, t.mask, merge_components=True)
        assert s.images_hit == 1, t.name


def test_split_is_by_recording_group():
    """H and L channels of one pass (timestamps 1 s apart, same minute) share a half."""
    a = sdvd_split("left_20240429111838L_sample_2_tile_13.png", True)
    b = sdvd_split("left_20240429111839H_sample_2_tile_13.png", True)
    assert a == b
    assert sdvd_split("3_15.jpg", False) == sdvd_split("3_99.jpg", False)


def test_full_sdvd_set_meets_targets(shared_data):
    """All 135 positive + 85 negative tiles, preset 'sdvd' (size rule) and the 'sdvd'
    region filter for both methods: improved Otsu finds the effigy in >= 80 % of positive
    tiles and its PPV is above the maximum-entropy baseline's."""
    root = shared_data / "sdvd"
    if not root.is_dir():
        pytest.skip("../shared/data/sdvd not present")
    tiles = load_sdvd(root)
    assert sum(t.positive for t in tiles) == 135 and sum(not t.positive for t in tiles) == 85
    rf = get_region_filter("sdvd")
    io = evaluate(tiles, "improved-otsu", "sdvd", rf)
    kapur = evaluate(tiles, "kapur", "sdvd", rf)
    assert io.hit_rate >= 0.80
    assert io.all.ppv > kapur.all.ppv
    assert io.hit_rate > kapur.hit_rate


@pytest.mark.parametrize("filter_name", ["sdvd-contrast", "sdvd-shadow"])
def test_copied_tiles_side_scan_filters_keep_effigy(copied_tiles, filter_name):
    """The side-scan detection filters (contrast, shadow) keep the effigy landmark on each
    copied positive tile (masks are the independent truth)."""
    rf = get_region_filter(filter_name)
    for t in (t for t in copied_tiles if t.positive):
        res = segment_filtered(t.image, "improved-otsu", "sdvd", rf)
        s = score_result(res, t.mask, merge_components=True)
        assert s.images_hit == 1, (filter_name, t.name)


@pytest.mark.parametrize("filter_name", ["sdvd-contrast", "sdvd-shadow"])
def test_full_sdvd_set_side_scan_filters(shared_data, filter_name):
    """Presets chosen on the tune half only, the same filter for both methods. Full set:
    improved Otsu still finds the effigy in >= 80 % of positive tiles (issue target), its
    PPV is above max entropy's on the full set AND on the held-out test half, and the
    negatives get "few" detections: <= 2 per negative tile (the 'sdvd' geometry filter
    gives 6.2)."""
    root = shared_data / "sdvd"
    if not root.is_dir():
        pytest.skip("../shared/data/sdvd not present")
    tiles = load_sdvd(root)
    rf = get_region_filter(filter_name)
    io = evaluate(tiles, "improved-otsu", "sdvd", rf)
    kapur = evaluate(tiles, "kapur", "sdvd", rf)
    assert io.hit_rate >= 0.80
    assert io.all.ppv > kapur.all.ppv
    assert io.hit_rate > kapur.hit_rate
    assert io.detections_per_negative <= 2.0
    test = [t for t in tiles if t.split == "test"]
    io_t = evaluate(test, "improved-otsu", "sdvd", rf)
    kapur_t = evaluate(test, "kapur", "sdvd", rf)
    assert io_t.all.ppv > kapur_t.all.ppv
