"""``undersea realism``: the table, strict JSON, the figure and exit code 2 on bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

import sim.viz.rerun_log as L
from sim.cli.main import main
from sim.cli.realism_io import PREPARED_DB, load_rrd_waterfall, parse_pings


def _waterfall(rng, seabed, wc_samples=64, p=96, s=256):
    sides = []
    for _ in range(2):
        wc = rng.exponential(1e-3, (p, wc_samples))
        sides.append(np.concatenate([wc, seabed((p, s - wc_samples))], axis=1))
    return np.concatenate([sides[0][:, ::-1], sides[1]], axis=1).astype(np.float32)


@pytest.fixture
def files(tmp_path, rng):
    ray = tmp_path / "rayleigh.npy"
    np.save(ray, _waterfall(rng, lambda sh: rng.exponential(1.0, sh)))
    k = tmp_path / "k.npz"
    tex = lambda sh: rng.gamma(1.0, 1.0, sh) * rng.exponential(1.0, sh)  # noqa: E731
    np.savez(k, intensity=_waterfall(rng, tex))
    return ray, k


def test_json_is_strict_and_a_file_against_itself_is_at_distance_zero(files, capsys):
    ray, _ = files
    assert main(["realism", str(ray), str(ray), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["comparison"]["all_within"] is True
    for d in doc["comparison"]["distances"].values():
        assert d["lbp"]["js"] == pytest.approx(0.0, abs=1e-6)
        assert d["intensity"]["emd"] == pytest.approx(0.0, abs=1e-9)
    cv = doc["sim"]["statistics"]["port"]["cv_amplitude"]
    assert cv == pytest.approx(np.sqrt(4 / np.pi - 1), rel=0.05)  # Rayleigh


def test_k_clutter_against_rayleigh_fails_the_cv_row_and_writes_a_figure(files, capsys, tmp_path):
    """K with nu = 1 has amplitude CV 0.76 (analytic), far outside 10 % of Rayleigh's 0.52."""
    ray, k = files
    png = tmp_path / "fig.png"
    assert main(["realism", str(k), str(ray), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    cv_line = next(line for line in out.splitlines() if line.startswith("speckle CV"))
    assert cv_line.rstrip().endswith("nn")
    assert "all within issue-11 tolerances (texture JS < 0.1): no" in out
    assert png.stat().st_size > 10_000


def test_nan_statistic_becomes_null(tmp_path, rng, capsys):
    """A water column of 16 samples (twice the guard) leaves no water-column sample: null."""
    f = tmp_path / "nowc.npy"
    np.save(f, _waterfall(rng, lambda sh: rng.exponential(1.0, sh), wc_samples=16))
    assert main(["realism", str(f), str(f), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["sim"]["statistics"]["port"]["water_column_db"] is None


@pytest.mark.parametrize(
    "array, message",
    [
        (np.ones((10, 512)), "too short"),
        (np.ones((128, 7)), "even width"),
        (None, "no seabed"),
    ],
)
def test_bad_input_exits_2_with_a_message(tmp_path, rng, capsys, files, array, message):
    ray, _ = files
    bad = tmp_path / "bad.npy"
    np.save(bad, rng.exponential(1.0, (128, 512)) if array is None else array)
    assert main(["realism", str(bad), str(ray)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.startswith("undersea realism: ")


def test_unknown_suffix_and_bad_ping_range_exit_2(tmp_path, files, capsys):
    ray, _ = files
    txt = tmp_path / "x.txt"
    txt.write_text("1 2")
    assert main(["realism", str(txt), str(ray)]) == 2
    assert "unknown recording type" in capsys.readouterr().err
    assert main(["realism", str(ray), str(ray), "--real-pings", "50:10"]) == 2
    assert "outside" in capsys.readouterr().err


def test_parse_pings_halves():
    assert parse_pings("first", 461) == slice(0, 230)
    assert parse_pings("second", 461) == slice(230, 461)
    assert parse_pings(":100", 461) == slice(0, 100)


def test_rrd_windows_decode_by_one_fixed_mapping(tmp_path, rng):
    """Two windows in dB, 17 dB apart, logged as the runner does (fixed PREPARED_DB span):
    they come back stacked, each within half a grey step (30/255/2 dB) of its own level
    clipped to the span: no per-window rescaling (a 17-dB step stays a 17-dB step)."""
    path = tmp_path / "recording.rrd"
    rec = L.open_recording(path)
    wins = [rng.normal(m, 3.0, (8, 32)).astype(np.float32) for m in (-2.0, 15.0)]
    for i, w in enumerate(wins):
        L.set_time(rec, float(i))
        L.log_sonar_image(rec, "auv", "sss", w, db_span=PREPARED_DB)
    L.close_recording(rec)
    got = load_rrd_waterfall(tmp_path)  # the run directory
    assert got.intensity.shape == (16, 32) and got.kind == "rrd"
    step = (PREPARED_DB[1] - PREPARED_DB[0]) / 255
    for i, w in enumerate(wins):
        dec = 10 * np.log10(got.intensity[8 * i : 8 * (i + 1)])
        ref = np.clip(w, *PREPARED_DB)
        assert np.abs(dec - ref).max() <= step / 2 + 1e-6
