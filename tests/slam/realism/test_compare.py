"""The tolerance rules of the comparison (issue 11's "what must hold") and strict JSON."""

from __future__ import annotations

import json
import math

import pytest

from slam.realism.compare import json_ready, within


@pytest.mark.parametrize(
    "key, sim, real, ok",
    [
        ("cv_amplitude", 0.41, 0.38, True),  # +7.9 %
        ("cv_amplitude", 0.43, 0.38, False),  # +13 %
        ("db_std", 3.75, 3.3, True),
        ("db_std", 3.85, 3.3, False),
        ("lag1_range", 0.19, 0.28, True),
        ("lag1_ping", 0.01, 0.13, False),
        ("water_column_db", -35.5, -41.0, True),
        ("dynamic_range_db", 121.0, 58.0, False),
        ("saturation", 0.027, 0.014, True),  # x1.9
        ("saturation", 0.03, 0.014, False),  # x2.1
        ("saturation", 0.0, 0.014, False),
        ("saturation", 0.0, 0.0005, True),  # both below 0.1 %: noise, not a level
    ],
)
def test_within_follows_the_issue_tolerances(key, sim, real, ok):
    assert within(key, sim, real) is ok


def test_nan_is_neither_within_nor_outside_and_becomes_null():
    assert within("db_std", math.nan, 3.0) is None
    doc = json_ready({"a": [1.0, math.nan, {"b": math.inf}], "c": "x"})
    assert json.loads(json.dumps(doc, allow_nan=False)) == {"a": [1.0, None, {"b": None}], "c": "x"}
