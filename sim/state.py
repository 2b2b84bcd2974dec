"""The true state of one vehicle at one instant, read from the physics.

Produced by ``VehicleHandle.state()`` (sim.world); consumed by nav sensors, sonars,
controllers, the runner and the envs. Plain arrays, SI units.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from sim.frames import euler_from_wxyz, matrix_from_wxyz


@dataclass(frozen=True)
class VehicleState:
    """True kinematic state.

    t                     : simulation time, s.
    position              : (3,) body origin in the world frame (x east, y north, z up), m.
    quat_wxyz             : (4,) body orientation, body->world, MuJoCo order.
    velocity_body         : (3,) velocity over ground in the body frame, m/s.
    angular_velocity_body : (3,) rad/s in the body frame.
    acceleration_body     : (3,) linear acceleration over ground in the body frame, m/s²
                            (kinematic, without gravity).
    water_velocity_world  : (3,) ocean current at the vehicle, world frame, m/s.
    altitude              : distance to the seabed straight below, m (nan if unknown).
    """

    t: float
    position: np.ndarray
    quat_wxyz: np.ndarray
    velocity_body: np.ndarray
    angular_velocity_body: np.ndarray
    acceleration_body: np.ndarray
    water_velocity_world: np.ndarray
    altitude: float = float("nan")

    @property
    def depth(self) -> float:
        """Depth below the datum z = 0, m (positive down)."""
        return float(-self.position[2])

    @cached_property
    def rotation(self) -> np.ndarray:
        """(3, 3) body->world rotation matrix (computed once per state)."""
        return matrix_from_wxyz(self.quat_wxyz)

    @cached_property
    def euler(self) -> np.ndarray:
        """(roll, pitch, yaw) in rad; yaw counter-clockwise from east (computed once)."""
        return euler_from_wxyz(self.quat_wxyz)

    @property
    def velocity_world(self) -> np.ndarray:
        return self.rotation @ self.velocity_body
