"""``undersea segment`` end to end on the copied SDVD tiles and on a synthetic image."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from sim.cli.main import main

TILES = Path(__file__).resolve().parents[2] / "data" / "sdvd"


def test_segment_json_with_masks_and_overlay(tmp_path, capsys):
    """Four effigy tiles with their masks: JSON has thresholds, landmarks, a confusion
    matrix per image and a summary whose hit rate equals the per-image hits."""
    images = sorted((TILES / "positive" / "images").glob("*.png"))
    out_dir = tmp_path / "ov"
    rc = main(
        [
            "segment",
            *map(str, images),
            "--preset",
            "sdvd",
            "--masks",
            str(TILES / "positive" / "masks"),
            "--merge-components",
            "--filter",
            "sdvd",
            "--overlay",
            str(out_dir),
            "--json",
        ]
    )
    assert rc == 0
    data = json.loads(capsys.readouterr().out)
    recs = data["images"]
    assert len(recs) == 4
    for r in recs:
        assert 0 <= r["threshold"] <= r["threshold_star"] <= 255
        assert r["score"]["confusion_matrix"][0][0] == r["score"]["tp"]
        assert len(r["landmarks"]) == r["n_landmarks"] <= 8
        assert Path(r["overlay"]).is_file()
    assert data["region_filter"]["max_count"] == 8
    hits = sum(r["score"]["images_hit"] for r in recs)
    assert data["summary"]["improved-otsu"]["hit_rate"] == pytest.approx(hits / 4)


def test_segment_text_all_methods(tmp_path, capsys):
    img = np.full((120, 160), 30, np.uint8)
    img[40:70, 60:100] = 230
    p = tmp_path / "square.png"
    cv2.imwrite(str(p), img)
    overlay = tmp_path / "o.png"
    assert main(["segment", str(p), "--preset", "low-res-sss", "--overlay", str(overlay)]) == 0
    out = capsys.readouterr().out
    assert "improved-otsu" in out and "landmark x=" in out
    assert overlay.is_file()
    assert main(["segment", str(p), "--method", "all", "--preset", "low-res-sss"]) == 0
    out = capsys.readouterr().out
    for m in ("otsu", "local", "isodata", "kapur"):
        assert f"[{m}," in out


def test_segment_errors(tmp_path, capsys):
    """Missing file, missing mask and a mask of another shape: exit code 2 and a message."""
    assert main(["segment", str(tmp_path / "none.png")]) == 2
    img = np.zeros((20, 20), np.uint8)
    p = tmp_path / "a.png"
    cv2.imwrite(str(p), img)
    masks = tmp_path / "m"
    masks.mkdir()
    assert main(["segment", str(p), "--masks", str(masks)]) == 2
    assert "no mask" in capsys.readouterr().err
    cv2.imwrite(str(masks / "a.png"), np.zeros((21, 20), np.uint8))
    assert main(["segment", str(p), "--masks", str(masks)]) == 2
    assert "differs from the image shape" in capsys.readouterr().err
    assert main(["segment", str(p), "--max-elongation", "0.5"]) == 2
