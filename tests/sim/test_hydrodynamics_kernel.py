"""The compiled step (sim.physics_kernel) against the numpy model it replaced, kept as
tests/helpers/hydro_reference.py: same forces, accelerations, thruster states and
trajectories to 1e-9."""

from __future__ import annotations

import numpy as np
import pytest
from hydro_reference import ReferenceHydroBatch, random_hydro_params, reference_step
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.frames import matrix_from_wxyz
from sim.hydrodynamics import HydroBatch
from sim.thrusters import ThrusterBank, ThrusterSpec
from sim.world import SeabedSpec, VehicleSpec, WorldSpec, build_world
from sim.world.currents import CurrentSpec

RHO = 1025.0
SEABED = SeabedSpec(kind="ripples", size_xy=(120.0, 120.0), resolution=1.0, depth=30.0, seed=3)


def _random_bank(rng, n, dt=0.01):
    """n vehicles with a propeller and a fin pair each (random geometry and gains)."""
    specs = []
    for _ in range(n):
        d = rng.normal(size=(2, 3))
        specs.append(
            [
                ThrusterSpec("p", "propeller", rng.uniform(10, 100), rng.uniform(5, 80),
                             rng.uniform(0.05, 0.5), tuple(rng.normal(0, 0.5, 3)), tuple(d[0])),
                ThrusterSpec("f", "fin", rng.uniform(1, 20), rng.uniform(1, 20),
                             rng.uniform(0.05, 0.5), tuple(rng.normal(0, 0.5, 3)), tuple(d[1]),
                             lift_gain=rng.uniform(1, 30)),
            ]
        )  # fmt: skip
    return ThrusterBank(specs, dt)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans(), st.booleans())
def test_kernel_wrench_equals_both_numpy_references(seed, with_current, with_thrusters):
    """Second implementations: the quadratic-form and term-by-term numpy evaluations of
    the same model, with the numpy ThrusterBank.step, agree with the kernel to 1e-9."""
    rng = np.random.default_rng(seed)
    n = 3
    params = random_hydro_params(rng, n)
    q = rng.normal(size=(n, 4))
    rot = matrix_from_wxyz(q / np.linalg.norm(q, axis=1, keepdims=True))
    pos = rng.normal(0, 1, (n, 3)) - [0, 0, 0.3]  # some vehicles breaking the surface
    vel = rng.normal(0, 1, (n, 3))
    om = rng.normal(0, 0.5, (n, 3))
    cur = rng.normal(0, 0.5, (n, 3)) if with_current else None
    tau = rng.normal(0, 20, (n, 6))
    banks = [_random_bank(np.random.default_rng(seed), n) for _ in range(3)]
    for b in banks:
        b.command[:] = np.random.default_rng(seed + 1).uniform(-1, 1, b.n)
        b.level[:] = np.random.default_rng(seed + 2).uniform(-1, 1, b.n)
    th = banks if with_thrusters else [None] * 3
    hb = HydroBatch(params, RHO, 9.81, 0.0)
    ref = ReferenceHydroBatch(params, RHO, 9.81, 0.0)
    got = hb.body_wrench(rot, pos, vel, om, cur, tau, th[0])
    want_q = ref.body_wrench(rot, pos, vel, om, cur, tau, th[1])
    acc_q = ref.last_accel.copy()
    want_e = ref.body_wrench_explicit(rot, pos, vel, om, cur, tau, th[2])
    for want, acc in ((want_q, acc_q), (want_e, ref.last_accel)):
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(hb.last_accel, acc, rtol=1e-9, atol=1e-9)
    if with_thrusters:
        np.testing.assert_allclose(banks[0].level, banks[1].level, rtol=0, atol=1e-15)
        np.testing.assert_allclose(banks[0].force, banks[1].force, rtol=1e-12, atol=1e-12)


def _pair(kinds, current):
    def one():
        vs = tuple(
            VehicleSpec(k, position=(-30.0 + 20.0 * i, 0.0, -15.0)) for i, k in enumerate(kinds)
        )
        return build_world(WorldSpec(seabed=SEABED, vehicles=vs, current=current))

    return one(), one()


@pytest.mark.parametrize(
    "current",
    [CurrentSpec(), CurrentSpec(velocity=(0.3, -0.1, 0.0), variation=0.15, seed=2)],
    ids=["still", "varying"],
)
def test_world_step_follows_the_numpy_step_to_1e9(current):
    """The five vehicle kinds driven by random commands in mid-water for 20 s: the compiled
    step and the pre-kernel numpy step (mj_step1 → numpy forces → mj_step2) give the same
    states, thruster levels and accelerations. (Mid-water: through a seabed contact the
    rounding-level differences of the two evaluations grow like any perturbation does.)"""
    kinds = ("alister9", "ixn", "naiad", "saga", "rexrov")
    a, b = _pair(kinds, current)
    ref = ReferenceHydroBatch(b._hydro_params, b.water.density, b.water.gravity, 0.0)
    rng = np.random.default_rng(7)
    contacts = 0
    for _ in range(200):
        for ha, hb_ in zip(a.vehicles.values(), b.vehicles.values()):
            u = rng.uniform(-1, 1, ha.n_thrusters)
            ha.set_thruster_commands(u)
            hb_.set_thruster_commands(u)
        a.step(10)
        reference_step(b, ref, 10)
        contacts += a.data.ncon
    assert a.data.time == b.data.time
    assert contacts == 0  # the comparison is the free-water model
    np.testing.assert_allclose(a.data.qpos, b.data.qpos, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.data.qvel, b.data.qvel, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.thrusters.level, b.thrusters.level, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.hydro.last_accel, ref.last_accel, rtol=1e-9, atol=1e-9)


def test_body_wrench_compiles_one_specialisation_for_any_input_layout():
    """Read-only broadcast views, exact-shape writable arrays and per-vehicle rows all
    reach the kernel as writable C arrays, so numba compiles it once per process (a
    read-only argument is a different numba type and would compile another version)."""
    from numba import types

    from sim.physics_kernel import wrench_batch

    rng = np.random.default_rng(5)
    n = 2
    hb = HydroBatch(random_hydro_params(rng, n), RHO, 9.81, 0.0)
    rot = np.broadcast_to(np.eye(3), (n, 3, 3))  # read-only view
    inputs = [
        (rot, np.zeros(3), np.ones((n, 3)), np.zeros(3), None, np.zeros(6)),
        (np.ascontiguousarray(rot), np.zeros((n, 3)), [0.5, 0.0, 0.0], np.zeros((n, 3)),
         np.zeros(3), np.zeros((n, 6))),
    ]  # fmt: skip
    before = len(wrench_batch.signatures)
    outs = [hb.body_wrench(*a) for a in inputs]
    assert all(np.isfinite(o).all() for o in outs)
    assert len(wrench_batch.signatures) - before <= 1
    arrays = [t for sig in wrench_batch.signatures for t in sig if isinstance(t, types.Array)]
    assert arrays and all(t.mutable for t in arrays)
