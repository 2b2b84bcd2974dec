"""End-to-end scenario runs (CI-sized): shipwreck-survey detects the wreck and maps it;
same seed, same metrics; Ctrl-C leaves a readable recording and an 'incomplete' metrics."""

from __future__ import annotations

import json
import math

import pytest

from sim.runner import OutputExistsError, run_scenario
from sim.scenario import load_scenario
from sim.scenario.schema import load_scenario_dict, parse_scenario
from sim.viz.rerun_log import read_component, read_recording

#: CI size: 400 samples per side instead of 1000 (same 40 m range) and a shorter first
#: leg (x from -45 m): it passes the rock at (-30, -16) and the wreck at (10, -12), 18 m
#: to port, within 55 s.
SMALL_SSS = {
    "vehicles[0].sonars[0].overrides": {
        "max_range": 40.0,
        "samples_per_side": 400,
        "range_resolution": 0.05,
    },
    "vehicles[0].mission.size_m": [90.0, 60.0],
    "vehicles[0].start.position": [-45.0, -30.0, -22.0],
}
CI_DURATION = 55.0


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "shipwreck"
    scn = load_scenario("shipwreck-survey", SMALL_SSS).with_overrides(duration_s=CI_DURATION)
    return run_scenario(scn, out, progress=False)


def test_shipwreck_survey_detects_the_wreck(survey):
    """A detection lies within 3 m of the wreck's true position (placed with the true pose
    at its ping: this scores the sonar + front end + observation model)."""
    assert survey.complete
    det = survey.metrics["vehicles"]["alister9"]["detections"]
    wreck = next(k for k in det["nearest_detection_m"] if k.startswith("shipwreck"))
    assert det["nearest_detection_m"][wreck] < 3.0
    assert det["ppv"] >= 0.5 and det["fpr_pixels"] < 0.05


def test_shipwreck_survey_slam_within_bounds(survey):
    """Stated bounds for one CI-sized run: every imaged object mapped once (no duplicates),
    landmark RMSE < 2.5 m (the wreck is 20 m x 5 m: its side-scan highlight, hence its
    landmark, sits on its sonar-facing side, ~half its width from the base centre the
    truth uses; the rock is mapped to < 1 m) and landmark NEES mean < chi2_2(0.95) = 5.99; pose ATE < 1 m and
    mean pose NEES below the per-step chi2_3 97.5 % bound 9.35 (a single run's time-
    correlated errors make the mean not chi2(3N)/N, so the per-step bound is the check),
    with at least 60 % of the steps inside the 95 % interval."""
    v = survey.metrics["vehicles"]["alister9"]
    lm, po = v["landmarks"], v["pose"]
    assert lm["n_objects_imaged"] >= 2
    assert lm["n_true_mapped"] == lm["n_objects_imaged"]
    assert lm["n_duplicated_objects"] == 0 and lm["n_spurious"] <= 1
    assert lm["rmse_m"] < 2.5 and lm["landmark_nees_mean"] < 5.99
    assert po["ate_m"] < 1.0
    assert po["nees_mean"] < 9.35 and po["nees_in_95_interval"] >= 0.6


def test_recording_reads_back_with_expected_entities(survey):
    p = survey.out_dir / "recording.rrd"
    ents = read_recording(p)
    for e in (
        "/world/seabed",
        "/world/alister9",
        "/world/alister9/mesh",
        "/world/alister9/sonar/sss/image",
        "/world/alister9/sonar/sss/segmentation",
        "/world/trajectories/alister9/true",
        "/world/trajectories/alister9/estimated",
        "/world/slam/alister9/landmarks",
        "/world/slam/alister9/landmark_cov",
        "/world/detections/alister9/sss",
        "/metrics/alister9/slam/n_landmarks",
    ):
        assert e in ents, e
    objs = [e for e in ents if e.startswith("/world/objects/")]
    assert len(objs) == len(survey.metrics["objects"]) and all(ents[e].static for e in objs)
    # vehicle pose logged every 0.5 s of sim time
    assert ents["/world/alister9"].rows == pytest.approx(CI_DURATION / 0.5, abs=2)
    n_lm = [v[0] for v in read_component(p, "metrics/alister9/slam/n_landmarks", "Scalars:scalars")]
    assert n_lm[-1] == survey.metrics["vehicles"]["alister9"]["landmarks"]["n_estimated"]


def test_outputs_complete_and_figures(survey):
    d = survey.out_dir
    m = json.loads((d / "metrics.json").read_text())
    assert m["complete"] is True and m["sim_time_s"] == pytest.approx(CI_DURATION)
    assert (d / "trajectory_map.png").stat().st_size > 5000
    assert (d / "sss_mosaic.png").stat().st_size > 5000
    assert not list(d.parent.glob(f".{d.name}.partial*"))
    assert set(m["timing"]["stages_s"]) >= {"physics", "sonar", "frontend", "slam", "navigation"}


def _short(seed=5, duration=12.0, **extra):
    ov = {
        "vehicles[0].sonars[0].overrides": {
            "max_range": 30.0,
            "samples_per_side": 150,
            "range_resolution": 0.2,
        },
        "frontend.window_pings": 60,
        "frontend.hop_pings": 30,
    }
    ov.update(extra)
    return load_scenario("shipwreck-survey", ov).with_overrides(seed=seed, duration_s=duration)


