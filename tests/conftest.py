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


@pytest.fixture(scope="session")
def local_ray():
    """One local Ray runtime (2 CPUs) for the tests that run sweeps or exports on Ray:
    started and shut down by ``sim.parallel.ray_session`` (the path of a run without
    ``--address``), once per pytest worker instead of once per test; the sweep and the
    export attach to it as to a running cluster and must leave it running."""
    pytest.importorskip("ray")
    from sim.parallel import ray_session

    with ray_session(2, None, "run the tests") as ray:
        assert ray.is_initialized() and ray.cluster_resources().get("CPU") == 2
        yield ray
    assert not ray.is_initialized(), "ray_session did not shut down the Ray it started"
