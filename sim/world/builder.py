"""Scenario-driven MuJoCo world: water, seabed mesh, objects, vehicles, hydrodynamics.

``build_world(WorldSpec) -> World``. The MJCF is assembled with ``mujoco.MjSpec``:
the seabed as a static triangle mesh (for rays) plus a transparent hfield of the same
grid (for contacts only; alpha 0 makes it invisible to ``mj_ray``), static objects as
mesh bodies welded to the world, the articulated mannequin as a capsule tree, and the
vehicles attached from ``assets/vehicles/<kind>/<kind>.xml`` with prefix ``"<name>/"``.

MuJoCo's own fluid model is off (density = viscosity = 0) and gravity is on; buoyancy,
added mass, damping, currents and thrust are applied each physics step through
``xfrc_applied`` by ``sim.hydrodynamics.HydroBatch`` and ``sim.thrusters.ThrusterBank``,
vectorized over all vehicles (``mj_step1`` → one compiled pass over the vehicles →
``mj_step2``, n steps per call: ``sim.physics_kernel``).

Build time is dominated by MuJoCo's processing of the seabed mesh (≈ 3 µs per triangle):
≈ 1.3 s for the default 100 m × 100 m at 0.25 m (320 k triangles), ≈ 5 s for 1.28 M.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import mujoco
import numpy as np

from sim.frames import wxyz_from_euler
from sim.hydrodynamics import HydroBatch, HydroParams
from sim.physics_kernel import MJ_STEP1, MJ_STEP2, step_world
from sim.thrusters import ThrusterBank
from sim.world.currents import CurrentField, CurrentSpec
from sim.world.objects import (
    MANNEQUIN_JOINTS,
    MANNEQUIN_SEGMENTS,
    SEABED_REFLECTIVITY,
    VEHICLE_REFLECTIVITY,
    ObjectSpec,
    object_mesh,
)
from sim.world.seabed import Seabed, SeabedSpec, generate_seabed
from sim.world.vehicle import VehicleHandle
from sim.world.vehicles import SENSOR_SITES, VEHICLE_KINDS, vehicle_model
from sim.world.water import Water

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_\-]*$")
SEABED_RGBA = (0.76, 0.70, 0.50, 1.0)


@dataclass(frozen=True)
class VehicleSpec:
    """A vehicle in the world.

    kind          : one of VEHICLE_KINDS ("alister9", "ixn", "naiad", "saga", "rexrov").
    name          : instance name (MJCF prefix); default = kind.
    position      : (3,) start position of the CG, world m.
    rpy_deg       : (roll, pitch, yaw) start attitude, degrees (yaw CCW from east).
    net_buoyancy  : trim, (B − W)/W; 0 = neutrally buoyant, 0.005 = 0.5 % positive.
    mass          : optional total mass override, kg (payload variants); the inertia is
                    scaled by the same factor. None = the MJCF's mass (REFERENCE.md).
    """

    kind: str
    name: str | None = None
    position: tuple[float, float, float] = (0.0, 0.0, -5.0)
    rpy_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    net_buoyancy: float = 0.0
    mass: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in VEHICLE_KINDS:
            raise ValueError(f"vehicle kind must be one of {VEHICLE_KINDS}, got {self.kind!r}")
        if self.name is None:
            object.__setattr__(self, "name", self.kind)
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ValueError(f"vehicle name must match {_NAME.pattern}, got {self.name!r}")
        for f in ("position", "rpy_deg"):
            a = np.asarray(getattr(self, f), dtype=float)
            if a.shape != (3,) or not np.isfinite(a).all():
                raise ValueError(
                    f"vehicle {self.name!r} {f} must be 3 finite numbers, got {getattr(self, f)!r}"
                )
        if not -0.5 <= float(self.net_buoyancy) <= 0.5:
            raise ValueError(
                f"vehicle {self.name!r} net_buoyancy must be in [-0.5, 0.5], got {self.net_buoyancy!r}"
            )
        if self.mass is not None and not (np.isfinite(self.mass) and 0.0 < float(self.mass) <= 1e5):
            raise ValueError(
                f"vehicle {self.name!r} mass must be a positive number of kg (<= 1e5) or None, "
                f"got {self.mass!r}"
            )


@dataclass(frozen=True)
class WorldSpec:
    """Everything ``build_world`` needs. ``vehicles`` may hold kind strings."""

    seabed: SeabedSpec = field(default_factory=SeabedSpec)
    water: Water = field(default_factory=Water)
    vehicles: tuple[VehicleSpec, ...] = ()
    objects: tuple[ObjectSpec, ...] = ()
    current: CurrentSpec = field(default_factory=CurrentSpec)
    timestep: float = 0.01
    seabed_contacts: bool = True

    def __post_init__(self) -> None:
        vs = tuple(VehicleSpec(v) if isinstance(v, str) else v for v in self.vehicles)
        for v in vs:
            if not isinstance(v, VehicleSpec):
                raise ValueError(f"vehicles must be VehicleSpec or kind strings, got {v!r}")
        names = [v.name for v in vs]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"vehicle names must be unique, duplicated: {sorted(dup)}")
        object.__setattr__(self, "vehicles", vs)
        obs = tuple(self.objects)
        for o in obs:
            if not isinstance(o, ObjectSpec):
                raise ValueError(f"objects must be ObjectSpec, got {o!r}")
        object.__setattr__(self, "objects", obs)
        dt = float(self.timestep)
        if not np.isfinite(dt) or not 1e-4 <= dt <= 0.05:
            raise ValueError(f"timestep must be in [0.0001, 0.05] s, got {self.timestep!r}")


@dataclass(frozen=True)
class ObjectInfo:
    """A seabed object in a built world (``id`` >= 1 is its label in geom_object_id)."""

    id: int
    class_name: str
    reflectivity: float
    position: np.ndarray  # (3,) base centre, world m
    body_name: str
    size: np.ndarray  # (3,) bbox L, W, H, m
    yaw: float = 0.0  # rad
    static: bool = True


@dataclass(eq=False, repr=False)
class World:
    """A built world. See CONTRACTS.md; ``step`` advances hydrodynamics + thrusters + MuJoCo."""

    model: mujoco.MjModel
    data: mujoco.MjData
    water: Water
    objects: list[ObjectInfo]
    geom_object_id: np.ndarray
    geom_reflectivity: np.ndarray
    vehicles: dict[str, VehicleHandle]
    spec: WorldSpec
    seabed: Seabed
    current: CurrentField
    thrusters: ThrusterBank | None = None
    hydro: HydroBatch | None = None
    _hydro_params: list[HydroParams] = field(default_factory=list)
    _static_parts: list = field(default_factory=list)  # (vertices world, faces, geom_id)
    _external: np.ndarray | None = None
    _bid: np.ndarray | slice | None = None
    _dofs: np.ndarray | slice | None = None
    _body_ids: np.ndarray | None = None  # (N,) vehicle root bodies (for the compiled step)
    _dof0: np.ndarray | None = None  # (N,) first dof of each vehicle's free joint
    _ids: np.ndarray | None = None  # (2, N) [_body_ids; _dof0]
    _addr: np.ndarray | None = None  # (4,) mj_step1, mj_step2, mjModel, mjData addresses
    _init_qpos: np.ndarray | None = None
    _static_cache: tuple | None = None

    def __repr__(self) -> str:
        return (
            f"World(t={self.time:.3f} s, dt={self.timestep} s, seabed={self.spec.seabed.kind!r}, "
            f"vehicles={list(self.vehicles)}, objects={len(self.objects)}, ngeom={self.model.ngeom})"
        )

    @property
    def time(self) -> float:
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        return float(self.model.opt.timestep)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(x_min, x_max, y_min, y_max) of the seabed, world m: the horizontal extent of
        the world (vehicles beyond it have no seabed below)."""
        sb = self.seabed
        return float(sb.x[0]), float(sb.x[-1]), float(sb.y[0]), float(sb.y[-1])

    def _apply_forces(self) -> None:
        d = self.data
        bid = self._bid
        qv = d.qvel[self._dofs].reshape(-1, 6)
        if self.current.is_zero:
            cur = None
        else:
            cur = self.current.velocity(d.xpos[bid], d.time)
        d.xfrc_applied[bid] = self.hydro.body_wrench(
            d.xmat[bid].reshape(-1, 3, 3),
            d.xpos[bid],
            qv[:, :3],
            qv[:, 3:],
            cur,
            self._external,
            self.thrusters,
        )

    def step(self, n: int = 1) -> None:
        """Advance n physics steps (hydrodynamics + thrusters + mj_step each), all n in one
        compiled call (``sim.physics_kernel.step_world``)."""
        m, d = self.model, self.data
        if not self.vehicles:
            mujoco.mj_step(m, d, nstep=int(n))
        else:
            th, cf, t0 = self.thrusters, self.current, d.time
            t = step_world(
                self._addr, int(n), t0, m.opt.timestep, d.xmat, d.xpos, d.qvel,
                d.xfrc_applied, self._ids, self._external, self.hydro.packed, th.table,
                th.offsets, th.state, cf.uniform, cf.modes, self.hydro.last_accel,
            )  # fmt: skip
            # MuJoCo resets the data when a state goes bad (the time then restarts): the
            # full check only when the time is off, or cannot tell (a run from t = 0)
            if t == d.time and t0 != 0.0:
                return
        if d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number or not np.isfinite(d.qpos).all():
            raise FloatingPointError(
                f"physics diverged at t = {d.time:.3f} s (MuJoCo bad qacc / non-finite state); "
                "check thruster commands, external wrenches and the timestep"
            )

    def _forward(self) -> None:
        """mj_forward with this state's hydrodynamic forces applied (consistent qacc)."""
        mujoco.mj_forward(self.model, self.data)
        if self.vehicles:
            lv = self.thrusters.level.copy()
            self._apply_forces()
            self.thrusters.level[:] = lv  # a forward pass must not advance the lag
            mujoco.mj_forward(self.model, self.data)

    def reset(self) -> None:
        """Back to the start state (time 0, start poses, thrusters idle)."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:] = self._init_qpos
        self.thrusters.command[:] = 0.0
        self.thrusters.level[:] = 0.0
        self._external[:] = 0.0
        self._forward()

    def seabed_height(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2) world x, y -> (N,) seabed z, m (objects not included)."""
        return self.seabed.height(xy)

    def static_mesh(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World-frame (vertices (V,3) float64, faces (F,3) int32, geom id per face (F,)
        int32) of everything that never moves: the seabed mesh and the static objects."""
        if self._static_cache is None:
            vs, fs, gs = [], [], []
            off = 0
            for v, f, g in self._static_parts:
                vs.append(v)
                fs.append(f + off)
                gs.append(np.full(len(f), g, dtype=np.int32))
                off += len(v)
            out = (
                np.ascontiguousarray(np.concatenate(vs), dtype=np.float64),
                np.ascontiguousarray(np.concatenate(fs), dtype=np.int32),
                np.concatenate(gs),
            )
            for a in out:
                a.setflags(write=False)
            self._static_cache = out
        return self._static_cache


def _yaw_quat(yaw: float) -> np.ndarray:
    return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


def _add_seabed(s: mujoco.MjSpec, sb: Seabed, contacts: bool) -> None:
    mesh = s.add_mesh(name="seabed")
    mesh.uservert = sb.vertices.ravel()
    mesh.userface = sb.faces.ravel()
    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    s.worldbody.add_geom(
        name="seabed",
        type=mujoco.mjtGeom.mjGEOM_MESH,
        meshname="seabed",
        contype=0,
        conaffinity=0,
        group=0,
        rgba=SEABED_RGBA,
    )
    if contacts:
        z = sb.z
        zmin, zmax = float(z.min()), float(z.max())
        rng = max(zmax - zmin, 1e-3)
        hf = s.add_hfield(
            name="seabed_contact",
            size=[(sb.x[-1] - sb.x[0]) / 2, (sb.y[-1] - sb.y[0]) / 2, rng, 1.0],
            nrow=z.shape[0],
            ncol=z.shape[1],
        )
        hf.userdata = ((z - zmin) / rng).ravel()
        s.worldbody.add_geom(
            name="seabed_contact",
            type=mujoco.mjtGeom.mjGEOM_HFIELD,
            hfieldname="seabed_contact",
            pos=[(sb.x[0] + sb.x[-1]) / 2, (sb.y[0] + sb.y[-1]) / 2, zmin],
            contype=2,
            conaffinity=1,
            group=3,
            rgba=[0, 0, 0, 0],
        )


def _add_mannequin(s, k: int, o: ObjectSpec, pos: np.ndarray, rng) -> tuple[str, list, dict]:
    """Articulated capsule tree lying supine; returns root name, geom names, posed qpos."""
    cls = o.object_class
    scale = o.bbox[0] / 1.75
    yaw = np.deg2rad(o.yaw_deg)
    # supine: body x (face) -> world up, body z (head) -> horizontal along yaw + pi
    q_lie = np.array([np.cos(-np.pi / 4), 0.0, np.sin(-np.pi / 4), 0.0])
    q = np.empty(4)
    mujoco.mju_mulQuat(q, _yaw_quat(yaw + np.pi), q_lie)
    bodies, geoms, pose = {}, [], {}
    for name, parent, p, (a, b), r in MANNEQUIN_SEGMENTS:
        bname = f"object_{k}_mannequin/{name}"
        if parent is None:
            body = s.worldbody.add_body(
                name=bname, pos=pos + np.array([0.0, 0.0, 0.12 * scale]), quat=q
            )
        else:
            body = bodies[parent].add_body(name=bname, pos=np.array(p) * scale)
            axis, (lo, hi) = MANNEQUIN_JOINTS[name]
            ang = float(rng.uniform(lo, hi))
            jn = body.add_joint(
                name=f"{bname}_joint",
                type=mujoco.mjtJoint.mjJNT_HINGE,
                axis=axis,
                range=[lo - 0.5, hi + 0.5],
                stiffness=20.0 * scale**3,
                damping=2.0 * scale**3,
                springref=ang,
            )
            pose[jn.name] = ang
        body.gravcomp = 1.0
        gname = f"{bname}_geom"
        body.add_geom(
            name=gname,
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=np.concatenate([np.array(a) * scale, np.array(b) * scale]),
            size=[r * scale, 0, 0],
            density=1000.0,
            group=1,
            contype=2,
            conaffinity=1,
            rgba=cls.rgba,
        )
        bodies[name] = body
        geoms.append(gname)
    return f"object_{k}_mannequin/pelvis", geoms, pose


def build_world(spec: WorldSpec) -> World:
    """Build the MuJoCo model and data of a scenario (see WorldSpec)."""
    if not isinstance(spec, WorldSpec):
        raise ValueError(f"build_world needs a WorldSpec, got {type(spec).__name__}")
    water = spec.water
    sb = generate_seabed(spec.seabed)
    xlo, xhi, ylo, yhi = sb.x[0], sb.x[-1], sb.y[0], sb.y[-1]

    s = mujoco.MjSpec()
    s.modelname = "undersea_world"
    s.compiler.degree = False  # angles (joint ranges, spring references) in radians
    s.option.timestep = float(spec.timestep)
    s.option.gravity = [0.0, 0.0, -water.gravity]
    s.option.density = 0.0
    s.option.viscosity = 0.0
    s.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    s.visual.map.zfar = 1000.0
    s.stat.extent = float(max(xhi - xlo, yhi - ylo))
    s.worldbody.add_light(
        pos=[0, 0, water.surface_z + 20],
        dir=[0, 0, -1],
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
    )
    _add_seabed(s, sb, spec.seabed_contacts)

    # ---- objects
    obj_geoms: dict[str, tuple[int, float]] = {}
    objects: list[tuple] = []  # (k, spec, pos, body name, static mesh or None, pose)
    mannequin_pose: dict[str, float] = {}
    for i, o in enumerate(spec.objects):
        k = i + 1
        x, y = (float(v) for v in o.position_xy)
        if not (xlo <= x <= xhi and ylo <= y <= yhi):
            raise ValueError(
                f"objects[{i}].position_xy {o.position_xy!r} lies outside the seabed "
                f"x in [{xlo:g}, {xhi:g}], y in [{ylo:g}, {yhi:g}]"
            )
        H = o.bbox[2]
        z = float(sb.height(np.array([[x, y]]))[0]) - o.burial * H
        pos = np.array([x, y, z])
        refl = float(o.reflectivity if o.reflectivity is not None else o.object_class.reflectivity)
        if o.object_class.articulated:
            root, gnames, pose = _add_mannequin(s, k, o, pos, np.random.default_rng(o.seed))
            mannequin_pose.update(pose)
            for g in gnames:
                obj_geoms[g] = (k, refl)
            objects.append((k, o, pos, root, None, refl))
            continue
        v, f = object_mesh(o)
        bname = f"object_{k}_{o.kind}"
        yaw = np.deg2rad(o.yaw_deg)
        body = s.worldbody.add_body(name=bname, pos=pos, quat=_yaw_quat(yaw))
        mesh = s.add_mesh(name=f"{bname}_mesh")
        mesh.uservert = v.ravel()
        mesh.userface = f.ravel()
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
        body.add_geom(
            name=f"{bname}_geom",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=f"{bname}_mesh",
            group=1,
            contype=2,
            conaffinity=1,
            rgba=o.object_class.rgba,
        )
        obj_geoms[f"{bname}_geom"] = (k, refl)
        c, sn = np.cos(yaw), np.sin(yaw)
        rot = np.array([[c, -sn, 0.0], [sn, c, 0.0], [0.0, 0.0, 1.0]])
        objects.append((k, o, pos, bname, (v @ rot.T + pos, f), refl))

    # ---- vehicles
    for i, vs in enumerate(spec.vehicles):
        vm = vehicle_model(vs.kind)
        p = np.asarray(vs.position, dtype=float)
        if not (xlo <= p[0] <= xhi and ylo <= p[1] <= yhi):
            raise ValueError(
                f"vehicles[{i}] ({vs.name}) position {vs.position!r} lies outside the seabed "
                f"x in [{xlo:g}, {xhi:g}], y in [{ylo:g}, {yhi:g}]"
            )
        floor = float(sb.height(p[None, :2])[0])
        if p[2] - 0.5 * vm.envelope[2] < floor:
            raise ValueError(
                f"vehicles[{i}] ({vs.name}) position z = {p[2]:g} m puts the hull below the "
                f"seabed (z = {floor:g} m there); allowed: z >= {floor + 0.5 * vm.envelope[2]:g}"
            )
        child = mujoco.MjSpec.from_file(str(vm.xml_path))
        for key in list(child.keys):
            child.delete(key)
        for act in list(child.actuators):  # viewer-only motors: thrust goes through sim.thrusters
            child.delete(act)
        if vs.mass is not None:
            base = child.body("base")
            scale = float(vs.mass) / base.mass
            base.mass = float(vs.mass)
            base.inertia = np.asarray(base.inertia) * scale
        r, pch, y = np.deg2rad(np.asarray(vs.rpy_deg, dtype=float))
        frame = s.worldbody.add_frame(pos=p, quat=wxyz_from_euler(r, pch, y))
        s.attach(child, prefix=f"{vs.name}/", frame=frame)

    try:
        model = s.compile()
    except Exception as e:  # MuJoCo's compiler error, re-raised with context
        raise ValueError(f"world MJCF failed to compile: {e}") from e
    data = mujoco.MjData(model)

    # ---- labels
    geom_object_id = np.full(model.ngeom, -1, dtype=np.int32)
    geom_refl = np.zeros(model.ngeom, dtype=np.float64)
    seabed_gid = model.geom("seabed").id
    geom_object_id[seabed_gid] = 0
    geom_refl[seabed_gid] = SEABED_REFLECTIVITY
    if spec.seabed_contacts:
        g = model.geom("seabed_contact").id
        geom_object_id[g] = 0
        geom_refl[g] = SEABED_REFLECTIVITY
    for gname, (k, refl) in obj_geoms.items():
        g = model.geom(gname).id
        geom_object_id[g] = k
        geom_refl[g] = refl
    static_parts = [(np.asarray(sb.vertices), np.asarray(sb.faces), seabed_gid)]
    infos = []
    for k, o, pos, bname, mesh, refl in objects:
        if mesh is not None:
            static_parts.append((mesh[0], mesh[1], model.geom(f"{bname}_geom").id))
        infos.append(
            ObjectInfo(
                id=k,
                class_name=o.object_class.class_name,
                reflectivity=refl,
                position=pos,
                body_name=bname,
                size=np.array(o.bbox),
                yaw=float(np.deg2rad(o.yaw_deg)),
                static=mesh is not None,
            )
        )
    for name, ang in mannequin_pose.items():
        data.qpos[model.jnt_qposadr[model.joint(name).id]] = ang

    world = World(
        model=model,
        data=data,
        water=water,
        objects=infos,
        geom_object_id=geom_object_id,
        geom_reflectivity=geom_refl,
        vehicles={},
        spec=spec,
        seabed=sb,
        current=CurrentField(spec.current),
        _static_parts=static_parts,
    )

    # ---- vehicles: handles, hydrodynamics, thrusters
    params, thr_specs, bids = [], [], []
    for i, vs in enumerate(spec.vehicles):
        vm = vehicle_model(vs.kind)
        bid = model.body(f"{vs.name}/base").id
        geoms = np.flatnonzero(model.geom_bodyid == bid)
        geom_refl[geoms] = VEHICLE_REFLECTIVITY
        if not (
            np.allclose(model.body_ipos[bid], 0)
            and np.allclose(np.abs(model.body_iquat[bid][0]), 1)
        ):
            raise ValueError(
                f"vehicle {vs.kind!r} MJCF must put the CoM at the body origin with principal axes along the body axes"
            )
        site_ids = {n: model.site(f"{vs.name}/{n}").id for n in SENSOR_SITES}
        positions, directions = {}, {}
        for n in vm.actuators:
            sid = model.site(f"{vs.name}/{n}").id
            rmat = np.empty(9)
            mujoco.mju_quat2Mat(rmat, model.site_quat[sid])
            positions[n] = model.site_pos[sid].copy()
            directions[n] = rmat.reshape(3, 3)[:, 2].copy()  # site z axis
        thr_specs.append(vm.thruster_specs(positions, directions, water.density))
        params.append(
            vm.hydro_params(
                float(model.body_mass[bid]),
                model.body_inertia[bid].copy(),
                water.density,
                vs.net_buoyancy,
            )
        )
        bids.append(bid)
        world.vehicles[vs.name] = VehicleHandle(
            world, i, vs.name, vm, bid, site_ids, tuple(vm.actuators)
        )
    world._hydro_params = params
    world._external = np.zeros((len(bids), 6))
    world._bid = np.array(bids, dtype=np.intp)
    world.thrusters = ThrusterBank(thr_specs, spec.timestep)
    if bids:
        world.hydro = HydroBatch(params, water.density, water.gravity, water.surface_z)
        adr = np.array([model.jnt_dofadr[model.body_jntadr[b]] for b in bids])
        world._dofs = adr[:, None] + np.arange(6)[None, :]
        world._body_ids = np.array(bids, dtype=np.intp)
        world._dof0 = adr.astype(np.intp)
        world._ids = np.ascontiguousarray(np.stack([world._body_ids, world._dof0]))
        world._addr = np.array([MJ_STEP1, MJ_STEP2, model._address, data._address], np.intp)
        # vehicles are attached last, one body and one free joint each: use slices (views,
        # cheaper than fancy indexing every step) when their ids are contiguous
        if np.array_equal(world._bid, np.arange(bids[0], bids[0] + len(bids))):
            world._bid = slice(int(bids[0]), int(bids[0]) + len(bids))
        if np.array_equal(world._dofs.ravel(), np.arange(adr[0], adr[0] + 6 * len(bids))):
            world._dofs = slice(int(adr[0]), int(adr[0]) + 6 * len(bids))
    world._init_qpos = data.qpos.copy()
    world._forward()
    return world
