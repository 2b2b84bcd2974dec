"""Small self-contained MJCF scenes for sonar tests, benchmarks and demos.

A triangulated seabed mesh (flat or gently rolling), a few static objects, and a
"vehicle" body (free joint, box hull) carrying the sonar sites ``sss_port``,
``sss_starboard``, ``fls`` and ``msis`` (x forward, y port, z up). These are not the
project's world (``sim.world``); they let the sonar be tested and timed on its own.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from sim.sonar.config import Water


@dataclass(frozen=True)
class SceneObject:
    """A static object: kind "box" (size = half-extents), "sphere" (size[0] radius),
    "cylinder" (radius, half-height); pos world m (centre); reflectivity in [0, 1]."""

    kind: str
    pos: tuple[float, float, float]
    size: tuple[float, ...]
    reflectivity: float = 1.0
    moving: bool = False
    euler_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class SonarScene:
    """model, data (after mj_forward), site ids, geom_object_id / geom_reflectivity per the
    world contract (0 seabed, k object, −1 vehicle), water, vehicle root body id."""

    model: mujoco.MjModel
    data: mujoco.MjData
    sites: dict[str, int]
    geom_object_id: np.ndarray
    geom_reflectivity: np.ndarray
    water: Water
    vehicle_body: int
    objects: list[SceneObject] = field(default_factory=list)

    def qpos_adr(self, body: int | str) -> int:
        """First qpos index of a free-jointed body (by id or name): x, y, z, qw, qx, qy, qz."""
        b = (
            body
            if isinstance(body, int)
            else mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, body)
        )
        return int(self.model.jnt_qposadr[self.model.body_jntadr[b]])

    def sidescan(self, cfg, site: str = "sss", **kwargs):
        """A ``SideScanSonar`` with config ``cfg`` mounted at ``site`` of this scene
        (``kwargs``: e.g. ``backend``)."""
        from sim.sonar.sidescan import SideScanSonar  # the scene module stays import-light

        return SideScanSonar(
            cfg,
            self.model,
            self.data,
            self.sites[site],
            self.geom_object_id,
            self.geom_reflectivity,
            self.water,
            **kwargs,
        )

    def move_vehicle(self, x: float, y: float | None = None, z: float | None = None) -> None:
        """Place the vehicle (world m) and update kinematics (``mj_kinematics``)."""
        a = self.qpos_adr(self.vehicle_body)
        self.data.qpos[a] = x
        if y is not None:
            self.data.qpos[a + 1] = y
        if z is not None:
            self.data.qpos[a + 2] = z
        mujoco.mj_kinematics(self.model, self.data)


def seabed_grid(
    size: float,
    cells: int,
    relief: float = 0.0,
    seed: int = 0,
    ripples: tuple[float, float] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Seabed triangles over a square of side ``size`` m centred on the origin, z = 0 mean,
    ``cells × cells`` quads (2·cells² triangles), optional smooth relief amplitude (m) and
    sand ripples ``(height, wavelength)`` m with crests along y.

    MuJoCo 4.0's ray–mesh test is not watertight: a ray passing exactly through a shared
    triangle edge can miss both triangles (Embree does not). A fan in the vertical plane
    through a grid line would lose every ray, so ``build_scene`` shifts the grid by a few
    centimetres off round coordinates."""
    x = np.linspace(-size / 2, size / 2, cells + 1)
    X, Y = np.meshgrid(x, x)
    Z = np.zeros_like(X)
    if relief > 0:
        rng = np.random.default_rng(seed)
        for _ in range(6):
            k = rng.uniform(0.02, 0.1, 2)
            ph = rng.uniform(0, 2 * np.pi, 2)
            Z += relief / 6 * np.sin(k[0] * X + ph[0]) * np.cos(k[1] * Y + ph[1])
    if ripples is not None:
        Z += 0.5 * ripples[0] * np.sin(2 * np.pi * X / ripples[1])
    V = np.stack([X.ravel(), Y.ravel(), Z.ravel()], 1)
    i = np.arange((cells + 1) ** 2).reshape(cells + 1, cells + 1)
    a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel()
    F = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    F = F.astype(np.int32)
    return V, F


def build_scene(
    altitude: float = 10.0,
    objects: list[SceneObject] | tuple[SceneObject, ...] = (),
    seabed_size: float = 200.0,
    seabed_cells: int = 40,
    relief: float = 0.0,
    ripples: tuple[float, float] | None = None,
    vehicle_pos: tuple[float, float] = (0.0, 0.0),
    vehicle_yaw: float = 0.0,
    seabed_reflectivity: float = 1.0,
    water: Water | None = None,
    zero_gravity: bool = True,
) -> SonarScene:
    """Build a scene with the vehicle at ``altitude`` m above the z = 0 seabed."""
    V, F = seabed_grid(seabed_size, seabed_cells, relief, ripples=ripples)
    vtx = " ".join(f"{v:.6g}" for v in V.ravel())
    fcs = " ".join(str(int(f)) for f in F.ravel())
    body = []
    for k, o in enumerate(objects, start=1):
        size = " ".join(f"{s:g}" for s in o.size)
        pos = " ".join(f"{p:g}" for p in o.pos)
        eul = " ".join(f"{e:g}" for e in o.euler_deg)
        geom = (
            f'<geom name="obj{k}" type="{o.kind}" size="{size}" euler="{eul}" '
            'contype="0" conaffinity="0" mass="1"/>'
        )
        if o.moving:
            body.append(f'<body name="obj{k}" pos="{pos}"><freejoint/>{geom}</body>')
        else:
            body.append(f'<body name="obj{k}" pos="{pos}">{geom}</body>')
    cy, sy = np.cos(vehicle_yaw / 2), np.sin(vehicle_yaw / 2)
    grav = 'gravity="0 0 0"' if zero_gravity else ""
    # angles in degrees (MuJoCo default)
    xml = f"""<mujoco model="sonar_scene">
  <option {grav} density="0" viscosity="0"/>
  <asset><mesh name="seabed" vertex="{vtx}" face="{fcs}" inertia="shell"/></asset>
  <worldbody>
    <geom name="seabed" type="mesh" mesh="seabed" pos="0.0371 0.0529 0" contype="0" conaffinity="0"/>
    {"".join(body)}
    <body name="vehicle" pos="{vehicle_pos[0]:g} {vehicle_pos[1]:g} {altitude:g}" quat="{cy:g} 0 0 {sy:g}">
      <freejoint/>
      <geom name="hull" type="box" size="1 0.2 0.2" mass="70" contype="0" conaffinity="0"/>
      <site name="sss_port" pos="0 0.2 -0.1"/>
      <site name="sss_starboard" pos="0 -0.2 -0.1"/>
      <site name="sss" pos="0 0 -0.2"/>
      <site name="fls" pos="1.0 0 0"/>
      <site name="msis" pos="0.5 0 0.2"/>
    </body>
  </worldbody>
</mujoco>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    oid = np.full(model.ngeom, -1, np.int32)
    refl = np.ones(model.ngeom)
    sb = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "seabed")
    oid[sb] = 0
    refl[sb] = seabed_reflectivity
    for k, o in enumerate(objects, start=1):
        g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"obj{k}")
        oid[g] = k
        refl[g] = o.reflectivity
    sites = {
        n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, n)
        for n in ("sss_port", "sss_starboard", "sss", "fls", "msis")
    }
    vb = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "vehicle")
    return SonarScene(model, data, sites, oid, refl, water or Water(), vb, list(objects))
