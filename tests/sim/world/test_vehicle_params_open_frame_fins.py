"""Vehicle parameter derivations: low-aspect-ratio fin lift slope against its analytic
limits, the open-frame added-mass scale against the published BlueROV2 Heavy values it
is built from, and the fins' passive stiffness / damping signs (weathercock stability)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.guidance.gains import fin_damping, fin_stiffness
from sim.hydrodynamics import ellipsoid_added_mass
from sim.world import VehicleSpec, WorldSpec, build_world
from sim.world.seabed import SeabedSpec
from sim.world.vehicles import OPEN_FRAME_ADDED_MASS_SCALE, fin_lift_slope, vehicle_model


def test_fin_lift_slope_tends_to_slender_wing_and_lifting_line_limits():
    """Whicker–Fehlner: A_e → 0 gives 1.8 π A_e / 3.8, within 6 % of Jones' slender-wing
    slope π A_e / 2; A_e → ∞ gives 1.8 π; A_e = 2 span / chord (hull reflection plane)."""
    small = fin_lift_slope(0.001, 1.0)  # A_e = 0.002
    assert small == pytest.approx(math.pi * 0.002 / 2, rel=0.06)
    assert fin_lift_slope(1000.0, 1.0) == pytest.approx(1.8 * math.pi, rel=1e-3)
    # IXN fin (span 0.2, chord 0.25 → A_e 1.6): 1.8π·1.6 / (1.8 + √(1.6² + 4))
    assert fin_lift_slope(0.2, 0.25) == pytest.approx(
        1.8 * math.pi * 1.6 / (1.8 + math.sqrt(1.6**2 + 4)), rel=1e-12
    )
    with pytest.raises(ValueError, match="span"):
        fin_lift_slope(-0.1, 0.2)


def test_open_frame_scale_reproduces_the_published_bluerov2_heavy_added_mass():
    """Scale × Lamb ellipsoid on the BlueROV2 Heavy envelope = von Benzon et al. (2022)
    [6.3567, 7.1206, 18.6863] kg (ρ = 1000); the scaled Naiad heave added mass is below
    the enclosing ellipsoid's (open frame)."""
    lamb = ellipsoid_added_mass(0.4571 / 2, 0.575 / 2, 0.2539 / 2, 1000.0)
    np.testing.assert_allclose(
        np.array(OPEN_FRAME_ADDED_MASS_SCALE[:3]) * lamb[:3], [6.3567, 7.1206, 18.6863]
    )
    assert all(0.0 < s < 1.0 for s in OPEN_FRAME_ADDED_MASS_SCALE[:3])
    m = vehicle_model("naiad")
    h = m.hydro_params(30.0, np.array([1.0, 2.0, 2.6]), 1025.0)
    full = ellipsoid_added_mass(0.42, 0.3, 0.125, 1025.0)
    np.testing.assert_allclose(h.added_mass[:3], full[:3] * OPEN_FRAME_ADDED_MASS_SCALE[:3])


def test_ixn_stern_fins_are_weathercock_stable_in_yaw():
    """Aft fins: positive restoring stiffness in yaw and pitch and positive yaw damping
    g U x_f²; the rudder alone beats the yaw Munk coefficient A22 − A11 (its sizing rule
    ½ρ S C_Lα |x_f| ≥ A22 − A11)."""
    w = build_world(
        WorldSpec(
            seabed=SeabedSpec(kind="flat", size_xy=(40.0, 40.0), depth=20.0),
            vehicles=(VehicleSpec("ixn", position=(0.0, 0.0, -5.0)),),
        )
    )
    b = w.thrusters
    k = fin_stiffness(b.columns, b.is_fin, b.lift_gain)
    d = fin_damping(b.columns, b.is_fin, b.lift_gain)
    g = 0.5 * w.water.density * 0.1 * fin_lift_slope(0.2, 0.25)
    assert k[5] == pytest.approx(g * 0.85) and k[4] == pytest.approx(g * 0.85)
    assert d[5] == pytest.approx(g * 0.85**2)
    am = w.vehicles["ixn"].hydro.added_mass
    assert k[5] > am[1] - am[0]
