"""FLS recordings (.npy polar frames + JSON sidecar) through the pipeline (slam.fls_slam,
``undersea sss-slam FILE.npy``): a small generated recording with one target at a known
place, a bare-seabed recording, and the sidecar's errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sim.cli.main import main
from slam.fls_slam import load_fls_recording

DR_DB = 50.0
N_BINS, N_BEAMS, R_MIN, R_MAX, FOV_DEG = 256, 128, 0.5, 30.0, 90.0
BIN = (R_MAX - R_MIN) / N_BINS
RANGES = R_MIN + (np.arange(N_BINS) + 0.5) * BIN
BEARINGS_DEG = (0.5 - (np.arange(N_BEAMS) + 0.5) / N_BEAMS) * FOV_DEG
TARGET = np.array([20.0, 4.0])  # world m (x east, y north), local frame of frame 0


def _frame(rng, target_rb=None):
    """Log-compressed polar frame: speckle over a seabed falling 20 dB across the range,
    no return nearer than 12 m, optionally a 15 dB patch (6 bins x 4 beams) at target."""
    level = 10 ** (-2.0 * (RANGES - 12.0) / (R_MAX - 12.0))
    inten = rng.exponential(1.0, (N_BINS, N_BEAMS)) * level[:, None]
    if target_rb is not None:
        i = int(np.argmin(np.abs(RANGES - target_rb[0])))
        j = int(np.argmin(np.abs(np.radians(BEARINGS_DEG) - target_rb[1])))
        inten[i - 3 : i + 3, j - 2 : j + 2] *= 10**1.5
    img = np.clip((10 * np.log10(np.maximum(inten, 1e-12)) + 30.0) / DR_DB, 0.0, 1.0)
    img[RANGES < 12.0, :] = 0.0
    return img.astype(np.float32)


def write_recording(path, rng, n=14, target=True):
    """Vehicle heading east (heading 90 deg) at 0.5 m/s, 5 frames/s, positions in metres
    about (1000, 500); frames seeing TARGET (relative to the first position)."""
    x = 0.1 * np.arange(n)
    frames = []
    for k in range(n):
        d = TARGET - [x[k], 0.0]
        rb = (float(np.hypot(*d)), float(math.atan2(d[1], d[0]))) if target else None
        frames.append(_frame(rng, rb))
    np.save(path, np.stack(frames))
    side = {
        "kind": "fls",
        "ranges_m": RANGES.tolist(),
        "bearings_deg": BEARINGS_DEG.tolist(),
        "beamwidth_deg": 1.0,
        "log_compressed": True,
        "dynamic_range_db": DR_DB,
        "time_s": (0.2 * np.arange(n)).tolist(),
        "altitude_m": None,
        "nav": {
            "x": (1000.0 + x).tolist(),
            "y": [500.0] * n,
            "heading_deg": [90.0] * n,
        },
    }
    path.with_suffix(".json").write_text(json.dumps(side))
    return path


def _run(path, capsys):
    code = main(["sss-slam", str(path), "--nav-units", "metres", "--json"])
    out = capsys.readouterr()
    return code, out


def test_target_becomes_a_landmark_at_its_place(tmp_path, rng, capsys):
    """Independent expectation: the patch is drawn at TARGET in the local frame (the
    first frame's position); a landmark must lie within 1 m (cell 0.12 m x 0.7 deg,
    patch 0.7 x 2.8 deg) and every confirmed detection too."""
    code, out = _run(write_recording(tmp_path / "rec.npy", rng), capsys)
    assert code == 0, out.err
    s = json.loads(out.out)
    assert s["frames"] == 14 and s["observations"] >= 1
    lm = np.array(s["landmarks_m"]).reshape(-1, 2)
    assert len(lm) >= 1 and np.min(np.hypot(*(lm - TARGET).T)) < 1.0
    det = np.array([d["world_xy_nav_m"] for d in s["detections"]])
    assert len(det) >= 3 and np.max(np.hypot(*(det - TARGET).T)) < 1.0


def test_bare_seabed_gives_no_landmark(tmp_path, rng, capsys):
    code, out = _run(write_recording(tmp_path / "bare.npy", rng, target=False), capsys)
    assert code == 0, out.err
    assert json.loads(out.out)["landmarks_m"] == []


def test_sidecar_errors_name_file_and_field(tmp_path, rng, capsys):
    p = write_recording(tmp_path / "rec.npy", rng, n=3)
    side = json.loads(p.with_suffix(".json").read_text())
    p.with_suffix(".json").write_text(
        json.dumps({**side, "bearings_deg": side["bearings_deg"][:-1]})
    )
    with pytest.raises(ValueError, match="bearings_deg"):
        load_fls_recording(p)
    del side["nav"]
    p.with_suffix(".json").write_text(json.dumps(side))
    code, out = _run(p, capsys)
    assert code == 2 and "'nav'" in out.err and "rec.json" in out.err
    p.with_suffix(".json").unlink()
    code, out = _run(p, capsys)
    assert code == 2 and "sidecar" in out.err
