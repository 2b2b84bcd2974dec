"""Issue 15's CLI probes, each reproduced: --version, help text, bad input on stderr with
exit 2, strict JSON, a closed stdout, unwritable outputs, a corrupt file in a batch, the
demo's options, progress when stdout is not a terminal."""

from __future__ import annotations

import importlib.metadata
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from sim.cli.main import COMMANDS, main

REPO = Path(__file__).resolve().parents[2]


def _strict_json(text: str):
    """json.loads that refuses NaN/Infinity (the JSON standard), unlike Python's default."""

    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    return json.loads(text, parse_constant=refuse)


def _undersea(*args, **kw) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO), "CI": "1"}
    return subprocess.run(
        [sys.executable, "-m", "sim.cli.main", *args],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        **kw,
    )


def _waterfall_png(path: Path, rng) -> None:
    img = rng.rayleigh(40.0, (96, 128))
    cv2.imwrite(str(path), np.clip(img, 0, 255).astype(np.uint8))


def test_version_is_the_installed_package_version(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"undersea {importlib.metadata.version('undersea')}"


def test_top_level_help_describes_every_command(capsys):
    """Each command's line in `undersea --help` carries its one-line help."""
    assert main([]) == 2
    out = "".join(capsys.readouterr().out.split())  # argparse wraps lines (also at hyphens)
    for name, command in COMMANDS.items():
        assert "".join(command.help.split()) in out, name
    assert "(see: undersea" not in out


def test_nan_option_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["uwsn", "--sigma", "nan"])
    assert exc.value.code == 2
    cap = capsys.readouterr()
    assert "--sigma" in cap.err and "finite" in cap.err and cap.out == ""


def test_run_into_an_unwritable_place_is_exit_2(capsys):
    assert main(["run", "shipwreck-survey", "--out", "/proc/x", "--duration", "1"]) == 2
    cap = capsys.readouterr()
    assert "'/proc/x'" in cap.err and "Traceback" not in cap.err and cap.out == ""


def test_sweep_with_an_unknown_key_is_exit_2_and_runs_nothing(tmp_path, capsys):
    out = tmp_path / "sw"
    rc = main(
        ["sweep", "shipwreck-survey", "--runs", "1", "--vary", "bogus.key=1", "--out", str(out)]
    )
    assert rc == 2
    cap = capsys.readouterr()
    assert "'bogus'" in cap.err and cap.out == ""
    assert not out.exists()


def test_match_json_is_valid_json_when_nothing_matches(tmp_path, capsys):
    """Two featureless images: no transform, so rotation and scale are not available —
    null in JSON, never a bare NaN."""
    for name in ("a.png", "b.png"):
        cv2.imwrite(str(tmp_path / name), np.full((64, 64), 90, np.uint8))
    assert main(["match", str(tmp_path / "a.png"), str(tmp_path / "b.png"), "--json"]) == 0
    text = capsys.readouterr().out
    doc = _strict_json(text)
    assert doc["matched"] is False
    assert any(v is None for v in doc.values())  # the NaNs became null


