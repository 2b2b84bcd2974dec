"""Each vehicle reaches and holds its nominal survey speed (sources: the vehicle READMEs)
without a limit cycle.

Independent expectations: the cruise speed the gain design allows is the nominal speed
(within 1 %: SAGA's thrust reserve caps it at 0.497 of 0.5 m/s); an asymptotically
stable closed loop returns to the straight-line equilibrium after a small heading
disturbance, so after 60 s the yaw rate is steady (std < 0.01 rad/s; the loop that
limit-cycled before these changes oscillated with a yaw-rate std of 0.5–1 rad/s), the
speed equals the demand within 1 % and the pitch stays within 1°.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.frames import wxyz_from_euler
from sim.guidance import NOMINAL_SPEED, straight_line
from sim.guidance.world_adapter import autopilot_for, gains_for
from sim.world import VEHICLE_KINDS, VehicleSpec, WorldSpec, build_world
from sim.world.seabed import SeabedSpec


# CI flies two of the vehicles (alister9, ixn: 100-120 s each on a
# loaded 2-core machine); the other vehicles run with -m slow
# flat bottom on a 2 m grid: the 0.25 m default makes a 0.3 M-vertex mesh over 300 m x 60 m
# that costs seconds of MuJoCo compile per world; nothing here needs it
@pytest.mark.parametrize(
    "kind",
    [
        k if k in ("alister9", "ixn") else pytest.param(k, marks=pytest.mark.slow)
        for k in VEHICLE_KINDS
    ],
)
def test_vehicle_holds_nominal_speed_without_limit_cycle(kind):
    w = build_world(
        WorldSpec(
            seabed=SeabedSpec(kind="flat", size_xy=(300.0, 60.0), resolution=2.0, depth=30.0),
            vehicles=(VehicleSpec(kind, position=(-140.0, 0.0, -6.0)),),
        )
    )
    g = gains_for(w, kind)
    assert g.cruise_speed >= 0.99 * NOMINAL_SPEED[kind], (kind, g.cruise_speed)
    m = straight_line((-135.0, 0.0), (140.0, 0.0), speed=NOMINAL_SPEED[kind], depth=6.0)
    ap = autopilot_for(w, kind, m)
    h = w.vehicles[kind]
    # at cruise speed, heading 0.05 rad off the track
    h.set_pose((-140.0, 0.0, -6.0), wxyz_from_euler(0.0, 0.0, 0.05), velocity_body=(ap.speed, 0, 0))
    rec = []
    while w.time < 120.0:
        s = h.state()
        h.apply_wrench_demand(ap.update(s, 0.1))
        w.step(10)
        if s.t > 60.0:
            rec.append((s.angular_velocity_body[2], np.hypot(*s.velocity_world[:2]), s.euler[1]))
    r = np.array(rec)
    assert r[:, 0].std() < 0.01, (kind, r[:, 0].std())
    assert r[:, 1].mean() == pytest.approx(ap.speed, rel=0.01)
    assert np.abs(r[:, 2]).max() < np.radians(1.0)
