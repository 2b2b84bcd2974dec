"""Glue between sim.world and the guidance package: a vehicle's plant (mass, added
mass, damping, thrust authority) read from a built ``World``, missions checked against
the world's seabed, and a ready-to-fly :class:`~sim.guidance.autopilot.Autopilot`.

Reads only public ``World`` / ``VehicleHandle`` attributes plus the ThrusterBank arrays
(``columns``, ``is_fin``, ``f_fwd``, ``f_rev``, ``offsets``) and the seabed grid axes.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from sim.guidance.autopilot import Autopilot
from sim.guidance.gains import (
    NOMINAL_SPEED,
    AutopilotGains,
    VehiclePlant,
    _max_speed,
    design_gains,
    fin_damping,
    fin_stiffness,
    max_wrench_from_columns,
    split_authority,
)
from sim.guidance.missions import Mission, WorldBounds

__all__ = [
    "autopilot_for",
    "bounds_from_world",
    "check_mission_in_world",
    "gains_for",
    "plant_for",
]


def bounds_from_world(world) -> WorldBounds:
    """Horizontal extent of the seabed grid; max_depth = the shallowest seabed depth
    (conservative for a constant-depth mission)."""
    sb = world.seabed
    return WorldBounds(
        float(sb.x[0]),
        float(sb.x[-1]),
        float(sb.y[0]),
        float(sb.y[-1]),
        max_depth=float(-np.max(sb.z)),
    )


def check_mission_in_world(
    mission: Mission, world, margin: float = 2.0, clearance: float = 1.0, step: float = 1.0
) -> None:
    """ValueError if a waypoint lies outside the seabed extent (less ``margin`` m) or a
    constant-depth mission passes closer than ``clearance`` m to the seabed anywhere
    along its legs (sampled every ``step`` m)."""
    b = bounds_from_world(world)
    mission.validate_bounds(WorldBounds(b.x_min, b.x_max, b.y_min, b.y_max), margin=margin)
    if mission.depth is None:
        return
    w = mission.waypoints
    pts = [w[:1]]
    for a, c in itertools.pairwise(w):
        n = max(2, int(np.ceil(np.hypot(*(c - a)) / step)) + 1)
        pts.append(a + np.linspace(0, 1, n)[1:, None] * (c - a))
    p = np.vstack(pts)
    seabed_depth = -world.seabed_height(p)
    bad = np.flatnonzero(mission.depth > seabed_depth - clearance)
    if len(bad):
        i = int(bad[0])
        raise ValueError(
            f"{mission.kind} mission depth {mission.depth:g} m reaches the seabed at "
            f"({p[i, 0]:.4g}, {p[i, 1]:.4g}) m, where it is {seabed_depth[i]:.4g} m deep: "
            f"allowed depth <= seabed depth - {clearance:g} m clearance"
        )


def plant_for(world, name: str, cruise_speed: float | None = None) -> VehiclePlant:
    """The diagonal plant of vehicle ``name`` from its HydroParams and thrusters."""
    if name not in world.vehicles:
        raise ValueError(f"no vehicle {name!r} in the world; vehicles: {sorted(world.vehicles)}")
    h = world.vehicles[name]
    bank = world.thrusters
    lo, hi = bank.offsets[h.index], bank.offsets[h.index + 1]
    args = (bank.columns[lo:hi], bank.is_fin[lo:hi], bank.f_fwd[lo:hi], bank.f_rev[lo:hi])
    dofs = h.model.dof_mask
    hydro = h.hydro
    u0 = NOMINAL_SPEED.get(h.kind, 1.0) if cruise_speed is None else cruise_speed
    # fins' authority grows with speed²: evaluate at the speed the vehicle can reach
    x_max = max_wrench_from_columns(*args, dofs, 0.0)[0]
    u_fin = min(u0, 0.8 * _max_speed(hydro.linear_damping[0], hydro.quadratic_damping[0], x_max))
    tmax = split_authority(*args, dofs, u_fin)
    fins = (bank.columns[lo:hi], bank.is_fin[lo:hi], bank.lift_gain[lo:hi])
    return VehiclePlant.from_hydro(
        h.kind,
        h.model.envelope[0],
        hydro,
        tmax,
        dofs,
        rho=world.water.density,
        cruise_speed=u0,
        finned=bool(np.any(bank.is_fin[lo:hi])),
        fin_stiffness=fin_stiffness(*fins),
        fin_damping=fin_damping(*fins),
    )


def gains_for(world, name: str, cruise_speed: float | None = None) -> AutopilotGains:
    return design_gains(plant_for(world, name, cruise_speed))


def autopilot_for(world, name: str, mission: Mission, check: bool = True, **kw) -> Autopilot:
    """Autopilot for vehicle ``name`` flying ``mission`` (checked against the world
    first unless ``check`` is False). ``kw`` goes to :class:`Autopilot`."""
    if check:
        check_mission_in_world(mission, world)
    gains = gains_for(world, name, mission.speed)
    if mission.kind != "hold" and gains.cruise_speed < 0.95 * mission.speed:
        warnings.warn(
            f"vehicle {name!r} ({world.vehicles[name].kind}) cannot hold the mission speed "
            f"{mission.speed:.3g} m/s (thrust / Munk-moment limit): flying at "
            f"{gains.cruise_speed:.3g} m/s",
            UserWarning,
            stacklevel=2,
        )
    return Autopilot(mission, gains, **kw)
