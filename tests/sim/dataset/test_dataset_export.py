"""`undersea dataset`: masks are the simulator's labels, the COCO file loads with
pycocotools, boxes are mask extents, same seed -> same bytes (also across 2 workers and
Ray), resume after a lost shard, bad input.

The reference for every mask is an independent re-simulation of each shard's frames
(same scenario, shard seed and offset), not the exporter's output; the fan's reference
labels come from the simulator's own ``FLSFrame.cell_of``, pixel by pixel.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from pycocotools import mask as mask_utils
from pycocotools.coco import COCO

from sim.dataset import DatasetConfig, build_dataset, plan_dataset
from sim.dataset.simulate import ShardSimulation, prepare_scenario
from sim.sonar import fan_image

# A tiny scene: a 55 m line past four objects with a small side-scan and a small FLS.
SCENE = """
name = "dataset-test"
description = "tiny scene for dataset tests"
seed = 1
duration_s = 30.0
control_dt = 0.05
[world]
seabed = "flat"
size_m = [80.0, 60.0]
depth_m = 15.0
[[world.objects]]
class = "rock"
position = [-14.0, 6.0]
scale = 2.0
[[world.objects]]
class = "pipe"
position = [-6.0, -7.0]
yaw_deg = 10.0
[[world.objects]]
class = "tyre"
position = [2.0, 7.0]
[[world.objects]]
class = "rock"
position = [6.0, 3.0]
[[vehicles]]
kind = "alister9"
start = { position = [-25.0, 0.0, -9.0], yaw_deg = 0.0 }
[vehicles.mission]
type = "line"
waypoints = [[-25.0, 0.0], [30.0, 0.0]]
speed_mps = 1.5
altitude_m = 6.0
[[vehicles.sonars]]
preset = "deepeye680d"
name = "sss"
overrides = { max_range = 15.0, samples_per_side = 128, ping_rate_hz = 10.0 }
[[vehicles.sonars]]
preset = "blueview_p900_90"
name = "fls"
overrides = { max_range = 15.0, n_bins = 64, n_beams = 48, rays_per_beam = 4, ping_rate_hz = 10.0, tilt_deg = 20.0 }
"""
CLASSES_IN_FILE = ["rock", "pipe", "tyre", "rock"]  # object ids 1..4 in file order


def _cfg(scene: Path, **kw) -> DatasetConfig:
    base = dict(
        frames=6,
        seed=3,
        kind="both",
        tile_pings=16,
        fls_view="both",
        shard_frames=3,
        save_linear=True,
    )
    base.update(kw)
    return DatasetConfig(str(scene), **base)


def _files(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("scene") / "dataset-test.toml"
    p.write_text(SCENE)
    return p


@pytest.fixture(scope="module")
def serial(scene, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("serial")
    res = build_dataset(_cfg(scene), out, workers=1, progress=False)
    assert res.shards_done == [0, 1] and res.n_frames == 6 and res.frames_per_s > 0
    return out


@pytest.fixture(scope="module")
def resim(scene) -> dict:
    """Frame number -> SonarFrame, re-simulated shard by shard from the plan."""
    frames = {}
    for job in plan_dataset(_cfg(scene)):
        sim = ShardSimulation(prepare_scenario(job.scenario, job.seed), ("sss", "fls"), 16, 1.0)
        for fr in sim.frames(job.n_frames, job.offset_s):
            frames[job.first_frame + fr.index + 1] = fr
    return frames


def _reference_labels(fr, view: str) -> np.ndarray:
    """The simulator's labels of one image; the fan's via FLSFrame.cell_of per pixel."""
    if view != "fls-fan":
        return fr.labels
    fan = fan_image(fr.fls)
    out = np.full(fan.image.shape, -1, np.int32)
    for i, j in zip(*np.nonzero(fan.mask)):
        r, b = fan.pixel_to_range_bearing(i, j)
        bi, be = fr.fls.cell_of(float(r), float(b))
        if 0 <= bi < fr.labels.shape[0] and 0 <= be < fr.labels.shape[1]:
            out[i, j] = fr.labels[bi, be]
    return out


def test_masks_are_the_simulators_labels_pixel_exact(serial, resim):
    """Decoded RLE of every annotation == (labels == object id) of the re-simulated frame,
    every labelled object has exactly one annotation, and classes follow the scenario file."""
    coco = json.loads((serial / "annotations.json").read_text())
    anns_by_image: dict[int, list] = {}
    for a in coco["annotations"]:
        anns_by_image.setdefault(a["image_id"], []).append(a)
    n_checked = 0
    for im in coco["images"]:
        lab = _reference_labels(resim[im["frame"]], im["view"])
        assert lab.shape == (im["height"], im["width"])
        anns = anns_by_image.get(im["id"], [])
        assert sorted(a["object_id"] for a in anns) == sorted(set(lab[lab > 0].tolist()))
        for a in anns:
            m = mask_utils.decode(a["segmentation"])
            np.testing.assert_array_equal(m.astype(bool), lab == a["object_id"])
            cat = next(c["name"] for c in coco["categories"] if c["id"] == a["category_id"])
            assert cat == CLASSES_IN_FILE[a["object_id"] - 1]
            n_checked += 1
    # the comparison is not vacuous: several objects, in SSS and both FLS views
    assert n_checked >= 5
    views = {im["view"] for im in coco["images"] if anns_by_image.get(im["id"])}
    assert views == {"sss", "fls-polar", "fls-fan"}


def test_coco_loads_with_pycocotools_and_counts_instances(serial, resim):
    """pycocotools.coco.COCO reads the file; annotations = distinct object ids per image."""
    c = COCO(str(serial / "annotations.json"))
    expected = 0
    for im in c.dataset["images"]:
        lab = _reference_labels(resim[im["frame"]], im["view"])
        expected += len(np.unique(lab[lab > 0]))
    assert len(c.getAnnIds()) == expected > 0
    assert len(c.getImgIds()) == 6 + 4  # 2 SSS tiles (1 image) + 4 FLS frames (polar + fan)
    assert {cat["name"] for cat in c.loadCats(c.getCatIds())} >= {"rock", "pipe", "tyre"}
    # annToMask (the reader's own decoder) agrees with the stored area
    for a in c.loadAnns(c.getAnnIds()):
        assert c.annToMask(a).sum() == a["area"]


def test_card_counts_match_the_coco_file(serial):
    """The card's per-class instance counts are the COCO file's, class by class."""
    import re

    coco = json.loads((serial / "annotations.json").read_text())
    card = (serial / "README.md").read_text()
    names = {c["id"]: c["name"] for c in coco["categories"]}
    for cid, name in names.items():
        n = sum(a["category_id"] == cid for a in coco["annotations"])
        assert re.search(rf"^\| {name} \| {cid} \| {n} \|", card, re.M), name
    assert "generated by undersea" in card and "CC-BY-4.0" in card and "seed: 3" in card
    assert (serial / "preview.png").read_bytes()[:4] == b"\x89PNG"


def test_boxes_are_mask_extents(serial):
    """bbox [x, y, w, h] = the min/max row/column of the decoded mask (numpy.nonzero)."""
    coco = json.loads((serial / "annotations.json").read_text())
    for a in coco["annotations"]:
        rows, cols = np.nonzero(mask_utils.decode(a["segmentation"]))
        assert a["bbox"] == [
            cols.min(),
            rows.min(),
            cols.max() - cols.min() + 1,
            rows.max() - rows.min() + 1,
        ]


def test_png_is_log_display_of_linear_intensity(serial, resim):
    """PNG = round(255 clip((10 log10 I - floor) / range)) of the .npy (numpy by hand), and
    the .npy is the re-simulated linear image bit for bit."""
    coco = json.loads((serial / "annotations.json").read_text())
    for im in coco["images"]:
        meta = json.loads((serial / im["meta_file"]).read_text())
        lin = np.load(serial / im["linear_file"])
        if im["view"] != "fls-fan":
            np.testing.assert_array_equal(lin, resim[im["frame"]].linear)
        d = meta["display"]
        want = np.round(
            255
            * np.clip(
                (10 * np.log10(np.maximum(lin, 1e-30)) - d["floor_db"]) / d["dynamic_range_db"],
                0,
                1,
            )
        )
        png = cv2.imread(str(serial / "images" / im["file_name"]), cv2.IMREAD_UNCHANGED)
        assert png.dtype == np.uint8 and png.shape == lin.shape
        assert np.abs(png.astype(int) - want).max() <= 1  # float32 vs float64 rounding


def test_display_matches_the_sonars_own_log_compression(scene, serial):
    """The first FLS frame (t = 0, shard 0) simulated with the sonar's own log compression
    on (the scenario runner's sonar, untouched) equals the PNG / 255 to one grey level."""
    from sim.runner.core import ScenarioRun

    job = plan_dataset(_cfg(scene))[0]
    run = ScenarioRun(prepare_scenario(job.scenario, job.seed))
    fls = next(s for s in run.vehicles[0].sonars if s.kind == "fls")
    assert fls.sonar.config.acoustic.log_compression
    img = fls.sonar.frame(run.world.data, fls.rng).image
    png = cv2.imread(str(serial / "images" / "000001_fls-polar.png"), cv2.IMREAD_UNCHANGED)
    assert np.abs(png / 255.0 - img).max() <= 0.5 / 255 + 1e-6


def test_sidecar_pose_and_geometry(serial, resim):
    """SSS sidecars carry one pose per ping at the ping rate (10 Hz); the frame pose is the
    centre ping's; geometry matches the re-simulated frame."""
    coco = json.loads((serial / "annotations.json").read_text())
    for im in coco["images"]:
        meta = json.loads((serial / im["meta_file"]).read_text())
        fr = resim[im["frame"]]
        assert meta["pose"]["t"] == pytest.approx(im["time_s"], abs=1e-6)
        g = meta["geometry"]
        if im["kind"] == "sss":
            t = np.array(g["ping_time_s"])
            assert len(t) == 16 and np.allclose(np.diff(t), 0.1, atol=1e-6)
            assert np.array(g["ping_pose"]["position"]).shape == (16, 3)
            assert g["ping_pose"]["position"][8] == meta["pose"]["position"]
            np.testing.assert_allclose(g["slant_range_m"], fr.geometry["slant_range_m"])
            assert len(g["slant_range_m"]) == im["width"] == 256
        else:
            assert len(g["range_m"]) == 64 and len(g["bearing_rad"]) == 48
            if im["view"] == "fls-fan":
                assert g["fan"]["x_max_m"] == pytest.approx(15.0)


def test_two_workers_same_bytes_as_serial_and_other_seed_differs(scene, serial, tmp_path):
    """A second run with the same seed on 2 worker processes writes byte-identical files
    (COCO JSON, PNGs, sidecars, card); another seed changes them."""
    res = build_dataset(_cfg(scene), tmp_path / "par", workers=2, progress=False)
    assert sorted(res.shards_done) == [0, 1]
    a, b = _files(serial), _files(tmp_path / "par")
    assert sorted(a) == sorted(b)
    for name in a:
        assert a[name] == b[name], name
    other = tmp_path / "seed4"
    build_dataset(_cfg(scene, seed=4, frames=3), other, progress=False)
    assert (other / "images/000001_fls-polar.png").read_bytes() != a["images/000001_fls-polar.png"]
    assert (other / "annotations.json").read_bytes() != a["annotations.json"]


def test_ray_local_two_workers_same_bytes(scene, serial, tmp_path):
    """A local Ray started by the export (2 workers) writes the serial files byte for byte."""
    pytest.importorskip("ray")
    build_dataset(_cfg(scene), tmp_path, workers=2, use_ray=True, progress=False)
    a, b = _files(serial), _files(tmp_path)
    assert sorted(a) == sorted(b)
    assert [k for k in a if a[k] != b[k]] == []


def test_lost_shard_is_redone_and_finished_shards_are_kept(scene, serial, tmp_path):
    """With shard 1's record and one of its images gone (a worker killed mid-shard), a
    re-run keeps shard 0 and redoes shard 1 only, giving the same bytes; other settings
    in the same directory are refused."""
    d = tmp_path / "ds"
    shutil.copytree(serial, d)
    (d / "shards/shard_0001.json").unlink()
    (d / "images/000005_sss.png").unlink()
    before = (d / "shards/shard_0000.json").stat().st_mtime_ns
    res = build_dataset(_cfg(scene), d, progress=False)
    assert res.shards_resumed == [0] and res.shards_done == [1]
    assert (d / "shards/shard_0000.json").stat().st_mtime_ns == before
    assert _files(d) == _files(serial)
    with pytest.raises(ValueError, match="other settings"):
        build_dataset(_cfg(scene, tile_pings=8), d, progress=False)


def test_other_code_version_is_another_plan_and_force_starts_over(
    scene, serial, tmp_path, monkeypatch
):
    """Issue 15: resume is keyed on the whole plan, code version included; --force
    deletes the old dataset's files and builds the new plan from scratch."""
    import sim.version

    d = tmp_path / "ds"
    shutil.copytree(serial, d)
    monkeypatch.setattr(sim.version, "code_version", lambda: "0.0.0+gother")
    with pytest.raises(ValueError, match="--force"):
        build_dataset(_cfg(scene), d, progress=False)
    assert _files(d) == _files(serial)  # nothing touched
    monkeypatch.undo()
    res = build_dataset(_cfg(scene, frames=1, shard_frames=1), d, progress=False, force=True)
    assert res.shards_resumed == [] and res.shards_done == [0]
    assert sorted(p.name for p in (d / "shards").iterdir()) == ["shard_0000.json"]


def test_bad_input_clear_errors(scene, tmp_path, capsys):
    with pytest.raises(ValueError, match=r"scenario 'no-such-scenario'.*allowed"):
        build_dataset(DatasetConfig("no-such-scenario", frames=2), tmp_path)
    with pytest.raises(ValueError, match=r"frames = 0 .*allowed: an integer >= 1"):
        DatasetConfig(str(scene), frames=0)
    with pytest.raises(ValueError, match=r"kind = 'radar'.*sss, fls, both"):
        DatasetConfig(str(scene), frames=2, kind="radar")
    with pytest.raises(ValueError, match="tile_pings"):
        DatasetConfig(str(scene), frames=2, tile_pings=1)
    with pytest.raises(ValueError, match="workers"):
        build_dataset(_cfg(scene), tmp_path, workers=0)
    with pytest.raises(ValueError, match="carries no fls sonar"):
        plan_dataset(DatasetConfig("shipwreck-survey", frames=2, kind="fls"))
    from sim.cli.main import main

    assert main(["dataset", "no-such-scenario", "--frames", "2", "--out", str(tmp_path / "x")]) == 2
    assert "not a file and not a built-in" in capsys.readouterr().err
    assert (
        main(
            [
                "dataset",
                str(scene),
                "--frames",
                "2",
                "--kind",
                "sonar",
                "--out",
                str(tmp_path / "x"),
            ]
        )
        == 2
    )
    assert "kind = 'sonar'" in capsys.readouterr().err


def test_killed_export_keeps_finished_shard_and_resumes(scene, serial, tmp_path):
    """`undersea dataset` killed (SIGKILL) after its first shard: the shard's record and
    files survive, the re-run only simulates the second shard, and the result is the
    uninterrupted dataset byte for byte."""
    import os
    import signal
    import subprocess
    import sys
    import time

    d = tmp_path / "killed"
    cmd = [
        sys.executable,
        "-m",
        "sim.cli.main",
        "dataset",
        str(scene),
        "--frames",
        "6",
        "--seed",
        "3",
        "--kind",
        "both",
        "--tile-pings",
        "16",
        "--fls-view",
        "both",
        "--shard-frames",
        "3",
        "--npy",
        "--no-progress",
        "--out",
        str(d),
    ]
    proc = subprocess.Popen(
        cmd,
        cwd=Path(__file__).resolve().parents[3],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        t_end = time.monotonic() + 90
        while not (d / "shards/shard_0000.json").exists():
            assert proc.poll() is None and time.monotonic() < t_end, "export ended or hung"
            time.sleep(0.02)
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.wait()
    assert not (d / "shards/shard_0001.json").exists(), "killed too late to test anything"
    res = build_dataset(_cfg(scene), d, progress=False)
    assert res.shards_resumed == [0] and res.shards_done == [1]
    assert not list(d.rglob("*.tmp"))
    assert _files(d) == _files(serial)


def test_min_objects_keeps_only_frames_with_objects(scene, tmp_path):
    """With min_objects = 1 every image has an annotation; the vehicle starts 10 m before
    the first object, so the first kept tile (16 pings at 10 Hz, centre at 0.8 s if none
    were skipped) comes later than 2 s."""
    build_dataset(
        _cfg(scene, kind="sss", frames=2, shard_frames=2, min_objects=1), tmp_path, progress=False
    )
    coco = json.loads((tmp_path / "annotations.json").read_text())
    assert len(coco["images"]) == 2
    assert {a["image_id"] for a in coco["annotations"]} == {1, 2}
    assert coco["images"][0]["time_s"] > 2.0


# slow: the same kill-and-resubmit of sim.parallel.run_local_pool is tested in CI by the
# sweep's test_killed_worker_loses_no_finished_run
@pytest.mark.slow
def test_killed_worker_process_shard_is_redone_in_the_same_run(scene, serial, tmp_path):
    """SIGKILL one of 2 local worker processes once the first shard is on disk: the export
    still finishes in the same call (the lost shard runs again on a fresh pool) and writes
    the serial dataset byte for byte."""
    import multiprocessing
    import os
    import signal
    import threading
    import time

    out = tmp_path / "ds"
    box: dict = {}

    def target() -> None:
        try:
            box["res"] = build_dataset(_cfg(scene), out, workers=2, progress=False)
        except BaseException as exc:  # reported below
            box["err"] = exc

    before = {p.pid for p in multiprocessing.active_children()}
    th = threading.Thread(target=target)
    th.start()
    t_end = time.monotonic() + 90
    killed = None
    while th.is_alive() and time.monotonic() < t_end and killed is None:
        if list((out / "shards").glob("shard_*.json")):
            workers = [p for p in multiprocessing.active_children() if p.pid not in before]
            if workers and len(list((out / "shards").glob("*.json"))) < 2:
                killed = workers[0].pid
                os.kill(killed, signal.SIGKILL)
        time.sleep(0.01)
    th.join(120)
    assert killed is not None, "no worker to kill before the export ended"
    assert "err" not in box, box.get("err")
    assert sorted(box["res"].shards_done) == [0, 1]
    assert box["res"].retried  # the kill did break the pool and a shard ran again
    ref, got = _files(serial), _files(out)
    assert sorted(got) == sorted(ref)
    assert [k for k in ref if ref[k] != got[k]] == []
