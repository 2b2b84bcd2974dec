"""Guidance and control: PID with anti-windup, lookahead LOS path following, mission
generators (lawnmower, loop, straight line, hold), per-vehicle gain design and the
autopilot that turns a mission and the vehicle state into a body wrench demand."""

from sim.guidance.autopilot import Autopilot, MissionStatus
from sim.guidance.gains import (
    NOMINAL_SPEED,
    AutopilotGains,
    VehiclePlant,
    design_gains,
    max_wrench,
    max_wrench_from_columns,
    split_authority,
)
from sim.guidance.los import LOSResult, integral_los_rate, los_guidance, wrap
from sim.guidance.missions import (
    Mission,
    WorldBounds,
    hold,
    lawnmower,
    lawnmower_spacing,
    loop,
    straight_line,
    with_calibration_loop,
)
from sim.guidance.pid import PID, PIDGains
from sim.guidance.world_adapter import (
    autopilot_for,
    bounds_from_world,
    check_mission_in_world,
    gains_for,
    plant_for,
)

__all__ = [
    "NOMINAL_SPEED",
    "PID",
    "Autopilot",
    "AutopilotGains",
    "LOSResult",
    "Mission",
    "MissionStatus",
    "PIDGains",
    "VehiclePlant",
    "WorldBounds",
    "autopilot_for",
    "bounds_from_world",
    "check_mission_in_world",
    "design_gains",
    "gains_for",
    "hold",
    "integral_los_rate",
    "lawnmower",
    "lawnmower_spacing",
    "loop",
    "los_guidance",
    "max_wrench",
    "max_wrench_from_columns",
    "plant_for",
    "split_authority",
    "straight_line",
    "with_calibration_loop",
    "wrap",
]
