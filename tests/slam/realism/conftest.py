"""Synthetic waterfalls with known statistics for the realism tests."""

from __future__ import annotations

import numpy as np
import pytest

WC_SAMPLES = 64  # water-column samples on each side
WC_MEAN = 1e-3  # water-column mean intensity re seabed mean 1


def make_waterfall(seabed_port: np.ndarray, seabed_stbd: np.ndarray, rng) -> np.ndarray:
    """(P, 2S) waterfall: per side WC_SAMPLES of exponential water column (mean WC_MEAN)
    then the given seabed (near range first); port mirrored to the left."""
    p = seabed_port.shape[0]
    sides = []
    for sb in (seabed_port, seabed_stbd):
        wc = rng.exponential(WC_MEAN, size=(p, WC_SAMPLES))
        sides.append(np.concatenate([wc, sb], axis=1))
    return np.concatenate([sides[0][:, ::-1], sides[1]], axis=1)


@pytest.fixture
def waterfall_factory():
    return make_waterfall
