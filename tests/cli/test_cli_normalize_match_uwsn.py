"""CLI commands normalize / match / uwsn on small generated inputs."""

from __future__ import annotations

import json

import cv2
import numpy as np

from sim.cli.main import main


def _waterfall_png(path, rng):
    z = np.arange(128.0)
    decay = 200.0 * np.exp(-z / 60.0) + 40.0
    img = rng.rayleigh(0.8, (64, 256)) * np.concatenate([decay[::-1], decay])[None, :]
    cv2.imwrite(str(path), np.clip(img, 0, 255).astype(np.uint8))


def test_normalize_json_and_png(tmp_path, rng, capsys):
    """MIRA lowers SIQEM on a decaying waterfall; the PNG has the waterfall's shape."""
    src = tmp_path / "wf.png"
    _waterfall_png(src, rng)
    out = tmp_path / "n.png"
    assert (
        main(
            [
                "normalize",
                str(src),
                "--method",
                "mira",
                "--average",
                "9",
                "--patch",
                "16",
                "--out",
                str(out),
                "--json",
            ]
        )
        == 0
    )
    rep = json.loads(capsys.readouterr().out)
    assert rep["siqem_after"] < rep["siqem_before"]
    assert cv2.imread(str(out), cv2.IMREAD_UNCHANGED).shape == (64, 256)


def test_normalize_bad_file_exit_code(tmp_path, capsys):
    bad = tmp_path / "x.xtf"
    bad.write_bytes(b"nope")
    assert main(["normalize", str(bad)]) == 2
    assert "not an XTF" in capsys.readouterr().err


def test_match_and_uwsn_json(tmp_path, rng, capsys):
    img = (cv2.GaussianBlur(rng.normal(size=(160, 160)), (0, 0), 2.0) * 60 + 128).clip(0, 255)
    img = img.astype(np.uint8)
    m = cv2.getRotationMatrix2D((80, 80), 90, 1.0)
    cv2.imwrite(str(tmp_path / "a.png"), img)
    cv2.imwrite(str(tmp_path / "b.png"), cv2.warpAffine(img, m, (160, 160)))
    assert main(["match", str(tmp_path / "a.png"), str(tmp_path / "b.png"), "--json"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["matched"] and abs(rep["rotation_deg"] - 90) < 1.0
    assert main(["uwsn", "--seed", "3", "--json", "--plot", str(tmp_path / "u.png")]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert abs(rep["comm_range_m"] - 447.2) < 0.1 and rep["matched"]
    assert rep["translation_error_m"] < 2.0
    assert (tmp_path / "u.png").stat().st_size > 0
