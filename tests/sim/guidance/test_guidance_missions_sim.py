"""Every mission type flown to completion by every vehicle in the MuJoCo world.

Independent expectation for the cross-track bound: with perfect heading tracking the
lookahead LOS law makes the cross-track error obey ė = −U e / sqrt(Δ² + e²) (Fossen 2011
§10.3.2), i.e. it decays at least like e₀ exp(−s/Δ) along the path. A leg is entered
with |e₀| <= the acceptance radius (2 m), so after 2Δ along the leg the kinematic bound
is 2·e⁻² ≈ 0.27 m; the test allows 1.0 m for the vehicle dynamics (thruster lag,
saturation, Munk moment) and states the bounds below. Missions are sized in lookaheads
Δ and cruise speeds U of each vehicle so that all runs stay CI-fast; a larger variant is
marked slow. A vehicle whose steady turn radius R exceeds 2 m (IXN at 1 m/s) accepts a
waypoint within R, so it enters the next leg with |e₀| <= R: the same kinematic bound
(0.27 m) is then reached after 2Δ + Δ ln(R / 2 m) along the leg (``settle_distance``),
and its legs are lengthened by that much so that every leg has a settled part.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.guidance import lawnmower, loop, straight_line
from sim.guidance.world_adapter import autopilot_for, gains_for
from sim.world import VEHICLE_KINDS, VehicleSpec, WorldSpec, build_world
from sim.world.seabed import SeabedSpec

DEPTH = 6.0  # m, mission depth; the vehicles start at 5 m
CONTROL_DT = 0.1  # s
SETTLED_CROSS_TRACK = 1.0  # m, |e| once 2Δ along a leg (kinematic LOS bound 0.27 m)
DEPTH_TOLERANCE = 0.6  # m, |depth - demand| after the first DEPTH_SETTLE s
DEPTH_SETTLE = 20.0  # s
ACCEPTANCE = 2.0  # m


# flat bottom on a 2 m grid: the 0.25 m default makes a mesh of ~0.4 M vertices
# (160 m square) that costs seconds of MuJoCo compile per world; nothing here needs it
@pytest.fixture(scope="module", params=VEHICLE_KINDS)
def world_kind(request):
    kind = request.param
    spec = WorldSpec(
        seabed=SeabedSpec(kind="flat", size_xy=(160.0, 160.0), resolution=2.0, depth=20.0),
        vehicles=(VehicleSpec(kind, position=(0.0, 0.0, -5.0)),),
    )
    return build_world(spec), kind


def settle_distance(D: float, R: float) -> float:
    """Along-track distance after which |e| is checked: 2Δ for an entry error <= 2 m,
    2Δ + Δ ln(R / 2) when the waypoint acceptance radius is the turn radius R > 2 m (same
    kinematic bound e₀ exp(−s/Δ) <= 2 e⁻²)."""
    return 2 * D + D * math.log(max(R, ACCEPTANCE) / ACCEPTANCE)


def make_mission(kind_of_mission: str, U: float, D: float, scale: float = 1.0, R: float = 0.0):
    """Mission sized in lookaheads D and cruise speeds U; R is the vehicle's steady turn
    radius at U (a waypoint is accepted within R: legs are lengthened by R plus the extra
    settle distance so that part of each leg lies beyond it, and lawnmower tracks are spaced at least 2R — a turn
    diameter — as a real survey plan would)."""
    extra = settle_distance(D, R) - 2 * D + R
    if kind_of_mission == "line":
        # starts 3 m to port of the vehicle's track: exercises LOS convergence
        length = max(4 * D, 30 * U) * scale + extra
        return straight_line(
            (2.0, 3.0),
            (2.0 + length, 3.0),
            speed=U,
            depth=DEPTH,
            acceptance_radius=ACCEPTANCE,
        )
    if kind_of_mission == "loop":
        a = 3 * D * scale + extra
        return loop(
            [(2.0, 0.0), (2.0 + a, 0.0), (2.0 + a, a), (2.0, a)],
            speed=U,
            depth=DEPTH,
            laps=1 if scale == 1.0 else 2,
            acceptance_radius=ACCEPTANCE,
        )
    if kind_of_mission == "lawnmower":
        # 3 tracks (5 when slow) of length 4Δ (+ R) spaced max(Δ, 2R) = swath (1 - 0.2)
        n = 3 if scale == 1.0 else 5
        sp = max(D, 2 * R)
        track = 4 * D * scale + extra
        return lawnmower(
            (2.0 + track / 2, (n - 1) * sp / 2),
            track,
            (n - 1) * sp,
            swath_width=sp / 0.8,
            overlap=0.2,
            speed=U,
            depth=DEPTH,
            acceptance_radius=ACCEPTANCE,
        )
    raise AssertionError(kind_of_mission)


def fly(world, kind, mission):
    world.reset()
    ap = autopilot_for(world, kind, mission)
    h = world.vehicles[kind]
    n = round(CONTROL_DT / world.timestep)
    D = ap.gains.lookahead
    s_settle = settle_distance(D, ap.acceptance)
    t_max = 2.5 * (mission.length + 10.0) / mission.speed + 30.0
    settled, anywhere, depth_err = [], [], []
    while world.time < t_max and not ap.done:
        s = h.state()
        h.apply_wrench_demand(ap.update(s, CONTROL_DT))
        world.step(n)
        st = ap.status
        assert np.all(np.isfinite(s.position))
        if st.on_survey_leg and not st.done:
            anywhere.append(abs(st.cross_track))
            if s_settle < st.along_track:
                settled.append(abs(st.cross_track))
        if s.t > DEPTH_SETTLE:
            depth_err.append(abs(s.depth - DEPTH))
    return ap, np.array(settled), np.array(anywhere), np.array(depth_err), t_max


# "loop" (the slowest: up to 90 s per vehicle on a loaded 2-core machine) runs with -m slow;
# "line" and "lawnmower" keep every vehicle's straight legs and turns in CI
@pytest.mark.parametrize(
    "mission_type", ["line", pytest.param("loop", marks=pytest.mark.slow), "lawnmower"]
)
def test_mission_flown_to_completion_with_bounded_cross_track(world_kind, mission_type):
    """Completion within 2.5x the nominal time; |e| <= 1.0 m after 2Δ along each leg;
    |e| never beyond max(acceptance radius, Δ) + 1 m on a survey leg (turn overshoot
    bounded by the leg spacing scale); depth within 0.6 m after 20 s."""
    world, kind = world_kind
    g = gains_for(world, kind)
    m = make_mission(mission_type, g.cruise_speed, g.lookahead, R=g.turn_radius)
    ap, settled, anywhere, depth_err, t_max = fly(world, kind, m)
    assert ap.done, f"{kind} {mission_type}: not complete after {t_max:.0f} s ({ap.status})"
    assert ap.status.progress == 1.0
    assert len(settled) > 10 and len(depth_err) > 10
    assert settled.max() <= SETTLED_CROSS_TRACK, (kind, mission_type, settled.max())
    assert anywhere.max() <= max(ACCEPTANCE, g.lookahead) + 1.0, (kind, anywhere.max())
    assert depth_err.max() <= DEPTH_TOLERANCE, (kind, mission_type, depth_err.max())


@pytest.mark.slow
@pytest.mark.parametrize("mission_type", ["loop", "lawnmower"])
def test_long_missions_flown_to_completion(world_kind, mission_type):
    """Larger variant (2 laps, 5 tracks, 2x longer legs): same bounds. Flown over a
    400 m seabed (IXN's 10 m lookahead makes its long missions ~110 m wide)."""
    _, kind = world_kind
    world = build_world(
        WorldSpec(
            seabed=SeabedSpec(kind="flat", size_xy=(400.0, 400.0), resolution=2.0, depth=20.0),
            vehicles=(VehicleSpec(kind, position=(0.0, 0.0, -5.0)),),
        )
    )
    g = gains_for(world, kind)
    m = make_mission(mission_type, g.cruise_speed, g.lookahead, scale=2.0, R=g.turn_radius)
    ap, settled, anywhere, depth_err, t_max = fly(world, kind, m)
    assert ap.done, f"{kind} {mission_type}: not complete after {t_max:.0f} s"
    assert settled.max() <= SETTLED_CROSS_TRACK
    assert anywhere.max() <= max(ACCEPTANCE, g.lookahead) + 1.0
    assert depth_err.max() <= DEPTH_TOLERANCE


def test_mission_leaving_the_world_is_rejected(world_kind):
    """A lawnmower whose far tracks lie beyond the 160 m seabed: ValueError naming the
    waypoint and the allowed bounds (never a MuJoCo crash)."""
    world, kind = world_kind
    m = lawnmower((70.0, 0.0), 40.0, 20.0, 10.0, 0.0, speed=1.0, depth=DEPTH)
    with pytest.raises(ValueError, match=r"waypoint 1 at \(90, -10\).*x in \[-80, 80\]"):
        autopilot_for(world, kind, m)
    deep = straight_line((0.0, 0.0), (10.0, 0.0), speed=1.0, depth=25.0)
    with pytest.raises(ValueError, match="reaches the seabed"):
        autopilot_for(world, kind, deep)
    assert math.isfinite(gains_for(world, kind).cruise_speed)


def test_too_fast_mission_speed_is_capped_with_a_warning(world_kind):
    """A 4 m/s mission exceeds every vehicle's thrust (U_max from d_l U + d_q U² = X_max):
    the autopilot_for call warns and the speed demand is the vehicle's cruise limit."""
    world, kind = world_kind
    m = straight_line((0.0, 0.0), (30.0, 0.0), speed=4.0, depth=DEPTH)
    with pytest.warns(UserWarning, match="cannot hold the mission speed"):
        ap = autopilot_for(world, kind, m)
    assert ap.speed == pytest.approx(gains_for(world, kind, 4.0).cruise_speed)
    assert ap.speed < 4.0
