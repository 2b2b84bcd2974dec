"""scripts/check_viewer_browser.py (issue 15, item 5): `undersea view RUN --web` opened in
headless Chromium shows the recording (world 3-D view, sonar view, metric plots) with no
error. The end-to-end check needs Debian's Chromium at /usr/bin/chromium and is skipped
with a message without it; the helpers it judges by are tested here on known inputs."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from script_module import load_script

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "scripts" / "check_viewer_browser.py"
C = load_script("check_viewer_browser")


def test_views_of_the_default_blueprint_read_back(tmp_path):
    """The runner's default blueprint, saved by rerun, reads back as a 3-D world view, one
    2-D view per sonar and a time-series view per vehicle; a blueprint without the sonar
    view is reported as lacking it."""
    import rerun.blueprint as rrb

    from sim.viz.rerun_log import default_blueprint

    path = tmp_path / "bp.rrd"
    default_blueprint({"alister9": ["sss"]}).save("undersea", str(path))
    views = C.rrd_views(path)
    assert sorted(views) == [
        ("2D", "alister9 sss", "world/alister9/sonar/sss"),
        ("3D", "world", "world"),
        ("TimeSeries", "alister9 metrics", "metrics/alister9"),
    ]
    assert C.views_missing(views) == []
    rrb.Blueprint(rrb.Spatial3DView(origin="world", name="world")).save("u", str(path))
    assert C.views_missing(C.rrd_views(path)) == ["sonar image view", "metrics plot"]


def test_error_badge_found_and_orange_note_ignored():
    """A filled red circle of badge size is found at its centre; an orange note, a red
    line and a large red area are not badges."""
    import cv2

    img = np.full((400, 600, 3), 250, np.uint8)
    cv2.circle(img, (500, 30), 7, (80, 20, 225), -1)  # BGR red badge
    cv2.circle(img, (100, 30), 7, (0, 140, 245), -1)  # orange note
    cv2.line(img, (50, 200), (550, 200), (80, 20, 225), 2)  # a red plot line
    cv2.rectangle(img, (300, 250), (500, 390), (80, 20, 225), -1)  # a red object
    assert C.error_badges(img) == [(500, 30)]


def test_pane_structure_flat_and_textured():
    """A flat screenshot has no structure in any pane; noise in the world pane only shows
    there."""
    img = np.full((1000, 1600, 3), 240, np.uint8)
    flat = C.pane_structure(img, 2)
    assert set(flat) == {"world 3-D view", "sonar view 1", "metrics plot"}
    assert max(flat.values()) == 0.0
    img[:, :900] = np.random.default_rng(0).integers(0, 255, (1000, 900, 3), dtype=np.uint8)
    tex = C.pane_structure(img, 2)
    assert tex["world 3-D view"] > 30 and tex["sonar view 1"] == tex["metrics plot"] == 0.0


@pytest.mark.slow
def test_viewer_in_headless_chromium(tmp_path):
    """A short scenario run, served by `undersea view --web` and opened in Chromium: the
    script's checks all pass and its screenshot is written."""
    if not Path(C.CHROMIUM).is_file():
        pytest.skip(f"{C.CHROMIUM} not installed (apt-get install chromium): browser check skipped")
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = tmp_path / "run"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "sim.cli.main",
            "run",
            "shipwreck-survey",
            "--duration",
            "11",
            "--out",
            str(run),
            "--no-progress",
        ],
        check=True,
        env=env,
        capture_output=True,
    )
    shot = tmp_path / "viewer.png"
    res = subprocess.run(
        [sys.executable, str(SCRIPT), str(run), "--screenshot", str(shot), "--timeout", "900"],
        env=env,
        capture_output=True,
        text=True,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    assert shot.stat().st_size > 10_000
