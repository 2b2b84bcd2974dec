"""``[frontend] profile``: "real-sidescan" gives a scenario the recorded-data front end of
``undersea sss-slam`` (slam.pipeline.REAL_SIDESCAN); the default keeps the pipeline's."""

from __future__ import annotations

import pytest

from sim.runner.build import pipeline_config
from sim.scenario.schema import ScenarioError, load_scenario_dict, parse_scenario
from slam.pipeline import REAL_SIDESCAN, PipelineConfig


def _vehicle(profile=None, min_area=None):
    d = load_scenario_dict("dense-loop")
    fe = d.setdefault("frontend", {})
    if profile is not None:
        fe["profile"] = profile
    if min_area is not None:
        fe["min_area_m2"] = min_area
    return parse_scenario(d).vehicles[0]


def test_default_profile_keeps_the_pipeline_defaults():
    cfg = pipeline_config(_vehicle())
    ref = PipelineConfig()
    assert (cfg.normalization, cfg.min_area_m2, cfg.max_extent_m) == (
        ref.normalization,
        ref.min_area_m2,
        ref.max_extent_m,
    )
    assert cfg.drop_first_return_edge is ref.drop_first_return_edge


def test_real_sidescan_profile_takes_the_recorded_data_front_end():
    cfg = pipeline_config(_vehicle("real-sidescan", min_area=0.2))
    assert cfg.normalization == REAL_SIDESCAN.normalization == "column-median"
    assert cfg.max_extent_m == REAL_SIDESCAN.max_extent_m
    assert cfg.drop_first_return_edge is REAL_SIDESCAN.drop_first_return_edge is True
    assert cfg.require_shadow is REAL_SIDESCAN.require_shadow is True
    assert cfg.min_area_m2 == 0.2  # the scenario's own speckle filter
    # the run's own pose prior (the launch lag) and the speed floor stay
    sim_cfg = pipeline_config(_vehicle())
    assert cfg.pose0_var_xy_m2 == sim_cfg.pose0_var_xy_m2
    assert cfg.pose0_sigma_yaw_deg == sim_cfg.pose0_sigma_yaw_deg
    assert cfg.min_speed_mps == PipelineConfig().min_speed_mps


def test_unknown_profile_names_the_field():
    with pytest.raises(ScenarioError, match=r"frontend\.profile"):
        _vehicle("recorded")


def test_max_extent_overrides_the_profile_and_is_validated():
    d = load_scenario_dict("dense-loop")
    d.setdefault("frontend", {}).update(profile="real-sidescan", max_extent_m=25.0)
    assert pipeline_config(parse_scenario(d).vehicles[0]).max_extent_m == 25.0
    d["frontend"]["max_extent_m"] = -1.0
    with pytest.raises(ScenarioError, match=r"frontend\.max_extent_m"):
        parse_scenario(d)


def test_require_shadow_overrides_the_profile_and_is_validated():
    d = load_scenario_dict("dense-loop")
    assert pipeline_config(parse_scenario(d).vehicles[0]).require_shadow is False
    d.setdefault("frontend", {})["require_shadow"] = True
    assert pipeline_config(parse_scenario(d).vehicles[0]).require_shadow is True
    d["frontend"].update(profile="real-sidescan", require_shadow=False)
    assert pipeline_config(parse_scenario(d).vehicles[0]).require_shadow is False
    d["frontend"]["require_shadow"] = "yes"
    with pytest.raises(ScenarioError, match=r"frontend\.require_shadow"):
        parse_scenario(d)