def test_closed_stdout_ends_quietly():
    """`undersea uwsn --json | head -c0`: the reader is gone before the command writes;
    no BrokenPipeError traceback, and the SIGPIPE-like exit code 141."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.cli.main", "uwsn", "--nodes", "200", "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
    )
    proc.stdout.close()  # before the interpreter has even imported the command
    err = proc.stderr.read().decode()
    rc = proc.wait(timeout=120)
    assert "Traceback" not in err and "BrokenPipeError" not in err, err
    assert rc == 141


@pytest.mark.parametrize("option", ["--out", "--compare"])
def test_normalize_output_in_a_missing_folder_is_exit_2(tmp_path, rng, capsys, option):
    src = tmp_path / "wf.png"
    _waterfall_png(src, rng)
    target = tmp_path / "missing_dir" / "x.png"
    assert main(["normalize", str(src), option, str(target)]) == 2
    cap = capsys.readouterr()
    assert option in cap.err and "does not exist" in cap.err and cap.out == ""
    assert not target.exists()


def test_normalize_json_is_strict(tmp_path, rng, capsys):
    src = tmp_path / "wf.png"
    _waterfall_png(src, rng)
    assert main(["normalize", str(src), "--method", "none", "--json"]) == 0
    doc = _strict_json(capsys.readouterr().out)
    assert doc["shape"] == [96, 128]


def test_segment_reports_the_corrupt_file_and_keeps_the_good_one(tmp_path, rng, capsys):
    good, bad = tmp_path / "good.png", tmp_path / "corrupt.png"
    img = np.full((64, 64), 30, np.uint8)
    img[20:40, 20:40] = 220
    cv2.imwrite(str(good), img)
    bad.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(rng.integers(0, 256, 64, dtype=np.uint8)))
    overlays = tmp_path / "ov"
    rc = main(["segment", str(good), str(bad), "--overlay", str(overlays), "--json"])
    cap = capsys.readouterr()
    assert rc == 2
    assert "corrupt.png" in cap.err and "good.png" not in cap.err
    doc = _strict_json(cap.out)
    assert [r["image"] for r in doc["images"]] == [str(good)]
    assert [f["image"] for f in doc["failed"]] == [str(bad)]
    assert (overlays / "good_improved-otsu.png").is_file()


def test_demo_help_states_its_defaults(capsys):
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "default: runs/demo" in out
    assert "--overwrite" in out and "refuse" in out and "--full" in out


def test_demo_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "demo"
    out.mkdir()
    (out / "metrics.json").write_text("{}")
    assert main(["demo", "--out", str(out), "--no-progress"]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "metrics.json").read_text() == "{}"


def test_demo_default_is_short_and_full_is_the_whole_survey():
    """The quick demo is a 60 s cut of the survey file; --full is the file's whole survey
    (450 s: the lawnmower and its tie line), read here from the TOML itself."""
    import tomllib
    from pathlib import Path

    from sim.cli.run_cmd import DEFAULT_SCENARIO, DEMO_OVERRIDES
    from sim.scenario import load_scenario

    quick = load_scenario(DEFAULT_SCENARIO, overrides=DEMO_OVERRIDES)
    full = load_scenario(DEFAULT_SCENARIO)
    toml = Path(__file__).parents[2] / "assets" / "scenarios" / f"{DEFAULT_SCENARIO}.toml"
    file_duration = tomllib.loads(toml.read_text())["duration_s"]
    assert quick.duration_s <= 60.0 < full.duration_s == file_duration == 450.0
    # the quick survey still passes the wreck within the side-scan's 40 m range
    wreck = next(o for o in quick.world.objects if o.cls == "shipwreck")
    start = np.array(quick.vehicles[0].start_position[:2])
    travelled = quick.vehicles[0].mission.speed_mps * quick.duration_s
    assert start[0] < wreck.position[0] < start[0] + travelled
    assert abs(wreck.position[1] - start[1]) < 40.0


def test_progress_lines_when_not_a_terminal(monkeypatch):
    """Not a TTY: one plain line per 5 wall seconds and one at the end (a fake clock
    advancing 1 s per update over 23 updates: lines at 5, 10, 15, 20 s and the end)."""
    from sim.runner.progress import LineProgress, make_progress

    monkeypatch.setattr(sys, "stderr", io.StringIO())
    assert isinstance(make_progress("x", 10.0, None), LineProgress)
    assert make_progress("x", 10.0, False) is None
    clock = iter(range(100))
    stream = io.StringIO()
    p = LineProgress("demo", 23.0, every_s=5.0, stream=stream, clock=lambda: float(next(clock)))
    for t in range(1, 24):
        p.update(float(t))
    lines = stream.getvalue().splitlines()
    assert len(lines) == 5 and p.lines == 5
    assert lines[0].startswith("demo: 5.0/23.0 sim s (22%), RTF 1.00")
    assert lines[-1].startswith("demo: 23.0/23.0 sim s (100%)")


def test_uwsn_nan_end_to_end_exit_code_and_stderr():
    """The same probe as a user runs it: a separate process, exit 2, nothing on stdout."""
    r = _undersea("uwsn", "--sigma", "nan")
    assert r.returncode == 2 and r.stdout == "" and "Traceback" not in r.stderr
