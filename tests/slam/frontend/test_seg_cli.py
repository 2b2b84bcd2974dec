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


def test_segment_cli_shadow_filter_far_range(tmp_path, capsys):
    """Synthetic seabed (100) with two 10×10 highlights (200), only the left one followed
    by a 30-px shadow (20) towards column 0: with --filter sdvd-shadow --far-range left
    exactly that highlight is reported; the plain 'sdvd' filter reports both."""
    g = np.full((128, 128), 100, dtype=np.uint8)
    g[40:50, 70:80] = 200
    g[40:50, 40:70] = 20
    g[90:100, 60:70] = 200
    path = tmp_path / "scene.png"
    cv2.imwrite(str(path), g)
    base = ["segment", str(path), "--method", "kapur", "--preset", "sdvd", "--json"]
    assert main([*base, "--filter", "sdvd-shadow", "--far-range", "left"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["region_filter"]["far_range"] == "left"
    lms = data["images"][0]["landmarks"]
    assert len(lms) == 1
    x, y = lms[0]["centroid_xy"]
    assert 70 <= x < 80 and 40 <= y < 50
    assert main([*base, "--filter", "sdvd"]) == 0
    assert len(json.loads(capsys.readouterr().out)["images"][0]["landmarks"]) == 2
    with pytest.raises(SystemExit) as exc:
        main([*base, "--filter", "sdvd-shadow", "--far-range", "up"])
    assert exc.value.code == 2
