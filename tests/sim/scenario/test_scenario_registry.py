"""The scenario schema reads its names where the things are defined (one registry each)
and validates ``slam.params`` against the estimator's own config at load time."""

from __future__ import annotations

import pytest

from sim.scenario import schema
from sim.scenario.schema import ScenarioError, load_scenario
from sim.sonar.config import PRESETS, SSSConfig
from sim.world.vehicles import VEHICLES
from slam.estimators import ESTIMATORS
from slam.frontend.segmentation.presets import PRESETS as SEG_PRESETS


def test_names_are_those_of_the_defining_modules():
    assert set(schema.VEHICLE_KINDS) == set(VEHICLES)
    assert set(schema.SONAR_PRESETS) == set(PRESETS)
    assert {k for k in schema.SIDESCAN_PRESETS} == {
        k for k, c in PRESETS.items() if type(c) is SSSConfig
    }
    assert set(schema.ESTIMATORS) == {*ESTIMATORS, "none"}
    assert set(schema.FRONTEND_PRESETS) == {"auto", *SEG_PRESETS}


@pytest.mark.parametrize("name", ["aekf-submap", "aekf-robocentric"])
def test_every_estimator_is_selectable(name):
    scn = load_scenario("harbour-fls", {"slam.estimator": name})
    assert scn.vehicles[0].slam.estimator == name


def test_params_typo_is_a_load_time_error_naming_the_field():
    with pytest.raises(ScenarioError, match=r"slam\.params\.gatee'.*'aekf'"):
        load_scenario("harbour-fls", {"slam.params": {"gatee": 3.0}})
    with pytest.raises(ScenarioError, match=r"slam\.params"):
        load_scenario("harbour-fls", {"slam.estimator": "none", "slam.params": {"x": 1}})
