"""Shared fixtures. ``shared_data`` points at ../shared/data (the full real-data sets),
and skips with a clear message when a clone has no ../shared beside it.

With ``UNDERSEA_NUMBA_WARMUP=1`` and pytest-xdist (``-n 2``, the default), the
controller fills numba's on-disk cache before the workers start when any kernel is not
cached yet (tests/helpers/numba_warmup.py), so the workers and the processes their tests
start load the compiled kernels instead of each compiling them. Off by default: on the
files measured it cost more CPU than it saved (docs/test-suite.md)."""

from __future__ import annotations

import os
import time
from pathlib import Path

import numba_warmup
import pytest

REPO = Path(__file__).resolve().parents[1]
TEST_DATA = REPO / "tests" / "data"


_WARMUP = pytest.StashKey[str]()


def _is_xdist_controller(config) -> bool:
    n = getattr(config.option, "numprocesses", None)
    return (
        not hasattr(config, "workerinput")
        and isinstance(n, int)
        and n >= 2
        and getattr(config.option, "dist", "no") != "no"
    )


def pytest_configure(config):
    """xdist controller, ``UNDERSEA_NUMBA_WARMUP=1``: compile the cold numba kernels
    once, in two processes, before the workers start (a warm cache costs one read of
    each kernel's cache index)."""
    if (
        os.environ.get("UNDERSEA_NUMBA_WARMUP") != "1"
        or not _is_xdist_controller(config)
        or config.option.collectonly
    ):
        return
    cold = numba_warmup.cold_kernels(REPO)
    if not cold:
        config.stash[_WARMUP] = "numba cache: every kernel cached"
        return
    t0 = time.perf_counter()
    failed = numba_warmup.warm_in_parallel(REPO)
    still = numba_warmup.cold_kernels(REPO)
    config.stash[_WARMUP] = (
        f"numba cache: {len(cold)} cold kernels compiled before the workers started "
        f"({time.perf_counter() - t0:.0f} s); still cold: {', '.join(still) or 'none'}"
        + (f"; warm-up failed: {'; '.join(failed)}" if failed else "")
    )


def pytest_report_header(config):
    return config.stash.get(_WARMUP, None)


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
