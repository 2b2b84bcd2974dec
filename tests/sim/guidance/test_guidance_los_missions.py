"""LOS geometry against hand-worked cases, lawnmower leg count/spacing/coverage against
its definition, loop/line/hold shapes, bounds errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.guidance import (
    WorldBounds,
    hold,
    lawnmower,
    lawnmower_spacing,
    loop,
    los_guidance,
    straight_line,
    with_calibration_loop,
)


def test_los_cross_track_sign_and_magnitude_on_east_leg():
    """Leg along +x; a vehicle 3 m north (port of the path) has e = +3 and is steered
    right by atan(3/Δ); 3 m south gives e = -3 and a left turn (hand-worked)."""
    r = los_guidance((10.0, 3.0), (0, 0), (100, 0), lookahead=6.0)
    assert r.cross_track == pytest.approx(3.0)
    assert r.along_track == pytest.approx(10.0)
    assert r.course == pytest.approx(-math.atan(0.5))
    r = los_guidance((10.0, -3.0), (0, 0), (100, 0), lookahead=6.0)
    assert r.cross_track == pytest.approx(-3.0)
    assert r.course == pytest.approx(math.atan(0.5))
    assert r.remaining == pytest.approx(90.0)


def test_los_diagonal_leg_and_on_path():
    """Leg from (0,0) to (10,10): the point (0, 2) is left of it by 2/√2 = √2 and 2/√2
    along; on the path the course is the path angle 45°."""
    r = los_guidance((0.0, 2.0), (0, 0), (10, 10), lookahead=1.0)
    assert r.cross_track == pytest.approx(math.sqrt(2))
    assert r.along_track == pytest.approx(math.sqrt(2))
    assert r.course == pytest.approx(math.pi / 4 - math.atan(math.sqrt(2)))
    assert los_guidance((5, 5), (0, 0), (10, 10), 3.0).course == pytest.approx(math.pi / 4)


@settings(max_examples=50, deadline=None)
@given(
    st.floats(-50, 50),
    st.floats(-50, 50),
    st.floats(-math.pi, math.pi),
    st.floats(1, 80),
    st.floats(-20, 20),
    st.floats(-20, 20),
    st.floats(0.5, 20),
)
def test_los_is_rigid_motion_invariant(x0, y0, ang, length, s, e, delta):
    """Placing the vehicle at along-track s and cross-track e of any rotated/translated
    leg returns exactly (s, e) and course = π_p − atan(e/Δ) (the definition)."""
    a = np.array([x0, y0])
    u = np.array([math.cos(ang), math.sin(ang)])
    v = np.array([-u[1], u[0]])
    r = los_guidance(a + s * u + e * v, a, a + length * u, delta)
    assert r.cross_track == pytest.approx(e, abs=1e-9)
    assert r.along_track == pytest.approx(s, abs=1e-9)
    d = (r.course - (ang - math.atan(e / delta)) + math.pi) % (2 * math.pi) - math.pi
    assert abs(d) < 1e-9


def test_lawnmower_leg_count_and_spacing():
    """Width 50 m, swath 20 m, overlap 0.25 → s = 15 m, floor(50/15)+1 = 4 tracks,
    centred: offsets -22.5, -7.5, 7.5, 22.5 (all inside ±25)."""
    m = lawnmower((0, 0), 100.0, 50.0, 20.0, 0.25, speed=1.0, depth=5.0)
    assert lawnmower_spacing(20.0, 0.25) == 15.0
    w = m.waypoints
    assert len(w) == 8
    ys = w[::2, 1]
    np.testing.assert_allclose(sorted(ys), [-22.5, -7.5, 7.5, 22.5])
    np.testing.assert_allclose(np.abs(w[:, 0]), 50.0)
    # boustrophedon: consecutive tracks run in opposite directions
    dirs = np.sign(w[1::2, 0] - w[::2, 0])
    assert np.all(dirs[1:] == -dirs[:-1])


@settings(max_examples=40, deadline=None)
@given(
    st.floats(5, 200),
    st.floats(5, 200),
    st.floats(2, 60),
    st.floats(0, 0.9),
    st.floats(-math.pi, math.pi),
)
def test_lawnmower_spacing_and_full_coverage(length, width, swath, overlap, heading):
    """Tracks are spaced exactly swath·(1−overlap), lie inside the rectangle, and every
    point across the rectangle is within swath/2 of a track (coverage)."""
    m = lawnmower((3.0, -4.0), length, width, swath, overlap, heading=heading, speed=1.0, depth=2.0)
    s = swath * (1 - overlap)
    n = len(m.waypoints) // 2
    assert n == math.floor(width / s + 1e-9) + 1
    v = np.array([-math.sin(heading), math.cos(heading)])
    off = np.sort((m.waypoints[::2] - [3.0, -4.0]) @ v)
    np.testing.assert_allclose(np.diff(off), s, rtol=1e-9, atol=1e-9)
    assert off[0] >= -width / 2 - 1e-9 and off[-1] <= width / 2 + 1e-9
    across = np.linspace(-width / 2, width / 2, 201)
    gap = np.min(np.abs(across[:, None] - off[None, :]), axis=1)
    assert gap.max() <= swath / 2 + 1e-9


def test_loop_closes_and_repeats():
    sq = [(0, 0), (20, 0), (20, 20), (0, 20)]
    m = loop(sq, laps=2, speed=1.0, depth=3.0)
    assert len(m.waypoints) == 9
    np.testing.assert_allclose(m.waypoints[0], m.waypoints[-1])
    assert m.length == pytest.approx(160.0)


@pytest.mark.parametrize(("heading", "laps"), [(0.0, 1), (2.0, 2)])
def test_calibration_loop_is_a_starboard_circle_tangent_to_the_first_line(heading, laps):
    """The loop's vertices lie on a circle of radius R through the point ``at`` m along
    the first line, centred R to starboard of it (tangent there), swept clockwise seen
    from above (a starboard turn) through ``laps`` full turns; the rest is unchanged."""
    base = lawnmower(
        (5, -3), 80.0, 40.0, 10.0, 0.0, speed=1.0, altitude=8.0, heading=heading, spacing=20.0
    )
    r, at, n = 15.0, 30.0, 16
    m = with_calibration_loop(base, at, r, laps=laps, n_per_lap=n)
    u = np.array([math.cos(heading), math.sin(heading)])
    p = base.waypoints[0] + at * u
    centre = p + r * np.array([u[1], -u[0]])  # starboard of the line
    ring = m.waypoints[1 : 2 + n * laps]
    np.testing.assert_allclose(ring[0], p, atol=1e-9)
    np.testing.assert_allclose(ring[-1], p, atol=1e-9)
    np.testing.assert_allclose(np.hypot(*(ring - centre).T), r, atol=1e-9)
    ang = np.unwrap(np.arctan2(*(ring - centre).T[::-1]))
    assert np.all(np.diff(ang) < 0) and ang[0] - ang[-1] == pytest.approx(2 * math.pi * laps)
    np.testing.assert_array_equal(m.waypoints[2 + n * laps :], base.waypoints[1:])
    chord = 2 * r * math.sin(math.pi / n)
    assert m.length == pytest.approx(base.length + n * laps * chord)


def test_straight_line_and_hold():
    m = straight_line((0, 0), (30, 40), speed=1.2, altitude=5.0)
    assert m.n_legs == 1 and m.length == pytest.approx(50.0)
    h = hold((1, 2), duration=10.0, depth=4.0)
    assert h.hold_time == 10.0 and h.n_legs == 0


def test_mission_leaving_world_names_waypoint_and_bounds():
    b = WorldBounds(-100, 100, -100, 100, max_depth=30.0)
    m = lawnmower((90, 0), 40.0, 20.0, 10.0, 0.0, speed=1.0, depth=5.0)
    with pytest.raises(ValueError, match=r"waypoint 1 at \(110, -10\).*x in \[-100, 100\]"):
        m.validate_bounds(b)
    with pytest.raises(ValueError, match="below the seabed"):
        straight_line((0, 0), (10, 0), speed=1.0, depth=40.0).validate_bounds(b)
    straight_line((0, 0), (10, 0), speed=1.0, depth=10.0).validate_bounds(b)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: lawnmower((0, 0), 10, 10, 5, 1.0, speed=1, depth=1), "overlap"),
        (lambda: lawnmower((0, 0), 10, -1, 5, 0.1, speed=1, depth=1), "width"),
        (lambda: straight_line((0, 0), (0, 0), speed=1, depth=1), "coincide"),
        (lambda: straight_line((0, 0), (1, 0), speed=-1, depth=1), "speed"),
        (lambda: straight_line((0, 0), (1, 0), speed=1), "exactly one of depth or altitude"),
        (lambda: loop([(0, 0)], speed=1, depth=1), "N >= 2"),
        (lambda: straight_line((0, 0), (np.nan, 0), speed=1, depth=1), "not finite"),
        (
            lambda: with_calibration_loop(straight_line((0, 0), (10, 0), speed=1, depth=1), 12, 5),
            r"inside the first leg \(0, 10\) m, got 12",
        ),
        (
            lambda: with_calibration_loop(straight_line((0, 0), (10, 0), speed=1, depth=1), 5, 0),
            "radius",
        ),
    ],
)
def test_bad_mission_input(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_plot_mission_track_draws_plan_and_track():
    """The figure holds the plan polyline and the flown track with the given data."""
    from sim.guidance.plots import plot_mission_track

    m = loop([(0, 0), (10, 0), (10, 10)], speed=1.0, depth=2.0)
    track = np.array([[0.0, 0.0], [5.0, 0.5], [10.0, 1.0]])
    fig = plot_mission_track(m, track, cross_track=[0.0, 0.5, 1.0], t=[0.0, 1.0, 2.0])
    ax = fig.axes[0]
    flown = next(ln for ln in ax.lines if ln.get_label() == "flown")
    np.testing.assert_allclose(flown.get_xydata(), track)
    assert len(fig.axes) == 2
    with pytest.raises(ValueError, match="track_xy"):
        plot_mission_track(m, np.zeros(5))