def test_same_scenario_and_seed_same_metrics(tmp_path):
    """Everything but the wall-clock 'timing' section is identical between two runs."""
    scn = _short(**{"outputs.recording": False, "outputs.figures": False})
    a = run_scenario(scn, tmp_path / "a", progress=False).metrics
    b = run_scenario(scn, tmp_path / "b", progress=False).metrics
    a.pop("timing")
    b.pop("timing")
    assert json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
    ta = json.loads((tmp_path / "a" / "metrics.json").read_text())
    tb = json.loads((tmp_path / "b" / "metrics.json").read_text())
    ta.pop("timing")
    tb.pop("timing")
    assert ta == tb


def test_interrupted_run_is_marked_incomplete_and_recording_readable(tmp_path):
    """A stop after ~3 s of sim time (what Ctrl-C does) still writes a readable recording and
    metrics.json with complete = false; the directory is renamed into place, not left partial."""
    scn = _short(duration=30.0, **{"outputs.figures": False})
    ticks = {"n": 0}

    def stop():
        ticks["n"] += 1
        return ticks["n"] >= 60  # 60 control ticks of 0.05 s

    res = run_scenario(scn, tmp_path / "cut", progress=False, stop_flag=stop)
    assert not res.complete
    m = json.loads((tmp_path / "cut" / "metrics.json").read_text())
    assert m["complete"] is False and m["interrupted_at_s"] == pytest.approx(3.0, abs=0.06)
    ents = read_recording(tmp_path / "cut" / "recording.rrd")
    assert "/world/alister9" in ents and ents["/world/alister9"].rows >= 5
    assert not list(tmp_path.glob(".cut.partial*"))
    with pytest.raises(OutputExistsError):
        run_scenario(scn, tmp_path / "cut", progress=False)


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="known weakness (session 1 note, issue 6): since the navigation and vehicle "
    "updates the wreck's landmark stays on its north (lit) edge, ~6 m from the base centre, "
    "beyond the 5 m match radius; the south pass's highlight is not fused into it",
)
def test_full_default_survey_maps_every_object_once(tmp_path):
    """The full default run (420 s, 2 x 1000 samples; ~2-3 min): every object detected,
    one landmark per object, landmark RMSE < 2.5 m (the wreck's highlight sits on its
    sonar-facing side, up to half its width + a few m from the base centre), NEES bounds
    as in the CI variant."""
    res = run_scenario(load_scenario("shipwreck-survey"), tmp_path / "full", progress=False)
    v = res.metrics["vehicles"]["alister9"]
    assert v["detections"]["recall_objects"] == 1.0 and v["detections"]["ppv"] >= 0.8
    lm, po = v["landmarks"], v["pose"]
    assert lm["n_true_mapped"] == lm["n_objects_imaged"] == len(res.metrics["objects"])
    assert lm["n_duplicated_objects"] == 0 and lm["n_spurious"] == 0
    assert lm["rmse_m"] < 2.5 and lm["landmark_nees_mean"] < 5.99
    assert po["nees_mean"] < 9.35 and po["nees_in_95_interval"] >= 0.8


def test_swarms_mapping_runs_four_vehicles_each_with_own_slam(tmp_path):
    """Several vehicles in one scenario: each has its own sonar, navigation and SLAM
    entry in metrics.json and its own entities in the recording (2 s of sim)."""
    scn = load_scenario("swarms-mapping", {"outputs.figures": False}).with_overrides(duration_s=2.0)
    res = run_scenario(scn, tmp_path / "swarm", progress=False)
    names = {v.name for v in scn.vehicles}
    assert set(res.metrics["vehicles"]) == names and len(names) == 4
    for v in res.metrics["vehicles"].values():
        assert v["slam"]["estimator"] == "aekf" and v["pose"]["ate_m"] < 0.5
        assert v["pose"]["dead_reckoning_ate_m"] is not None
    ents = read_recording(tmp_path / "swarm" / "recording.rrd")
    assert all(f"/world/{n}" in ents and f"/world/{n}/mesh" in ents for n in names)
    # one fused map for the fleet: every vehicle's map in it, logged beside theirs
    fleet = res.metrics["fleet"]
    assert set(fleet["vehicles"]) == names and fleet["approximate_covariance"] == []
    assert (
        fleet["landmarks"]["n_estimated"]
        == sum(fleet["n_landmarks_per_vehicle"].values()) - (fleet["n_paired_between_vehicles"])
    )
    assert "/world/slam/fleet/landmarks" in ents and "fleet map (4 maps fused" in res.summary()


def test_a_surfaced_vehicle_s_gps_fix_anchors_the_fleet_map(tmp_path):
    """Two SLAM vehicles; SAGA starts 2 m deep and surfaces at 0.5 s (mission
    surface_at_s): its GPS fixes at the end of the run (at hand-over) anchor the fused map,
    and its fused final pose lies within the fix's 3σ (standalone GPS, 2 m) of the truth."""
    data = load_scenario_dict("swarms-mapping")
    data["duration_s"] = 12.0
    data["outputs"] = {"figures": False, "recording": False}
    saga = next(v for v in data["vehicles"] if v["kind"] == "saga")
    naiad = next(v for v in data["vehicles"] if v["kind"] == "naiad")
    saga["start"]["position"][2] = -2.0
    saga["mission"]["surface_at_s"] = 0.5
    data["vehicles"] = [naiad, saga]
    res = run_scenario(parse_scenario(data), tmp_path / "gps", progress=False)
    fleet = res.metrics["fleet"]
    assert fleet["gps_anchored"] == ["saga"]
    assert fleet["final_pose_error_m"]["saga"] < 3 * 2.0 * math.sqrt(2)
    assert "GPS anchors: saga" in res.summary()
