"""Fixtures handing the synthetic recording writers (tests/helpers/recording_writers.py)
to the reader tests."""

from __future__ import annotations

import pytest
import recording_writers


@pytest.fixture
def write_xtf():
    return recording_writers.write_xtf


@pytest.fixture
def write_sl2():
    return recording_writers.write_sl2
