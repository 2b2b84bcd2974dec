"""Scenario validation: each kind of mistake gives one message naming field, value, allowed."""

from __future__ import annotations

import copy

import pytest
from hypothesis import given
from hypothesis import strategies as st

from sim.scenario import (
    OBJECT_CLASSES,
    SONAR_PRESETS,
    VEHICLE_KINDS,
    ScenarioError,
    builtin_scenarios,
    load_scenario,
    load_scenario_dict,
    parse_scenario,
    set_dotted,
)


@pytest.fixture
def base() -> dict:
    return load_scenario_dict("shipwreck-survey")


def _err(data) -> str:
    with pytest.raises(ScenarioError) as ei:
        parse_scenario(data)
    return str(ei.value)


def test_builtins_present_and_valid():
    """The issue names four built-ins; every file there must parse."""
    names = set(builtin_scenarios())
    assert {"shipwreck-survey", "dense-loop", "harbour-fls", "swarms-mapping"} <= names
    for n in names:
        s = load_scenario(n)
        assert s.name == n


def test_shipwreck_default_contents():
    s = load_scenario("shipwreck-survey")
    v = s.vehicles[0]
    assert v.kind == "alister9" and v.sonars[0].preset == "deepeye680d"
    assert v.mission.type == "lawnmower"
    assert {"shipwreck", "rock", "tree_branch", "mannequin"} <= {o.cls for o in s.world.objects}


def test_swarms_has_all_four_vehicles_each_with_own_sonar_and_slam():
    s = load_scenario("swarms-mapping")
    assert {v.kind for v in s.vehicles} >= {"alister9", "ixn", "naiad", "saga"}
    assert all(v.sonars and v.slam.estimator for v in s.vehicles)


def test_unknown_top_key_rejected(base):
    base["durration_s"] = 3
    msg = _err(base)
    assert "durration_s" in msg and "duration_s" in msg  # names the bad key and the allowed ones


def test_unknown_nested_key_rejected(base):
    base["vehicles"][0]["mission"]["alt"] = 3
    msg = _err(base)
    assert "vehicles[0].mission.alt" in msg and "altitude_m" in msg


def test_wrong_type(base):
    base["duration_s"] = "long"
    msg = _err(base)
    assert "'duration_s'" in msg and "'long'" in msg and "a number" in msg


def test_out_of_range(base):
    base["vehicles"][0]["mission"]["speed_mps"] = -1.0
    msg = _err(base)
    assert "vehicles[0].mission.speed_mps" in msg and "-1.0" in msg and "> 0" in msg


def test_unknown_vehicle(base):
    base["vehicles"][0]["kind"] = "nautilus"
    msg = _err(base)
    assert "vehicles[0].kind" in msg and "'nautilus'" in msg
    assert all(k in msg for k in VEHICLE_KINDS)


def test_unknown_sonar(base):
    base["vehicles"][0]["sonars"][0]["preset"] = "deepeye999"
    msg = _err(base)
    assert "vehicles[0].sonars[0].preset" in msg and all(p in msg for p in SONAR_PRESETS)


def test_unknown_object_class(base):
    base["world"]["objects"][1]["class"] = "submarine"
    msg = _err(base)
    assert "world.objects[1].class" in msg and all(c in msg for c in OBJECT_CLASSES)


def test_object_outside_seabed(base):
    base["world"]["objects"][0]["position"] = [500.0, 0.0]
    msg = _err(base)
    assert "world.objects[0].position[0]" in msg and "500.0" in msg


def test_nan_rejected(base):
    base["world"]["depth_m"] = float("nan")
    assert "world.depth_m" in _err(base)


def test_duplicate_vehicle_names(base):
    base["vehicles"].append(copy.deepcopy(base["vehicles"][0]))
    assert "vehicles[1].name" in _err(base)


def test_vehicle_slam_overrides_top_level_defaults(base):
    base["vehicles"][0]["slam"] = {"estimator": "fastslam2", "params": {"n_particles": 50}}
    s = parse_scenario(base)
    assert s.vehicles[0].slam.estimator == "fastslam2"
    assert s.vehicles[0].slam.timing == "lagged"  # inherited from [slam]
    assert s.vehicles[0].slam.params["n_particles"] == 50


def test_set_dotted_override_then_validation(base):
    d = set_dotted(base, "vehicles[0].slam.estimator", "isam2")
    assert parse_scenario(d).vehicles[0].slam.estimator == "isam2"
    assert base["vehicles"][0].get("slam") is None  # the input is not mutated
    with pytest.raises(ScenarioError, match=r"vehicles\[0\]\.slam\.estimator"):
        parse_scenario(set_dotted(base, "vehicles[0].slam.estimator", "kalman"))
    with pytest.raises(ScenarioError, match="does not exist"):
        set_dotted(base, "vehicles[3].kind", "ixn")


def test_unknown_scenario_name_lists_builtins():
    with pytest.raises(ScenarioError, match="shipwreck-survey"):
        load_scenario("no-such-scenario")


