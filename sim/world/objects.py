"""The seabed object library: class name, acoustic reflectivity and generated geometry.

Geometry is generated in code with trimesh from a few parameters and a seed, and cached
on disk (``sim.world.cache``), never committed. Each generator returns a mesh in the
object's local frame: x along its length, z up, the lowest point at z = 0 (it rests on
the seabed; ``burial`` sinks it).

Reflectivity is the linear backscatter strength factor in [0, 1] the sonar multiplies
its echo by (steel = 1). The ranking follows published backscatter strengths at
moderate grazing angles (Lurton 2010, *An Introduction to Underwater Acoustics*,
ch. 3.6; APL-UW 1994 high-frequency model): steel and concrete structures are strong
(near-specular, −5…0 dB), rock −15…−10 dB, rubber/wood/plastic weaker, medium sand
−25…−20 dB. The absolute values are an assumption of this project; the sonar helper
calibrates overall level.

Contacts: MuJoCo collides mesh geoms through their convex hull, so for a vehicle the
hollow pipe, the tyre and the branch fork are solid (rays and the static mesh use the
true triangles). Objects never collide with each other or the seabed (they are placed).

The mannequin is articulated: a kinematic tree of capsules with hinge joints (spring-
loaded to a seeded pose, gravity-compensated as a flooded plastic body resting on the
floor), built straight into the MJCF by the world builder.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from sim.world.cache import cached_mesh

SEABED_REFLECTIVITY = 0.3  # medium sand
VEHICLE_REFLECTIVITY = 0.8  # painted aluminium / composite hull


@dataclass(frozen=True)
class ObjectClass:
    class_name: str
    reflectivity: float
    default_size: tuple[float, float, float]  # bbox L, W, H, m
    articulated: bool = False
    rgba: tuple[float, float, float, float] = (0.5, 0.5, 0.5, 1.0)


OBJECT_CLASSES: dict[str, ObjectClass] = {
    "shipwreck": ObjectClass("shipwreck", 1.0, (20.0, 5.0, 4.0), rgba=(0.45, 0.3, 0.2, 1)),
    "tree_branch": ObjectClass("tree_branch", 0.35, (3.0, 1.5, 0.3), rgba=(0.35, 0.25, 0.15, 1)),
    "mannequin": ObjectClass("mannequin", 0.25, (1.75, 0.5, 0.25), True, rgba=(0.9, 0.8, 0.7, 1)),
    "rock": ObjectClass("rock", 0.6, (1.2, 0.9, 0.6), rgba=(0.4, 0.4, 0.38, 1)),
    "pipe": ObjectClass("pipe", 0.9, (10.0, 0.5, 0.5), rgba=(0.3, 0.3, 0.3, 1)),
    "tyre": ObjectClass("tyre", 0.5, (0.7, 0.7, 0.22), rgba=(0.1, 0.1, 0.1, 1)),
    "sensor_node": ObjectClass("sensor_node", 0.85, (0.5, 0.5, 0.8), rgba=(0.9, 0.5, 0.1, 1)),
}
OBJECT_KINDS = tuple(OBJECT_CLASSES)


@dataclass(frozen=True)
class ObjectSpec:
    """One seabed object.

    kind         : one of OBJECT_KINDS.
    position_xy  : (x, y) world position of its base centre, m (z follows the seabed).
    yaw_deg      : heading of its local x axis, counter-clockwise from east.
    size         : (L, W, H) bounding box, m (None -> the class default).
    burial       : fraction of the height sunk into the seabed, [0, 0.9].
    seed         : seed of its shape.
    reflectivity : override of the class reflectivity, [0, 1].
    """

    kind: str
    position_xy: tuple[float, float] = (0.0, 0.0)
    yaw_deg: float = 0.0
    size: tuple[float, float, float] | None = None
    burial: float = 0.0
    seed: int = 0
    reflectivity: float | None = None

    def __post_init__(self) -> None:
        if self.kind not in OBJECT_CLASSES:
            raise ValueError(f"object kind must be one of {OBJECT_KINDS}, got {self.kind!r}")
        p = np.asarray(self.position_xy, dtype=float)
        if p.shape != (2,) or not np.isfinite(p).all():
            raise ValueError(
                f"object position_xy must be 2 finite numbers, got {self.position_xy!r}"
            )
        if not np.isfinite(self.yaw_deg):
            raise ValueError(f"object yaw_deg must be finite, got {self.yaw_deg!r}")
        if self.size is not None:
            s = np.asarray(self.size, dtype=float)
            if s.shape != (3,) or not np.isfinite(s).all() or np.any(s <= 0):
                raise ValueError(
                    f"object size must be 3 positive lengths (L, W, H) in m, got {self.size!r}"
                )
        if not 0.0 <= float(self.burial) <= 0.9:
            raise ValueError(f"object burial must be in [0, 0.9], got {self.burial!r}")
        if self.reflectivity is not None and not 0.0 <= float(self.reflectivity) <= 1.0:
            raise ValueError(f"object reflectivity must be in [0, 1], got {self.reflectivity!r}")

    @property
    def object_class(self) -> ObjectClass:
        return OBJECT_CLASSES[self.kind]

    @property
    def bbox(self) -> tuple[float, float, float]:
        return tuple(float(v) for v in (self.size or self.object_class.default_size))


def _fit(mesh: trimesh.Trimesh, size: tuple[float, float, float]) -> trimesh.Trimesh:
    """Scale to the bbox size and put the base centre at the origin (lowest point z = 0)."""
    lo, hi = mesh.bounds
    ext = np.maximum(hi - lo, 1e-9)
    mesh.apply_translation(-(lo + hi) / 2)
    mesh.apply_scale(1.0)  # keep trimesh caches consistent
    mesh.vertices = mesh.vertices * (np.asarray(size) / ext)
    mesh.apply_translation([0, 0, -mesh.bounds[0][2]])
    return mesh


def wigley_hull(length: float, beam: float, draft: float, freeboard: float, n=(48, 12)):
    """Closed hull surface of the Wigley parabolic hull (Wigley 1934; the ITTC benchmark
    hull form): half-breadth y = (B/2)(1 − (2x/L)²)(1 − (z/T)²) below the waterline
    (−T ≤ z ≤ 0), walls carried up vertically to the deck at z = freeboard, deck closed.
    Local frame: x forward, z up, waterline at z = 0."""
    nx, nz = n
    x = np.linspace(-0.5 * length, 0.5 * length, nx)
    z = np.concatenate([np.linspace(-draft, 0.0, nz), [freeboard]])
    zz = np.minimum(z, 0.0)
    y = 0.5 * beam * (1 - (2 * x[:, None] / length) ** 2) * (1 - (zz[None, :] / draft) ** 2)
    X = np.broadcast_to(x[:, None], y.shape)
    Z = np.broadcast_to(z[None, :], y.shape)
    port = np.stack([X, y, Z], -1).reshape(-1, 3)
    stbd = np.stack([X, -y, Z], -1).reshape(-1, 3)
    nzz = z.size
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(nzz - 1), indexing="ij")
    a = (i * nzz + j).ravel()
    b, c, d = a + nzz, a + nzz + 1, a + 1
    side = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    off = port.shape[0]
    top = np.arange(nx - 1) * nzz + nzz - 1  # deck edge vertices
    deck = np.concatenate(
        [
            np.stack([top, off + top + nzz, top + nzz], 1),
            np.stack([top, off + top, off + top + nzz], 1),
        ]
    )
    faces = np.concatenate([side, side[:, ::-1] + off, deck])
    return trimesh.Trimesh(np.concatenate([port, stbd]), faces, process=False)


def _shipwreck(size, rng: np.random.Generator) -> trimesh.Trimesh:
    """A small steel coaster wreck: Wigley hull with sheer-less deck, bridge house,
    funnel, hatch coaming, foremast with a derrick, and debris alongside; lying listed and
    trimmed. Proportions of a ~20 m coaster (L/B ≈ 4, depth ≈ 0.5 B)."""
    L, B, H = size
    draft, free = 0.35 * H, 0.2 * H
    parts = [wigley_hull(L, B, draft, free)]
    deck = free

    def box(ext, at):
        m = trimesh.creation.box(ext)
        m.apply_translation(at)
        parts.append(m)

    def cyl(radius, height, at, tilt=0.0):
        m = trimesh.creation.cylinder(radius=radius, height=height, sections=16)
        m.apply_translation([0, 0, 0.5 * height])
        if tilt:
            m.apply_transform(trimesh.transformations.rotation_matrix(tilt, [0, 1, 0]))
        m.apply_translation(at)
        parts.append(m)

    box([0.16 * L, 0.55 * B, 0.22 * H], [-0.28 * L, 0, deck + 0.11 * H])  # bridge house
    box([0.1 * L, 0.4 * B, 0.08 * H], [-0.28 * L, 0, deck + 0.26 * H])  # wheelhouse top
    cyl(0.07 * B, 0.2 * H, [-0.38 * L, 0, deck])  # funnel
    box([0.22 * L, 0.45 * B, 0.06 * H], [0.05 * L, 0, deck + 0.03 * H])  # hatch coaming
    cyl(0.025 * B + 0.03, 0.42 * H, [0.25 * L, 0, deck])  # foremast
    cyl(0.015 * B + 0.02, 0.25 * L, [0.25 * L, 0, deck + 0.1 * H], tilt=-1.2)  # derrick
    for _ in range(4):  # debris alongside (plates, a drum)
        px = rng.uniform(-0.4, 0.4) * L
        py = rng.choice([-1, 1]) * rng.uniform(0.3, 0.45) * B
        box(
            [rng.uniform(0.4, 1.2), rng.uniform(0.3, 0.8), rng.uniform(0.05, 0.2)], [px, py, -draft]
        )
    m = trimesh.util.concatenate(parts)
    roll = np.deg2rad(rng.uniform(8, 25)) * rng.choice([-1, 1])
    pitch = np.deg2rad(rng.uniform(-3, 3))
    m.apply_transform(trimesh.transformations.euler_matrix(roll, pitch, 0.0))
    return _fit(m, size)


def _tree_branch(size, rng) -> trimesh.Trimesh:
    L, _, H = size
    r0 = 0.5 * H
    parts = [trimesh.creation.cylinder(radius=r0, segment=[[0, 0, 0], [L, 0, 0]], sections=10)]
    for _ in range(int(rng.integers(2, 5))):
        s = rng.uniform(0.15, 0.8) * L
        ang = rng.uniform(0.35, 0.9) * rng.choice([-1, 1])
        ln = rng.uniform(0.25, 0.5) * L
        tip = [s + ln * np.cos(ang), ln * np.sin(ang), rng.uniform(0, 0.5) * r0]
        parts.append(
            trimesh.creation.cylinder(
                radius=r0 * rng.uniform(0.4, 0.7), segment=[[s, 0, 0], tip], sections=8
            )
        )
    return _fit(trimesh.util.concatenate(parts), size)


def _rock(size, rng) -> trimesh.Trimesh:
    m = trimesh.creation.icosphere(subdivisions=3)
    d = rng.normal(size=(6, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    w = rng.uniform(-0.12, 0.12, 6)
    v = m.vertices
    r = 1.0 + (np.abs(v @ d.T) ** 2 * w).sum(1) + 0.04 * rng.standard_normal(len(v))
    v = v * r[:, None]
    v[:, 2] = np.maximum(v[:, 2], -0.4)  # flat, settled underside
    m.vertices = v
    return _fit(m, size)


def _pipe(size, rng) -> trimesh.Trimesh:
    L, W, _ = size
    m = trimesh.creation.annulus(r_min=0.42 * W, r_max=0.5 * W, height=L, sections=24)
    m.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    return _fit(m, size)


def _tyre(size, rng) -> trimesh.Trimesh:
    L, _, H = size
    m = trimesh.creation.torus(major_radius=0.5 * L - 0.5 * H, minor_radius=0.5 * H)
    tilt = np.deg2rad(rng.uniform(0, 10))
    m.apply_transform(trimesh.transformations.rotation_matrix(tilt, [1, 0, 0]))
    return _fit(m, size)


def _sensor_node(size, rng) -> trimesh.Trimesh:
    base = trimesh.creation.cylinder(radius=0.5, height=0.2, sections=24)
    base.apply_translation([0, 0, 0.1])
    mast = trimesh.creation.cylinder(radius=0.06, height=0.6, sections=12)
    mast.apply_translation([0, 0, 0.5])
    buoy = trimesh.creation.icosphere(subdivisions=2, radius=0.18)
    buoy.apply_translation([0, 0, 0.82])
    return _fit(trimesh.util.concatenate([base, mast, buoy]), size)


_GENERATORS = {
    "shipwreck": _shipwreck,
    "tree_branch": _tree_branch,
    "rock": _rock,
    "pipe": _pipe,
    "tyre": _tyre,
    "sensor_node": _sensor_node,
}


def object_mesh(spec: ObjectSpec) -> tuple[np.ndarray, np.ndarray]:
    """Local-frame (vertices (V,3), faces (F,3) int32) of a static object, cached."""
    if spec.object_class.articulated:
        raise ValueError(f"object kind {spec.kind!r} is articulated and has no single mesh")
    params = {"kind": spec.kind, "size": list(spec.bbox), "seed": int(spec.seed)}
    if spec.kind == "shipwreck":
        params["shape"] = "wigley-coaster-1"  # the generator changed: new cache entries

    def build():
        m = _GENERATORS[spec.kind](spec.bbox, np.random.default_rng(spec.seed))
        return np.asarray(m.vertices), np.asarray(m.faces)

    return cached_mesh(params, build)


# Mannequin: (name, parent, pos in parent (m, standing pose, z up), capsule from-to in body, radius)
MANNEQUIN_SEGMENTS = (
    ("pelvis", None, (0.0, 0.0, 0.0), ((0, -0.09, 0), (0, 0.09, 0)), 0.09),
    ("torso", "pelvis", (0.0, 0.0, 0.08), ((0, 0, 0), (0, 0, 0.42)), 0.12),
    ("head", "torso", (0.0, 0.0, 0.5), ((0, 0, 0), (0, 0, 0.14)), 0.1),
    ("upper_arm_l", "torso", (0.0, 0.2, 0.4), ((0, 0, 0), (0, 0, -0.28)), 0.045),
    ("lower_arm_l", "upper_arm_l", (0.0, 0.0, -0.3), ((0, 0, 0), (0, 0, -0.27)), 0.04),
    ("upper_arm_r", "torso", (0.0, -0.2, 0.4), ((0, 0, 0), (0, 0, -0.28)), 0.045),
    ("lower_arm_r", "upper_arm_r", (0.0, 0.0, -0.3), ((0, 0, 0), (0, 0, -0.27)), 0.04),
    ("thigh_l", "pelvis", (0.0, 0.09, -0.05), ((0, 0, 0), (0, 0, -0.4)), 0.07),
    ("shin_l", "thigh_l", (0.0, 0.0, -0.42), ((0, 0, 0), (0, 0, -0.4)), 0.055),
    ("thigh_r", "pelvis", (0.0, -0.09, -0.05), ((0, 0, 0), (0, 0, -0.4)), 0.07),
    ("shin_r", "thigh_r", (0.0, 0.0, -0.42), ((0, 0, 0), (0, 0, -0.4)), 0.055),
)
# hinge axis (in the segment frame) and pose range (rad) of each joint
MANNEQUIN_JOINTS = {
    "torso": ((0, 1, 0), (-0.3, 0.3)),
    "head": ((0, 1, 0), (-0.5, 0.5)),
    "upper_arm_l": ((1, 0, 0), (0.1, 1.4)),
    "lower_arm_l": ((0, 1, 0), (-1.5, 0.0)),
    "upper_arm_r": ((1, 0, 0), (-1.4, -0.1)),
    "lower_arm_r": ((0, 1, 0), (-1.5, 0.0)),
    "thigh_l": ((1, 0, 0), (0.0, 0.4)),
    "shin_l": ((0, 1, 0), (0.0, 1.2)),
    "thigh_r": ((1, 0, 0), (-0.4, 0.0)),
    "shin_r": ((0, 1, 0), (0.0, 1.2)),
}


def scatter_objects(
    rng: np.random.Generator,
    n: int,
    area: tuple[float, float, float, float],
    kinds: tuple[str, ...] = OBJECT_KINDS,
    min_spacing: float = 5.0,
    max_burial: float = 0.3,
) -> tuple[ObjectSpec, ...]:
    """n seeded objects in area (x_min, x_max, y_min, y_max), m: kinds drawn uniformly,
    random heading, burial in [0, max_burial], shape seeds, centres at least
    ``min_spacing`` m apart (a batch of candidates is drawn and greedily thinned; raises
    ValueError when the area cannot hold n objects at that spacing)."""
    if int(n) < 0:
        raise ValueError(f"n must be >= 0, got {n!r}")
    x0, x1, y0, y1 = (float(v) for v in area)
    if not (x1 > x0 and y1 > y0):
        raise ValueError(f"area must be (x_min, x_max, y_min, y_max) with min < max, got {area!r}")
    bad = [k for k in kinds if k not in OBJECT_CLASSES]
    if bad or not kinds:
        raise ValueError(f"kinds must be a non-empty subset of {OBJECT_KINDS}, got {kinds!r}")
    if not 0.0 <= max_burial <= 0.9:
        raise ValueError(f"max_burial must be in [0, 0.9], got {max_burial!r}")
    cand = rng.uniform([x0, y0], [x1, y1], size=(max(50 * int(n), 100), 2))
    keep: list[np.ndarray] = []
    for p in cand:  # build time only
        if len(keep) == n:
            break
        if not keep or np.min(np.linalg.norm(np.array(keep) - p, axis=1)) >= min_spacing:
            keep.append(p)
    if len(keep) < n:
        raise ValueError(
            f"area {area!r} holds only {len(keep)} objects at min_spacing {min_spacing} m, asked for {n}"
        )
    out = []
    for p in keep:
        out.append(
            ObjectSpec(
                kind=str(rng.choice(kinds)),
                position_xy=(float(p[0]), float(p[1])),
                yaw_deg=float(rng.uniform(0.0, 360.0)),
                burial=float(rng.uniform(0.0, max_burial)),
                seed=int(rng.integers(0, 2**31 - 1)),
            )
        )
    return tuple(out)
