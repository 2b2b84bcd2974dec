"""Shared fixtures. ``shared_data`` points at ../shared/data (the full real-data sets),
and skips with a clear message when a clone has no ../shared beside it."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
TEST_DATA = REPO / "tests" / "data"


def shared_data_dir() -> Path | None:
    env = os.environ.get("UNDERSEA_SHARED_DATA")
    candidates = [Path(env)] if env else []
    candidates.append(REPO.parent / "shared" / "data")
    for c in candidates:
        if c.is_dir():
            return c
    return None


@pytest.fixture
def shared_data() -> Path:
    d = shared_data_dir()
    if d is None:
        pytest.skip(
            "../shared/data not found beside the clone (set UNDERSEA_SHARED_DATA): "
            "full real-data evaluations skipped"
        )
    return d


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)