def test_with_overrides_seed_duration():
    s = load_scenario("shipwreck-survey").with_overrides(seed=9, duration_s=5.0)
    assert (s.seed, s.duration_s) == (9, 5.0)
    with pytest.raises(ScenarioError, match="duration_s"):
        s.with_overrides(duration_s=0.0)


@given(st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=3) | st.booleans())
def test_speed_property_valid_or_named_error(value):
    """Property: any value for speed_mps either parses to a finite speed in (0, 5] or raises
    a ScenarioError naming that exact field - never another exception, never a NaN."""
    d = load_scenario_dict("shipwreck-survey")
    d["vehicles"][0]["mission"]["speed_mps"] = value
    try:
        s = parse_scenario(d)
    except ScenarioError as e:
        assert "vehicles[0].mission.speed_mps" in str(e)
    else:
        assert 0 < s.vehicles[0].mission.speed_mps <= 5


def test_sonar_override_checked_against_sonar_config(base):
    """An override that is not a field of the sonar preset names the field path."""
    base["vehicles"][0]["sonars"][0]["overrides"] = {"max_rnge": 30.0}
    msg = _err(base)
    assert "vehicles[0].sonars[0].overrides" in msg and "max_rnge" in msg


def test_nav_sensor_preset_and_override_checked(base):
    """Nav presets/overrides are checked against sim.navigation's configs."""
    base["vehicles"][0]["nav"] = {"dvl": {"preset": "rdi999"}}
    msg = _err(base)
    assert "vehicles[0].nav.dvl" in msg and "rdi600" in msg
    base["vehicles"][0]["nav"] = {"imu": {"preset": "tactical"}}
    cfg = parse_scenario(base).vehicles[0].nav.suite_config()
    from sim.navigation import IMUConfig

    assert cfg.imu == IMUConfig.preset("tactical")


def test_set_dotted_numeric_index_form(base):
    """'vehicles.0.x' and 'vehicles[0].x' address the same field."""
    a = set_dotted(base, "vehicles.0.mission.speed_mps", 1.0)
    b = set_dotted(base, "vehicles[0].mission.speed_mps", 1.0)
    assert a == b and parse_scenario(a).vehicles[0].mission.speed_mps == 1.0
    with pytest.raises(ScenarioError, match="allowed"):
        set_dotted(base, "vehicles..x", 1)


def test_surface_at_s_must_be_a_positive_time(base):
    base["vehicles"][0]["mission"]["surface_at_s"] = -5.0
    msg = _err(base)
    assert "vehicles[0].mission.surface_at_s" in msg and "-5.0" in msg and "> 0" in msg
    base["vehicles"][0]["mission"]["surface_at_s"] = 30.0
    assert parse_scenario(base).vehicles[0].mission.surface_at_s == 30.0


def test_tie_line_only_on_a_lawnmower_and_closes_at_the_start(base):
    from sim.runner.build import mission_for

    m = base["vehicles"][0]["mission"]
    m["tie_line"] = "yes"
    assert "vehicles[0].mission.tie_line" in _err(base) and "true or false" in _err(base)
    m.update(tie_line=True, type="loop", waypoints=[[0, 0], [10, 0]])
    msg = _err(base)
    assert "vehicles[0].mission.tie_line" in msg and "lawnmower" in msg
    m.update(type="lawnmower", tie_line=True, size_m=[100.0, 40.0], line_spacing_m=20.0)
    wps = mission_for(parse_scenario(base).vehicles[0], 50.0).waypoints
    # three lines of 100 m at y = -20, 0, 20 (centre 0, 0), then back to the first start
    assert len(wps) == 7 and wps[-1].tolist() == wps[0].tolist() == [-50.0, -20.0]
    assert wps[-2].tolist() == [50.0, 20.0]


def test_calibration_loop_only_on_a_lawnmower_and_flown_on_the_first_line(base):
    from sim.runner.build import mission_for

    m = base["vehicles"][0]["mission"]
    m.update(calibration_laps=-1)
    assert "vehicles[0].mission.calibration_laps" in _err(base)
    m.update(calibration_laps=1, tie_line=False, type="loop", waypoints=[[0, 0], [10, 0]])
    msg = _err(base)
    assert "vehicles[0].mission.calibration_laps" in msg and "lawnmower" in msg
    m.update(type="lawnmower", size_m=[100.0, 40.0], line_spacing_m=20.0, calibration_at_m=30.0)
    m.update(calibration_radius_m=-2.0)
    assert "vehicles[0].mission.calibration_radius_m" in _err(base)
    m.update(calibration_radius_m=10.0)
    wps = mission_for(parse_scenario(base).vehicles[0], 50.0).waypoints
    # first line y = -20 from x = -50: the loop leaves and rejoins it at (-20, -20), its
    # far side 2 R to starboard (south), then the line goes on to (50, -20)
    assert wps[1].tolist() == [-20.0, -20.0] and wps[17].tolist() == [-20.0, -20.0]
    assert wps[:18, 1].min() == pytest.approx(-40.0) and wps[18].tolist() == [50.0, -20.0]
    m.update(calibration_at_m=150.0)  # past the 100 m line
    with pytest.raises(ValueError, match="inside the first leg"):
        mission_for(parse_scenario(base).vehicles[0], 50.0)
