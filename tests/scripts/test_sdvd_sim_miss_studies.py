"""scripts/sdvd_stage2_sim_study.py and scripts/sdvd_miss_study.py (issue 14): a
simulator dataset written by the test (one 64-ping × 600-sample image, pings 0.1 m apart,
0.04 m range cells, a mannequin and a rock mask in COCO RLE) is resampled to square pixels
(rows × 2.5) and cut into 256-column windows with the mannequin where it was drawn; the
miss study names the stage that loses a hand-built effigy."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from script_module import load_script

S = load_script("sdvd_stage2_sim_study")
M = load_script("sdvd_miss_study")


@pytest.fixture
def sim_dir(tmp_path):
    from pycocotools import mask as mask_utils

    rng = np.random.default_rng(3)
    img = np.clip(rng.normal(60, 10, (64, 600)), 0, 255).astype(np.uint8)
    eff = np.zeros(img.shape, np.uint8)
    eff[20:30, 300:340] = 1  # mannequin: window 1 (columns 256–511), rows 50–74 after × 2.5
    img[eff > 0] = 230
    rock = np.zeros(img.shape, np.uint8)
    rock[40:50, 100:120] = 1
    img[rock > 0] = 200

    def ann(m, cid):
        rle = mask_utils.encode(np.asfortranarray(m))
        rle["counts"] = rle["counts"].decode()
        return {"category_id": cid, "segmentation": rle, "area": int(m.sum())}

    (tmp_path / "images").mkdir()
    (tmp_path / "meta").mkdir()
    cv2.imwrite(str(tmp_path / "images" / "000001_sss.png"), img)
    meta = {
        "geometry": {
            "ping_pose": {"position": [[0.1 * i, 0.0, -20.0] for i in range(64)]},
            "slant_range_m": [0.04 * (300 - i) for i in range(300)]
            + [0.04 * i for i in range(300)],
            "samples_per_side": 300,
        }
    }
    (tmp_path / "meta" / "000001_sss.json").write_text(json.dumps(meta))
    coco = {
        "images": [
            {
                "id": 1,
                "file_name": "000001_sss.png",
                "meta_file": "meta/000001_sss.json",
                "kind": "sss",
            }
        ],
        "annotations": [{**ann(eff, 3), "image_id": 1}, {**ann(rock, 4), "image_id": 1}],
        "categories": [{"id": 3, "name": "mannequin"}, {"id": 4, "name": "rock"}],
    }
    (tmp_path / "annotations.json").write_text(json.dumps(coco))
    return tmp_path


def test_sim_windows_square_pixels_and_mannequin_mask(sim_dir):
    wins = list(S.sim_windows(sim_dir))
    assert len(wins) == 2  # 600 columns -> two whole 256-column windows
    (img0, eff0), (_img1, eff1) = wins
    assert img0.shape == (160, 256)  # 64 pings × 0.1 m / 0.04 m
    assert not eff0.any()  # the rock is not an effigy
    rows, cols = np.nonzero(eff1)
    assert rows.min() == pytest.approx(50, abs=1) and rows.max() == pytest.approx(74, abs=1)
    assert cols.min() == 300 - 256 and cols.max() == 339 - 256


def test_sim_regions_label_the_mannequin_region(sim_dir):
    x, y, info = S.sim_regions([sim_dir], gap=4)
    assert info["windows"] == 2 and info["windows_with_effigy"] == 1
    assert x.shape == (len(y), 8) and y.sum() == 1


def test_miss_study_names_the_losing_stage(rng):
    """A bright effigy on a dim seabed is hit; the same effigy on a tile whose seabed is
    brighter than it (display-saturated) gets no region centred on it: 'threshold'."""
    from slam.frontend.segmentation.detector import get_detector
    from slam.frontend.segmentation.evaluation import LabelledTile

    mask = np.zeros((256, 256), bool)
    mask[100:112, 60:90] = True
    dim = np.clip(rng.normal(50, 8, (256, 256)), 1, 255).astype(np.uint8)
    dim[mask] = 230
    sat = np.clip(rng.normal(235, 5, (256, 256)), 1, 255).astype(np.uint8)
    sat[mask] = 150
    cfg = get_detector("sdvd-trusted")
    assert M.lost_at(LabelledTile("d", dim, mask, True, "tune"), cfg)["stage"] == "hit"
    assert M.lost_at(LabelledTile("s", sat, mask, True, "tune"), cfg)["stage"] == "threshold"
