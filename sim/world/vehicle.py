"""``VehicleHandle``: semantic access to one vehicle of a ``World``."""

from __future__ import annotations

from typing import TYPE_CHECKING

import mujoco
import numpy as np

from sim.state import VehicleState
from sim.world.vehicles import VehicleModel

if TYPE_CHECKING:
    from sim.world.builder import World

_DOWN = np.array([0.0, 0.0, -1.0])
_RAY_GROUPS = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)


class VehicleHandle:
    """One vehicle: its MuJoCo ids, true state, and actuator inputs.

    name        : instance name (MJCF prefix ``"<name>/"``); kind : vehicle library key.
    body_id     : root body (free joint), origin at the centre of gravity.
    site_ids    : sensor sites ("sss_port", "sss_starboard", "fls", "msis", "dvl", "imu",
                  "pressure"), each carrying the body orientation.
    """

    def __init__(
        self,
        world: World,
        index: int,
        name: str,
        model: VehicleModel,
        body_id: int,
        site_ids: dict[str, int],
        thruster_names: tuple[str, ...],
    ):
        self._world = world
        self.index = index
        self.name = name
        self.kind = model.kind
        self.model = model
        self.body_id = body_id
        self.site_ids = site_ids
        self.thruster_names = thruster_names
        m = world.model
        jnt = m.body_jntadr[body_id]
        self.qpos_adr = int(m.jnt_qposadr[jnt])
        self.dof_adr = int(m.jnt_dofadr[jnt])
        self._ray_gid = np.zeros(1, dtype=np.int32)

    @property
    def n_thrusters(self) -> int:
        """Number of actuator channels (propellers and, for the torpedo, fin pairs)."""
        return len(self.thruster_names)

    @property
    def hydro(self):
        """This vehicle's HydroParams."""
        return self._world._hydro_params[self.index]

    def _rot_pos(self) -> tuple[np.ndarray, np.ndarray]:
        d = self._world.data
        q = d.qpos[self.qpos_adr : self.qpos_adr + 7]
        r = np.empty(9)
        mujoco.mju_quat2Mat(r, q[3:7])
        return r.reshape(3, 3), q[:3].copy()

    def state(self) -> VehicleState:
        """True state now (see sim.state.VehicleState for units and frames).

        ``acceleration_body`` is MuJoCo's qacc of the last step (contacts included),
        expressed in the current body frame; ``altitude`` is a downward ray from the CG to
        the first geom of groups 0–2 that is not the vehicle itself (seabed, object or
        another vehicle), falling back to the seabed grid when the ray misses."""
        w = self._world
        d = w.data
        rot, pos = self._rot_pos()
        qv = d.qvel[self.dof_adr : self.dof_adr + 6]
        v_body = rot.T @ qv[:3]
        acc_body = rot.T @ d.qacc[self.dof_adr : self.dof_adr + 3]
        cur = w.current.velocity(pos[None, :], d.time)[0]
        dist = mujoco.mj_ray(w.model, d, pos, _DOWN, _RAY_GROUPS, 1, self.body_id, self._ray_gid)
        altitude = float(dist) if dist >= 0 else float(pos[2] - w.seabed_height(pos[None, :2])[0])
        return VehicleState(
            t=float(d.time),
            position=pos,
            quat_wxyz=d.qpos[self.qpos_adr + 3 : self.qpos_adr + 7].copy(),
            velocity_body=v_body,
            angular_velocity_body=qv[3:6].copy(),
            acceleration_body=acc_body,
            water_velocity_world=cur,
            altitude=altitude,
        )

    def set_thruster_commands(self, u: np.ndarray) -> None:
        """Raw normalized commands (n_thrusters,) in [−1, 1] (values beyond are saturated);
        held until changed. Channel order: ``thruster_names``."""
        self._world.thrusters.set_commands(self.index, u)

    def apply_wrench_demand(self, tau: np.ndarray) -> None:
        """Map a desired body wrench tau (6,) = [X, Y, Z, K, M, N] (N, N·m) to actuator
        commands by the thrust allocation (pseudo-inverse over the vehicle's controlled
        degrees of freedom, saturation, fins scaled by the current surge speed) and set
        them. The thruster lag then acts as for raw commands."""
        t = np.asarray(tau, dtype=float).reshape(-1)
        if t.shape != (6,) or not np.all(np.isfinite(t)):
            raise ValueError(f"tau must be 6 finite numbers [X, Y, Z, K, M, N], got {tau!r}")
        w = self._world
        speed_sq = 0.0
        if w.thrusters.any_fin:
            st = self.state()
            vr = st.velocity_body - st.rotation.T @ st.water_velocity_world
            speed_sq = float(vr[0] * abs(vr[0]))
        u = w.thrusters.allocate(self.index, t, self.model.dof_mask, speed_sq)
        w.thrusters.set_commands(self.index, u)

    def set_external_wrench(self, tau: np.ndarray) -> None:
        """A body-frame disturbance wrench (6,) (tether, collision test, step-force
        experiment) added to the thrusters' wrench until changed; goes through the same
        added-mass solve as every other force."""
        t = np.asarray(tau, dtype=float).reshape(-1)
        if t.shape != (6,) or not np.all(np.isfinite(t)):
            raise ValueError(f"external wrench must be 6 finite numbers, got {tau!r}")
        self._world._external[self.index] = t

    def set_pose(
        self,
        position,
        quat_wxyz=(1.0, 0.0, 0.0, 0.0),
        velocity_body=(0, 0, 0),
        angular_velocity_body=(0, 0, 0),
    ) -> None:
        """Teleport (position world m, orientation, body-frame velocities) and mj_forward."""
        p = np.asarray(position, dtype=float)
        q = np.asarray(quat_wxyz, dtype=float)
        if p.shape != (3,) or not np.isfinite(p).all():
            raise ValueError(f"position must be 3 finite numbers, got {position!r}")
        if q.shape != (4,) or not np.isfinite(q).all() or np.linalg.norm(q) < 1e-9:
            raise ValueError(f"quat_wxyz must be a finite non-zero quaternion, got {quat_wxyz!r}")
        q = q / np.linalg.norm(q)
        w = self._world
        d = w.data
        d.qpos[self.qpos_adr : self.qpos_adr + 3] = p
        d.qpos[self.qpos_adr + 3 : self.qpos_adr + 7] = q
        r = np.empty(9)
        mujoco.mju_quat2Mat(r, q)
        d.qvel[self.dof_adr : self.dof_adr + 3] = r.reshape(3, 3) @ np.asarray(velocity_body, float)
        d.qvel[self.dof_adr + 3 : self.dof_adr + 6] = np.asarray(angular_velocity_body, float)
        w._forward()
