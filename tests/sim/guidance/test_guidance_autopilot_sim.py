"""Autopilot features in the MuJoCo world, one representative vehicle each (CI-fast):
altitude following (flat seabed: depth = seabed depth − altitude, exact), station
keeping, integral LOS against a cross current (LOS theory: plain LOS leaves a steady
cross-track offset e = Δ tan β_c in a cross current, integral LOS removes it), and the
dead reckoner fed by the nav sensors on the simulated states (error inside 3σ of its
propagated covariance)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.guidance import hold, straight_line
from sim.guidance.world_adapter import autopilot_for, gains_for
from sim.navigation import NavSuite, NavSuiteConfig, true_increment
from sim.world import VehicleSpec, WorldSpec, build_world
from sim.world.currents import CurrentSpec
from sim.world.seabed import SeabedSpec

SEABED_DEPTH = 20.0
CURRENT = 0.2  # m/s


# flat bottom on a 2 m grid: the 0.25 m default makes a mesh of ~0.4 M vertices
# (160 m square) that costs seconds of MuJoCo compile per world; nothing here needs it
def make_world(kind, current=(0.0, 0.0, 0.0)):
    return build_world(
        WorldSpec(
            seabed=SeabedSpec(
                kind="flat", size_xy=(160.0, 160.0), resolution=2.0, depth=SEABED_DEPTH
            ),
            vehicles=(VehicleSpec(kind, position=(0.0, 0.0, -5.0)),),
            current=CurrentSpec(velocity=current),
        )
    )


def run(world, kind, ap, t_max, dt=0.1, each=None):
    h = world.vehicles[kind]
    n = round(dt / world.timestep)
    while world.time < t_max and not ap.done:
        s = h.state()
        h.apply_wrench_demand(ap.update(s, dt))
        world.step(n)
        if each is not None:
            each(s, ap.status)
    return h.state()


def test_altitude_mission_holds_altitude_over_flat_seabed():
    """Altitude 8 m over a 20 m flat seabed is depth 12 m: |altitude − 8| < 0.5 m once
    settled (after 40 s)."""
    world = make_world("saga")
    g = gains_for(world, "saga")
    m = straight_line(
        (2.0, 0.0), (2.0 + 40 * g.cruise_speed, 0.0), speed=g.cruise_speed, altitude=8.0
    )
    errs = []

    def each(s, st):
        if s.t > 40.0:
            errs.append(abs(s.altitude - 8.0))
            assert st.depth_desired == pytest.approx(SEABED_DEPTH - 8.0, abs=0.3)

    run(world, "saga", autopilot_for(world, "saga", m), 120.0, each=each)
    assert len(errs) > 50 and max(errs) < 0.5


def test_station_keeping_holds_position():
    """hold(): reach the point, then stay within 1 m of it for 20 s; mission done after."""
    world = make_world("naiad")
    m = hold((4.0, 2.0), duration=20.0, depth=6.0)
    ap = autopilot_for(world, "naiad", m)
    dist = []

    def each(s, st):
        if ap.leg >= ap.status.n_legs and ap._hold_start is not None and s.t > ap._hold_start + 5:
            dist.append(math.hypot(s.position[0] - 4.0, s.position[1] - 2.0))

    run(world, "naiad", ap, 120.0, each=each)
    assert ap.done and len(dist) > 100
    assert max(dist) < 1.0


def _cross_track_in_current(sigma):
    # the torpedo has no sway authority: only the guidance law can fight the current
    world = make_world("alister9", current=(0.0, CURRENT, 0.0))  # north, across an east leg
    g = gains_for(world, "alister9")
    m = straight_line((2.0, 0.0), (2.0 + 70.0, 0.0), speed=g.cruise_speed, depth=6.0)
    ap = autopilot_for(world, "alister9", m, ilos_sigma=sigma, crab_time_constant=0.0)
    es = []

    def each(s, st):
        if st.on_survey_leg and st.along_track > 45.0:
            es.append(st.cross_track)

    run(world, "alister9", ap, 200.0, each=each)
    return np.array(es), g


def test_integral_los_removes_the_current_offset():
    """Plain LOS (no crab compensation) settles at e ≈ Δ tan(β_c) to port when a
    0.2 m/s current pushes north across an eastbound leg, β_c = atan(0.2/U) — the
    crab angle the heading must hold; integral LOS brings the mean |e| below 0.3 m."""
    e_plain, g = _cross_track_in_current(0.0)
    e_ilos, _ = _cross_track_in_current(0.5)
    beta_c = math.atan(CURRENT / g.cruise_speed)
    expected = g.lookahead * math.tan(beta_c)
    assert e_plain.mean() == pytest.approx(expected, rel=0.35)
    assert abs(e_ilos.mean()) < 0.3 < abs(e_plain.mean())


def test_dead_reckoning_on_simulated_states_is_consistent():
    """Nav suite on the true states of an alister9 line: each 5 s odometry increment's
    error against the true increment lies inside the χ²(3) 99.9 % gate of its own
    covariance for at least 90 % of the intervals (consistency on real dynamics:
    turning, pitching, DVL dropouts). The increments' own (marginal) covariances: the
    default matched covariance is built for SLAM's recursion and may be singular alone."""
    from scipy import stats

    world = make_world("alister9")
    g = gains_for(world, "alister9")
    m = straight_line((5.0, 10.0), (60.0, 10.0), speed=g.cruise_speed, depth=8.0)
    ap = autopilot_for(world, "alister9", m)
    suite = NavSuite(NavSuiteConfig(matched_odometry_covariance=False), np.random.default_rng(3))
    gate = stats.chi2.ppf(0.999, 3)
    nees = []
    start = None

    def each(s, st):
        nonlocal start
        suite.poll(s)
        if start is None:
            start = s
        if s.t - start.t >= 5.0 - 1e-9:
            inc = suite.odometry(s.t)
            p0 = np.array([*start.position[:2], start.euler[2]])
            p1 = np.array([*s.position[:2], s.euler[2]])
            e = inc.delta - true_increment(p0, p1)
            e[2] = (e[2] + math.pi) % (2 * math.pi) - math.pi
            nees.append(float(e @ np.linalg.solve(inc.cov, e)))
            start = s

    run(world, "alister9", ap, 90.0, each=each)
    assert len(nees) >= 6
    assert np.mean(np.array(nees) < gate) >= 0.9, nees
