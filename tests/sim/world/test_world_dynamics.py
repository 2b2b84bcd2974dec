"""World-level dynamics: Archimedes at the surface, reset determinism, several vehicles in
one vectorized world, drift in the seeded varying current field."""

from __future__ import annotations

import numpy as np
import pytest

from sim.world import CurrentSpec, SeabedSpec, VehicleSpec, WorldSpec, build_world

SMALL = SeabedSpec(kind="flat", size_xy=(200.0, 200.0), resolution=4.0, depth=40.0)


@pytest.mark.parametrize("kind,excess", [("saga", 0.1), ("naiad", 0.05)])
def test_positively_buoyant_vehicle_floats_at_archimedes_draft(kind, excess):
    """Buoyancy ∝ submerged fraction of the height: B(1+f)·s = W ⇒ s = 1/(1+f), i.e. the CG
    settles at z = h (1/2 − s) (with CB above CG the attitude stays level)."""
    w = build_world(
        WorldSpec(
            seabed=SMALL, vehicles=(VehicleSpec(kind, position=(0, 0, -1.0), net_buoyancy=excess),)
        )
    )
    v = w.vehicles[kind]
    w.step(6000)
    h = v.model.envelope[2]
    s = 1.0 / (1.0 + excess)
    assert v.state().position[2] == pytest.approx(h * (0.5 - s), abs=2e-3)
    assert abs(v.state().velocity_body).max() < 1e-3


def test_reset_reproduces_the_same_trajectory():
    w = build_world(WorldSpec(seabed=SMALL, vehicles=("alister9", "saga")))

    def run():
        w.vehicles["alister9"].set_thruster_commands([0.8, 0.3, -0.2])
        w.vehicles["saga"].set_thruster_commands([0.5, -0.5, 0.2, 0.1, 0.3])
        w.step(300)
        return w.data.qpos.copy()

    a = run()
    w.reset()
    assert w.time == 0.0
    b = run()
    np.testing.assert_array_equal(a, b)


def test_four_swarms_vehicles_in_one_world_match_each_alone():
    """Second implementation: the vectorized 4-vehicle pass gives each vehicle the same
    trajectory as a world holding it alone (vehicles kept apart so no contacts)."""
    kinds = ("alister9", "ixn", "naiad", "saga")
    pos = {k: (-30.0 + 20.0 * i, 10.0, -15.0) for i, k in enumerate(kinds)}
    cmds = {
        "alister9": [0.7, 0.2, -0.1],
        "ixn": [0.5, 0.4, 0.1, -0.1, 0.2, 0.0, 0.3, -0.2],
        "naiad": [0.3, 0.1, -0.2, 0.4, 0.2, 0.1],
        "saga": [0.2, 0.5, -0.3, 0.1, -0.2],
    }
    cur = CurrentSpec(velocity=(0.2, -0.1, 0.0), variation=0.1, length_scale=40.0, seed=5)
    both = build_world(
        WorldSpec(
            seabed=SMALL,
            current=cur,
            vehicles=tuple(VehicleSpec(k, position=pos[k]) for k in kinds),
        )
    )
    for k in kinds:
        both.vehicles[k].set_thruster_commands(cmds[k])
    both.step(500)
    for k in kinds:
        one = build_world(
            WorldSpec(seabed=SMALL, current=cur, vehicles=(VehicleSpec(k, position=pos[k]),))
        )
        one.vehicles[k].set_thruster_commands(cmds[k])
        one.step(500)
        np.testing.assert_allclose(
            both.vehicles[k].state().position, one.vehicles[k].state().position, atol=1e-9
        )


def test_unpowered_vehicle_follows_the_varying_current():
    """Slowly varying field (100 m, 30 min, rms 0.4 m/s): a well-damped ROV moves with the
    local current. It lags the current it sees by its velocity time constant
    τ = (m + A)/D_l ≈ 2.3 s times the current's material derivative ≈ (2π/100 m)·0.4²
    ≈ 0.01 m/s², i.e. ≈ 0.025 m/s; the bound is 0.04 m/s (10 % of the field)."""
    cur = CurrentSpec(
        velocity=(0.0, 0.0, 0.0), variation=0.4, length_scale=100.0, time_scale=1800.0, seed=11
    )
    w = build_world(
        WorldSpec(seabed=SMALL, current=cur, vehicles=(VehicleSpec("saga", position=(0, 0, -15)),))
    )
    v = w.vehicles["saga"]
    w.step(6000)
    s = v.state()
    rel = s.velocity_world - s.water_velocity_world
    assert np.linalg.norm(s.water_velocity_world) > 0.05
    assert np.linalg.norm(rel) < 0.1 * 0.4
