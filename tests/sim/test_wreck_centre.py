"""The wreck maps at its centre from either side (issue 12, item 4): one simulated pass
north of the 20 m x 5 m wreck (seen to starboard) and one south of it (seen to port),
each 15 m from its centreline; the SLAM landmark of the wreck lies within 2 m of the
wreck's true base centre (the scenario's object position) and its covariance covers
the error. Before the highlight + shadow centre, the landmark sat on the lit flank,
2.5-6 m from the centre."""

from __future__ import annotations

import numpy as np
import pytest

from sim.runner import run_scenario
from sim.scenario import load_scenario

WRECK = np.array([10.0, -12.0])  # shipwreck-survey's wreck, yaw 20 deg


def _pass(offset_y: float, tmp_path):
    y = WRECK[1] + offset_y
    over = {
        # CI size: 400 samples per side over the same 40 m
        "vehicles[0].sonars[0].overrides": {
            "max_range": 40.0,
            "samples_per_side": 400,
            "range_resolution": 0.05,
        },
        "world.objects": [
            {
                "class": "shipwreck",
                "name": "wreck",
                "position": WRECK.tolist(),
                "yaw_deg": 20.0,
                "burial": 0.15,
            }
        ],
        "vehicles[0].start": {"position": [-14.0, y, -22.0], "yaw_deg": 0.0},
        "vehicles[0].mission": {
            "type": "line",
            "waypoints": [[-14.0, y], [36.0, y]],
            "speed_mps": 1.5,
            "altitude_m": 8.0,
        },
        "outputs": {"recording": False, "figures": False},
    }
    scn = load_scenario("shipwreck-survey", over).with_overrides(duration_s=36.0)
    return run_scenario(scn, tmp_path / f"pass{offset_y:+.0f}", progress=False)


@pytest.mark.parametrize("offset_y", [15.0, -15.0], ids=["north-starboard", "south-port"])
def test_wreck_landmark_at_its_centre(offset_y, tmp_path):
    res = _pass(offset_y, tmp_path)
    v = res.metrics["vehicles"]["alister9"]
    lm = v["landmarks"]
    assert lm["n_objects_imaged"] == 1
    assert lm["n_true_mapped"] == 1 and lm["n_duplicated_objects"] == 0
    assert lm["rmse_m"] < 2.0
    assert lm["landmark_nees_mean"] < lm["landmark_nees_95_upper"]
