"""Gain design: actuator authority of the least-squares allocation against hand-worked
thruster layouts, and the designed loops against the closed-form responses the design
rules promise (first-order surge loop with time constant 1/ω_u)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.guidance import PID, VehiclePlant, design_gains, max_wrench
from sim.hydrodynamics import HydroParams
from sim.thrusters import ThrusterSpec

ALL = np.ones(6, bool)


def twin_stern(F=50.0, R=30.0, d=0.2):
    """Two stern thrusters at y = ±d pushing +x (hand-worked: X_max = 2F; N_max: one
    forward at F, the other reverse must give the same magnitude → limited by R:
    N = 2·R·d; reverse X would be 2R)."""
    return [
        ThrusterSpec("p", "propeller", F, R, 0.1, (-0.5, d, 0.0), (1, 0, 0)),
        ThrusterSpec("s", "propeller", F, R, 0.1, (-0.5, -d, 0.0), (1, 0, 0)),
    ]


def test_max_wrench_twin_stern_thrusters():
    dofs = np.array([1, 0, 0, 0, 0, 1], bool)
    tmax = max_wrench(twin_stern(), dofs, speed=1.0)
    assert tmax[0] == pytest.approx(100.0)
    assert tmax[5] == pytest.approx(2 * 30.0 * 0.2)
    assert np.all(tmax[[1, 2, 3, 4]] == 0)


def test_max_wrench_fin_scales_with_speed_squared():
    """Fin lift ∝ u|u|: yaw authority of a rudder at 2 m/s is 4x that at 1 m/s."""
    fin = [ThrusterSpec("rudder", "fin", 10.0, 10.0, 0.1, (-1.0, 0, 0), (0, 1, 0))]
    dofs = np.array([0, 0, 0, 0, 0, 1], bool)
    a = max_wrench(fin, dofs, 1.0)[5]
    b = max_wrench(fin, dofs, 2.0)[5]
    assert a == pytest.approx(10.0 * 1.0)  # lever 1 m × g·u²
    assert b == pytest.approx(4 * a)


def make_plant(max_effort=(100.0, 50, 80, 5, 10, 20), controlled=ALL, mass=50.0):
    hydro = HydroParams(
        mass=mass,
        inertia=np.array([2.0, 5.0, 5.0]),
        volume=mass / 1025.0,
        r_cb=np.array([0, 0, 0.02]),
        added_mass=np.array([5.0, 40, 40, 0.5, 3, 3]),
        linear_damping=np.array([10.0, 20, 20, 1, 2, 2]),
        quadratic_damping=np.array([30.0, 60, 60, 1, 3, 3]),
        height=0.3,
    )
    return VehiclePlant.from_hydro(
        "ixn", 1.5, hydro, np.array(max_effort, float), np.asarray(controlled, bool)
    )


def test_plant_from_hydro_adds_added_mass_and_caps_cruise_speed():
    p = make_plant(max_effort=(20.0, 50, 80, 5, 10, 20))
    np.testing.assert_allclose(p.inertia, [55, 90, 90, 2.5, 8, 8])
    # steady drag at cruise = 0.8 X_max: 10 U + 30 U² = 16 → U = (-10 + sqrt(100 + 1920)) / 60
    u_cruise = (-10 + math.sqrt(100 + 4 * 30 * 16)) / 60
    assert p.cruise_speed == pytest.approx(min(1.0, u_cruise))
    assert p.stiffness[3] == pytest.approx(50.0 * 9.80665 * 0.02)  # ρ g V · BG, V = m/ρ


def test_surge_loop_is_first_order_with_designed_bandwidth():
    """On the linearised surge plant M u' = X − d u (d at cruise), the designed PI plus
    feedforward gives u(t) = U_0 + (U_1 − U_0)(1 − e^{−ω_u t}) for a small step
    (closed form of the pole-zero-cancelled loop)."""
    p = make_plant()
    g = design_gains(p)
    M = p.inertia[0]
    U0 = p.cruise_speed
    d = p.linear_damping[0] + 2 * p.quadratic_damping[0] * U0
    w_u = min(max(2 * d / M, 0.1), 1.0)
    pid = PID(g.surge)
    pid.integral = 0.0
    dt, T, step = 1e-3, 6.0 / w_u, 0.05
    u = U0
    ts, us = [], []
    for k in range(round(T / dt)):
        # linearised plant about U0 with the feedforward balancing the trim point
        X = pid.update(U0 + step - u, dt) + d * U0
        u += dt * (X - d * u) / M
        ts.append((k + 1) * dt)
        us.append(u)
    expected = U0 + step * (1 - np.exp(-w_u * np.array(ts)))
    assert np.max(np.abs(np.array(us) - expected)) < 0.01 * step


def test_second_order_gains_place_poles_at_designed_frequency():
    """kp = M ω² − k, kd = 2 sqrt(kp M) − d: with the destabilising Munk stiffness k < 0
    the closed loop M s² + (d + kd) s + (k + kp) has the designed ω² as the product of its
    roots and both roots real and stable (ζ >= 1); without k (sideslip suppressed) the
    loop M s² + (d + kd) s + kp has a double root at −sqrt(kp / M) (critical damping)."""
    p = make_plant()
    g = design_gains(p)
    M, k = p.inertia[5], p.stiffness[5]
    assert k < 0
    d = p.linear_damping[5] + 2 * p.quadratic_damping[5] * 0.2
    w = min(max(math.sqrt(20 / (M * 0.5)), 0.1), 1.0)
    roots = np.roots([M, d + g.heading.kd, k + g.heading.kp])
    assert np.all(np.abs(roots.imag) < 1e-9) and np.all(roots.real < 0)
    assert np.prod(roots).real == pytest.approx(w * w, rel=1e-6)
    free = np.roots([M, d + g.heading.kd, g.heading.kp])
    assert np.allclose(free.real, -math.sqrt(g.heading.kp / M), rtol=1e-3)
    assert g.heading.u_max == pytest.approx(20.0)


def test_torpedo_dives_by_pitch():
    p = make_plant(controlled=np.array([1, 0, 0, 0, 1, 1], bool))
    g = design_gains(p)
    assert g.depth_by_pitch
    assert g.depth_to_pitch.u_max == pytest.approx(0.35)
    assert not design_gains(make_plant()).depth_by_pitch
