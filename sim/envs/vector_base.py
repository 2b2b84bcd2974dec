"""Shared machinery of the batched undersea envs (``sim.envs.vector_nav``,
``sim.envs.vector_sonar``): N vehicles in one MuJoCo model, one compiled physics call per
control step for all of them.

Why one model with N vehicles (and not N MjData of one model): the compiled step of
``sim.physics_kernel`` then advances every vehicle with one call (one ``mj_step1`` /
``mj_step2`` pair per physics step for all N, the hydrodynamics of all N in one loop),
and every per-vehicle quantity is a row of the same MjData arrays, read for all N in one
compiled loop (``sim.envs.vector_kernel``). The vehicles do not see each other:
vehicle–vehicle contacts are masked (conaffinity) and the vehicles' geoms are moved to
geom group 3, outside the altitude ray's groups, so each vehicle's physics is that of a
single-vehicle world. The altitude is the height over the seabed mesh below each vehicle,
interpolated on MuJoCo's own (float32) copy of the mesh's vertices: what the single env's
downward ``mj_ray`` finds in a world without objects (to 1.3e-7 m: the ray's own
arithmetic), at a fraction of a ray's cost (20 µs against the 20,000-triangle seabed).
MuJoCo's per-body arithmetic does not depend on the other bodies, so each vehicle follows
the same trajectory as in the single env with the same seed and actions. (A seabed
contact is solved jointly with other vehicles' contacts at the same step; episodes end
at 0.3 m altitude, before the hull touches.)

Each sub-environment keeps its own random generator (seeded as ``gymnasium.Env.reset``
seeds it), its own clock (accumulated as MuJoCo accumulates ``d.time`` from 0 at its
reset) and navigation; the draws at reset are those of the single env, in the same
order. Autoreset: ``AutoresetMode.NEXT_STEP`` (gymnasium's default): the step after an
episode's end returns that sub-env's reset observation, reward 0, and ignores its
action; its vehicle is put back at the start after the physics of that step, so it
starts where a fresh single env starts. Truncation at ``max_episode_steps`` as the
TimeLimit wrapper does. With ``nav_sensors=True`` (default) the navigation of all N is
``sim.navigation.NavBatch``: each sub-env's sensors drawn from the generator its single
env's navigation would get, polled and dead-reckoned for all N in one compiled pass.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv

from sim.envs import vector_kernel as VK
from sim.envs.base import ENV_NAV_CONFIG, VEHICLE_CHOICES, NavEstimate
from sim.frames import wxyz_from_euler
from sim.navigation.batch import NavBatch
from sim.world import SeabedSpec, VehicleSpec, WorldSpec, build_world
from sim.world.seabed import Seabed


class VehicleBatchEnv(VectorEnv):
    """N single-vehicle envs in one world; subclasses add the task (reset draws, reward,
    observation). See the module docstring."""

    metadata: ClassVar[dict] = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int,
        vehicle: str,
        arena_size: float,
        water_depth: float,
        control_dt: float,
        physics_dt: float,
        nav_sensors: bool,
        max_episode_steps: int | None,
        render_mode: str | None,
    ) -> None:
        if int(num_envs) < 1:
            raise ValueError(f"num_envs = {num_envs!r}; allowed: an integer >= 1")
        if vehicle not in VEHICLE_CHOICES:
            raise ValueError(f"vehicle = {vehicle!r}; allowed: {', '.join(VEHICLE_CHOICES)}")
        if render_mode is not None:
            raise ValueError(f"render_mode = {render_mode!r}; the batched env does not render")
        ratio = control_dt / physics_dt
        if physics_dt <= 0 or abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"control_dt = {control_dt!r} must be a whole multiple of physics_dt = {physics_dt!r} (s)"
            )
        n = int(num_envs)
        self.num_envs = n
        self.vehicle_kind = vehicle
        self.arena_size = float(arena_size)
        self.water_depth = float(water_depth)
        self.frame_skip = round(ratio)
        self.nav_sensors = bool(nav_sensors)
        self.max_episode_steps = None if max_episode_steps is None else int(max_episode_steps)
        self.render_mode = None
        # the seabed and timestep of UnderseaEnv, N vehicles of one kind at its build depth
        z0 = -self.water_depth / 2
        spec = WorldSpec(
            seabed=SeabedSpec(
                kind="flat",
                size_xy=(arena_size, arena_size),
                resolution=max(1.0, self.arena_size / 100.0),
                depth=water_depth,
            ),
            vehicles=tuple(
                VehicleSpec(vehicle, name=f"v{i}", position=(*xy, z0))
                for i, xy in enumerate(_build_positions(n, self.arena_size))
            ),
            timestep=physics_dt,
        )
        self.world = w = build_world(spec)
        self.vehicles = list(w.vehicles.values())
        m = w.model
        for h in self.vehicles:  # invisible to each other: no contacts, not on the altitude ray
            g = np.flatnonzero(m.geom_bodyid == h.body_id)
            m.geom_conaffinity[g] = 2
            m.geom_group[g] = 3
        self.n_actuators = self.vehicles[0].n_thrusters
        self._qadr = np.array([h.qpos_adr for h in self.vehicles])[:, None] + np.arange(7)
        self._vadr = np.array([h.dof_adr for h in self.vehicles])[:, None] + np.arange(6)
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, (self.n_actuators,), np.float32)
        self.action_space = gym.vector.utils.batch_space(self.single_action_space, n)
        self._rngs: list[np.random.Generator] = [seeding.np_random()[0] for _ in range(n)]
        self._t = np.zeros(n)  # per-env clock, s
        self._elapsed = np.zeros(n, dtype=np.int64)
        self._done = np.zeros(n, dtype=bool)
        self._nav_pose = np.zeros((n, 3))
        self._nav = NavBatch(ENV_NAV_CONFIG, n) if self.nav_sensors else None
        self._meas = np.zeros((n, 8))  # v (3), r, depth, alt, roll, pitch
        self._seabed_mj = _mujoco_seabed(w)
        sx, sy = w.seabed.x, w.seabed.y
        self._axes = np.array([sx[0], sx[1] - sx[0], sy[0], sy[1] - sy[0], sx[-1], sy[-1]])

    # ------------------------------------------------------------------ state ---------
    def _true(self) -> tuple[np.ndarray, ...]:
        """Positions (N,3), quaternions (N,4), body velocities (N,3), angular velocities
        (N,3), altitudes (N,) and (roll, pitch, yaw) (N,3) of all vehicles now (fresh
        arrays). The altitude is over the seabed mesh (MuJoCo's vertices) below each
        vehicle; beyond the mesh, over the nearest edge of the grid (``VehicleHandle.state``'s
        fallback when its ray misses)."""
        n, d = self.num_envs, self.world.data
        pos, quat, vb, om, alt, rpy = (
            np.empty((n, 3)), np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 3)),
            np.empty(n), np.empty((n, 3)),
        )  # fmt: skip
        VK.truth(
            d.qpos, d.qvel, self._qadr, self._vadr, self._seabed_mj.z, self.world.seabed.z,
            self._axes, pos, quat, vb, om, alt, rpy,
        )  # fmt: skip
        return pos, quat, vb, om, alt, rpy

    # ------------------------------------------------------------------ reset ---------
    def _seed_rng(self, i: int, seed: int | None) -> np.random.Generator:
        """Env i's generator, reseeded as ``gymnasium.Env.reset(seed=seed)`` does."""
        if seed is not None:
            self._rngs[i] = seeding.np_random(seed)[0]
        return self._rngs[i]

    def _reset_vehicle(self, i: int, start: np.ndarray, yaw: float) -> None:
        """``UnderseaEnv._reset_world(start, yaw)`` for env i: vehicle at start (world m)
        heading yaw (rad), thrusters idle, clock 0, navigation restarted from a seed drawn
        from env i's generator and polled once, nav pose and held measurements reset."""
        w = self.world
        lo, hi = w.thrusters.offsets[i], w.thrusters.offsets[i + 1]
        w.thrusters.command[lo:hi] = 0.0
        w.thrusters.level[lo:hi] = 0.0
        w._external[i] = 0.0
        self.vehicles[i].set_pose(start, wxyz_from_euler(0.0, 0.0, yaw))  # mj_forward included
        self._t[i] = 0.0
        self._elapsed[i] = 0
        nav_seed = int(self._rngs[i].integers(2**63))
        pos, quat, vb, om, alts, _ = self._true()
        if self._nav is not None:  # NavSuite(cfg, rng, t0) and its first poll
            self._nav.reset(i, np.random.default_rng(nav_seed), 0.0)
            one = np.arange(self.num_envs) == i
            self._nav.poll(one, self._t, quat, vb, om, -pos[:, 2], alts)
        self._nav_pose[i] = (start[0], start[1], yaw)
        self._meas[i, :8] = (0.0, 0.0, 0.0, 0.0, -start[2], alts[i], 0.0, 0.0)

    def _seeds(self, seed) -> list:
        """Per-env seeds of ``reset(seed=...)``: an int (env i gets seed + i), a list of N
        ints or Nones, or None."""
        n = self.num_envs
        if seed is None:
            return [None] * n
        if isinstance(seed, (int, np.integer)):
            return [int(seed) + i for i in range(n)]
        seeds = list(seed)
        if len(seeds) != n:
            raise ValueError(f"seed must be an int, None or {n} seeds, got {len(seeds)}")
        return seeds

    # ------------------------------------------------------------------ step ----------
    def _advance(self, actions):
        """Check and apply the actions, step the physics one control step, read the truth
        and run the navigation. Returns u (N, n_act) (clipped; rows of envs resetting this
        step zero), clipped (N,), resetting (N,) and ``_true()``'s arrays."""
        n = self.num_envs
        a = np.asarray(actions)
        if a.dtype not in (np.float32, np.float64):
            a = a.astype(np.float64)
        a = a.reshape(n, -1) if a.size == n * self.n_actuators else a
        if a.shape != (n, self.n_actuators):
            raise ValueError(
                f"actions must have shape ({n}, {self.n_actuators}), got {np.shape(actions)}"
            )
        w = self.world
        resetting = self._done  # ignored actions: those envs are reset after the physics
        u, clipped = np.empty((n, self.n_actuators)), np.empty(n, bool)
        if not VK.actions(a, resetting, u, clipped):
            raise ValueError("actions must be finite (NaN/inf are rejected)")
        w.thrusters.command[:] = u.ravel()
        w.step(self.frame_skip)
        dt = w.timestep
        for _ in range(self.frame_skip):  # each env's clock, accumulated as d.time is
            self._t += dt
        self._elapsed += 1
        pos, quat, vb, om, alt, rpy = self._true()
        if self._nav is not None:
            active = ~resetting
            nav = self._nav
            nav.poll(active, self._t, quat, vb, om, -pos[:, 2], alt)
            delta = nav.odometry(active, self._t)
            VK.merge_nav(active, nav.out, nav.reported, delta, self._meas, self._nav_pose)
        else:
            VK.ideal_nav(pos, vb, om, alt, rpy, self._meas, self._nav_pose)
        return u, clipped, resetting, pos, quat, vb, om, alt, rpy

    def _reset_one(self, i: int, seed: int | None) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def _reset_all(self, seed) -> None:
        for i, s in enumerate(self._seeds(seed)):
            self._reset_one(i, s)
        self._done[:] = False

    def _autoreset(self, resetting, reward, terminated, truncated, terms) -> None:
        """NEXT_STEP autoreset: the envs ``resetting`` (their episode ended last step) are
        reset now and report reward 0, no end and zero reward terms; every env whose
        episode ends this step resets on the next."""
        if resetting.any():
            for i in np.flatnonzero(resetting):
                self._reset_one(i, None)
            reward[resetting] = 0.0
            terminated[resetting] = False
            truncated[resetting] = False
            terms[resetting] = 0.0
        self._done = terminated | truncated

    def _truncated(self) -> np.ndarray:
        if self.max_episode_steps is None:
            return np.zeros(self.num_envs, bool)
        return self._elapsed >= self.max_episode_steps

    def _info(self, pos, yaw, vb, collided, nav_err=None) -> dict:
        if nav_err is None:
            nav_err = np.linalg.norm(self._nav_pose[:, :2] - pos[:, :2], axis=1)
        return {
            "true_position": pos,
            "true_yaw": yaw,
            "true_velocity_body": vb,
            "nav_position_error_m": nav_err,
            "time_s": self._t.copy(),
            "collided": collided,
        }

    def nav_estimates(self) -> list[NavEstimate]:
        """What each vehicle's navigation knows (as ``UnderseaEnv.nav_estimate``)."""
        m = self._meas
        return [
            NavEstimate(self._nav_pose[i].copy(), m[i, 0:3].copy(), *m[i, 3:8])
            for i in range(self.num_envs)
        ]


def _build_positions(n: int, arena_size: float) -> list[tuple[float, float]]:
    """n distinct (x, y) inside the arena to build the world with (the vehicles may not
    overlap before their contacts are masked; every reset then puts them at the start)."""
    side = int(np.ceil(np.sqrt(n)))
    g = (np.arange(side) - (side - 1) / 2) * min(20.0, 0.8 * arena_size / side)
    return [(float(g[i % side]), float(g[i // side])) for i in range(n)]


def _mujoco_seabed(world) -> Seabed:
    """The world's seabed with the heights of MuJoCo's copy of its mesh (vertices stored
    in float32 in the mesh's principal frame), in world z: the surface ``mj_ray`` hits."""
    m, d = world.model, world.data
    g = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "seabed")
    k = m.geom_dataid[g]
    v = m.mesh_vert[m.mesh_vertadr[k] : m.mesh_vertadr[k] + m.mesh_vertnum[k]].astype(float)
    z = (v @ d.geom_xmat[g].reshape(3, 3).T + d.geom_xpos[g])[:, 2]
    sb = world.seabed
    if z.size != sb.z.size:  # not one vertex per grid node: MuJoCo merged some
        return sb
    return dataclasses.replace(sb, z=z.reshape(sb.z.shape))
