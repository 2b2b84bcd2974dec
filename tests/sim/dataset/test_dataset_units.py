"""Dataset pieces without simulation: shard seeds and plan, polygon masks, settings checks."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pycocotools import mask as mask_utils
from scipy import ndimage

from sim.dataset import DatasetConfig, plan_dataset, shard_seeds
from sim.dataset.coco import CATEGORY_ID, instance_annotations


def test_shard_seed_k_does_not_depend_on_shard_count():
    """Child k of SeedSequence(seed) has spawn key (k,): the same for any n."""
    assert shard_seeds(7, 5)[:2] == shard_seeds(7, 2)
    assert len(set(shard_seeds(7, 50))) == 50
    assert shard_seeds(7, 3) != shard_seeds(8, 3)


def test_plan_covers_frames_once_with_offsets_inside_the_mission():
    """Shards tile [0, N) without gaps; offsets rise from 0 and leave room for the shard."""
    cfg = DatasetConfig("shipwreck-survey", frames=50, shard_frames=16, kind="sss", tile_pings=64)
    jobs = plan_dataset(cfg)
    assert [j.n_frames for j in jobs] == [16, 16, 16, 2]
    assert [j.first_frame for j in jobs] == [0, 16, 32, 48]
    offs = [j.offset_s for j in jobs]
    assert offs[0] == 0 and offs == sorted(offs)
    # deepeye680d pings at 14 Hz: a 64-ping tile takes 64/14 s; the scenario lasts 420 s
    for j in jobs:
        assert j.offset_s + j.n_frames * 64 / 14 <= 420 + 1e-6
    assert len({j.settings_hash for j in jobs}) == 1


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_rle_and_polygon_masks_reproduce_random_labels(seed):
    """RLE decodes to labels == k exactly; the pixel-edge polygons rasterise (pycocotools)
    to the same mask with holes filled; bbox = extent."""
    rng = np.random.default_rng(seed)
    H, W = rng.integers(8, 40, 2)
    lab = np.zeros((H, W), np.int32)
    for k in (1, 2, 3):
        r0, c0 = rng.integers(0, H - 2), rng.integers(0, W - 2)
        lab[r0 : r0 + rng.integers(1, 6), c0 : c0 + rng.integers(1, 6)] = k  # rectangles
    cls = {1: "rock", 2: "pipe", 3: "tyre"}
    rle = instance_annotations(lab, cls, "rle")
    poly = instance_annotations(lab, cls, "polygon")
    assert [a["object_id"] for a in rle] == sorted(set(lab[lab > 0].tolist()))
    for a, p in zip(rle, poly):
        want = lab == a["object_id"]
        assert a["category_id"] == CATEGORY_ID[cls[a["object_id"]]]
        np.testing.assert_array_equal(mask_utils.decode(a["segmentation"]).astype(bool), want)
        pm = mask_utils.decode(mask_utils.merge(mask_utils.frPyObjects(p["segmentation"], H, W)))
        # COCO polygons cannot hold holes: the polygon mask is the mask with holes filled
        np.testing.assert_array_equal(pm.astype(bool), ndimage.binary_fill_holes(want))
        rows, cols = np.nonzero(want)
        assert (
            a["bbox"]
            == p["bbox"]
            == [cols.min(), rows.min(), cols.max() - cols.min() + 1, rows.max() - rows.min() + 1]
        )
        assert a["area"] == want.sum()


def test_label_of_unknown_object_is_an_error():
    lab = np.zeros((4, 4), np.int32)
    lab[1, 1] = 9
    with pytest.raises(ValueError, match="label 9"):
        instance_annotations(lab, {1: "rock"})


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("frames", -3, "frames = -3"),
        ("seed", -1, "seed = -1"),
        ("fls_view", "top", "fls_view = 'top'.*polar, fan, both"),
        ("fls_interval_s", 0.0, "fls_interval_s = 0.0"),
        ("shard_frames", 0, "shard_frames = 0"),
        ("segmentation", "mask", "segmentation = 'mask'.*rle, polygon"),
    ],
)
def test_settings_name_field_value_and_allowed(field, value, match):
    kw = {"frames": 2, field: value}
    with pytest.raises(ValueError, match=match):
        DatasetConfig("shipwreck-survey", **kw)


def test_cli_overrides_are_toml_values():
    """--set values parse as TOML (int, float, bool, list, quoted string), else stay text."""
    from sim.cli.dataset_cmd import parse_overrides

    got = parse_overrides(["a.b=3", "c=0.5", "d=true", "e=[1.0, 2.0]", 'f="x y"', "g=abc"])
    assert got == (
        ("a.b", 3),
        ("c", 0.5),
        ("d", True),
        ("e", [1.0, 2.0]),
        ("f", "x y"),
        ("g", "abc"),
    )
    with pytest.raises(ValueError, match="KEY=VALUE"):
        parse_overrides(["novalue"])
