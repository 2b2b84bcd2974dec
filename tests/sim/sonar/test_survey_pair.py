"""Two simulated passes over a wreck, mosaicked with the true poses on one grid: a
keypoint matcher must find the identity between them (the pair's known transform)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.sonar.survey_pair import wreck_survey_pair
from slam.frontend.matching import match_images, rotate_scale


def _display(linear: np.ndarray) -> np.ndarray:
    d = 10.0 * np.log10(np.maximum(linear, 1e-12))
    lo, hi = np.percentile(d, [10.0, 99.5])
    return np.clip(np.rint(255.0 * (d - lo) / (hi - lo)), 0, 255).astype(np.uint8)


@pytest.fixture(scope="module")
def pair():
    return wreck_survey_pair(0, half_extent=12.0, ping_spacing=0.3)


def test_pair_is_on_one_grid_and_the_farther_line_casts_longer_shadows(pair):
    """Same grid; the seabed south of the wreck (towards both tracks) is lit in both. A
    shadow behind an object of height h seen from altitude H at ground range g is
    g·h/(H − h) long, so the line 20 m off leaves more shadow north of the wreck than the
    line 14 m off (the tall parts' shadows run off the grid from both lines)."""
    assert pair.a.shape == pair.b.shape == (120, 120)
    south = slice(int(0.8 * 120), 120)  # rows of y in (−12, −7.2) m: bare seabed
    assert np.mean(pair.a[south] > 0) > 0.95 and np.mean(pair.b[south] > 0) > 0.95
    north = slice(0, 60)  # y > 0: behind the wreck as seen from the south
    assert np.sum(pair.b[north] == 0) > np.sum(pair.a[north] == 0)


def test_sift_finds_the_identity_between_the_passes(pair):
    """True transform from the simulator's poses: identity (within 1°, 2 %, 1 m)."""
    res = match_images(_display(pair.a), _display(pair.b), detector="sift")
    assert res.matched
    assert abs(res.rotation_deg) < 1.0 and res.scale == pytest.approx(1.0, abs=0.02)
    assert np.all(np.abs(res.transform[:, 2]) < 1.0 / pair.resolution)


def test_rotated_second_pass_recovers_the_applied_rotation(pair):
    """B = second pass rotated 90° and scaled 1.2: the match recovers (90°, 1.2)."""
    b, m_true = rotate_scale(_display(pair.b), 90.0, 1.2)
    res = match_images(_display(pair.a), b, detector="sift")
    assert res.matched
    assert abs(res.rotation_deg - 90.0) < 1.5 and res.scale == pytest.approx(1.2, rel=0.03)
    shift = res.transform[:, 2] - m_true[:, 2]
    assert np.all(np.abs(shift) < 1.2 / pair.resolution)  # within 1 m of B's grid
