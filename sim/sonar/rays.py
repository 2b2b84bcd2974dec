"""Ray-casting backends: MuJoCo ``mj_multiRay`` and Embree (``embreex``) + MuJoCo.

Both cast a bundle of rays from one origin (the sonar's acoustic centre) and return, per
ray, the distance (m, ``inf`` for no hit up to the cutoff), the geom id (−1 none) and the
unit surface normal in the world frame.

* :class:`MujocoRays`: everything through ``mujoco.mj_multiRay`` (the physics scene as is).
* :class:`EmbreeRays`: the static part of the scene (geoms welded to the world body) as a
  world-frame triangle mesh in Embree, moving bodies through ``mj_multiRay`` with
  ``flg_static=0``; the nearer hit wins. The static mesh comes from the world
  (``World.static_mesh()``) or is tessellated from the model here: mesh and box geoms
  exactly, planes as a finite square, other primitives with a chord error below
  ``tessellation_tol`` (default 0.25 mm). Embree works in float32: hits agree with MuJoCo
  to well below 1 mm (tested).

MuJoCo ignores geoms whose rgba alpha is 0; the tessellation does the same.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import mujoco
import numpy as np
from numpy.lib.stride_tricks import as_strided

from sim.sonar.ray_cones import RayCones, gather_hits, near_rays, ray_cones

__all__ = ["EmbreeRays", "MujocoRays", "RayCones", "RayHits", "make_backend", "ray_cones"]


@dataclass(frozen=True)
class RayHits:
    """Hits of a ray bundle. dist (N,) m (inf = no hit); geom (N,) int32 (−1 = none);
    normal (N, 3) unit world-frame normals (zeros where no hit)."""

    dist: np.ndarray
    geom: np.ndarray
    normal: np.ndarray


class RayBackend(Protocol):
    def cast(
        self,
        data: mujoco.MjData,
        origin: np.ndarray,
        dirs: np.ndarray,
        cutoff: float,
        cones: RayCones | None = None,
    ) -> RayHits:
        """Cast unit directions ``dirs`` (N, 3) world frame from ``origin`` (3,);
        ``cones``: optional bounding cones of ``dirs`` (a hint; results do not change)."""
        ...


class MujocoRays:
    """All geoms through ``mj_multiRay`` (geomgroup None = all groups, flg_static 1),
    excluding ``bodyexclude`` (the sonar's own vehicle root body; −1 for none)."""

    def __init__(self, model: mujoco.MjModel, bodyexclude: int = -1, flg_static: bool = True):
        self.model = model
        self.bodyexclude = int(bodyexclude)
        self.flg_static = bool(flg_static)

    def cast(
        self,
        data: mujoco.MjData,
        origin: np.ndarray,
        dirs: np.ndarray,
        cutoff: float,
        cones: RayCones | None = None,
    ) -> RayHits:
        n = dirs.shape[0]
        geom = np.empty(n, np.int32)
        dist = np.empty(n, np.float64)
        normal = np.empty(3 * n, np.float64)
        mujoco.mj_multiRay(
            self.model,
            data,
            np.ascontiguousarray(origin, np.float64),
            np.ascontiguousarray(dirs, np.float64).ravel(),
            None,
            self.flg_static,
            self.bodyexclude,
            geom,
            dist,
            normal,
            n,
            float(cutoff),
        )
        miss = (geom < 0) | (dist < 0) | (dist > cutoff)
        dist[miss] = np.inf
        geom[miss] = -1
        return RayHits(dist, geom, normal.reshape(n, 3))


def _geom_visible(model: mujoco.MjModel, g: int) -> bool:
    matid = model.geom_matid[g]
    alpha = model.mat_rgba[matid, 3] if matid >= 0 else model.geom_rgba[g, 3]
    return bool(alpha != 0)


_BOX_FACES = np.array(
    [
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ],
    np.int32,
)


def _local_mesh(model: mujoco.MjModel, g: int, tol: float, plane_half: float):
    """Triangles of geom g in its own frame: (V, 3) float64, (F, 3) int32, or None."""
    import trimesh

    t = int(model.geom_type[g])
    size = model.geom_size[g]
    G = mujoco.mjtGeom
    if t == G.mjGEOM_HFIELD:
        hid = model.geom_dataid[g]
        nr, nc = int(model.hfield_nrow[hid]), int(model.hfield_ncol[hid])
        adr = model.hfield_adr[hid]
        rx, ry, ez, _ = model.hfield_size[hid]
        z = model.hfield_data[adr : adr + nr * nc].reshape(nr, nc) * ez
        X, Y = np.meshgrid(np.linspace(-rx, rx, nc), np.linspace(-ry, ry, nr))
        v = np.stack([X.ravel(), Y.ravel(), z.ravel()], 1)
        i = np.arange(nr * nc).reshape(nr, nc)
        a, b, c, d = i[:-1, :-1].ravel(), i[:-1, 1:].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel()
        return v, np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)]).astype(np.int32)
    if t == G.mjGEOM_MESH:
        mid = model.geom_dataid[g]
        va, vn = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
        fa, fn = model.mesh_faceadr[mid], model.mesh_facenum[mid]
        return model.mesh_vert[va : va + vn].astype(float), model.mesh_face[fa : fa + fn].astype(
            np.int32
        )
    if t == G.mjGEOM_BOX:
        s = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * size
        return s, _BOX_FACES
    if t == G.mjGEOM_PLANE:
        hx = size[0] if size[0] > 0 else plane_half
        hy = size[1] if size[1] > 0 else plane_half
        v = np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], float)
        return v, np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    if t in (G.mjGEOM_SPHERE, G.mjGEOM_ELLIPSOID):
        radii = np.full(3, size[0]) if t == G.mjGEOM_SPHERE else size[:3]
        r = float(np.max(radii))
        # icosphere edge angle ≈ 1.107 / 2^s rad; chord error r(1 − cos(a/2)) ≤ tol
        s = 0
        while r * (1.0 - math.cos(1.107 / 2**s / 2.0)) > tol and s < 8:
            s += 1
        m = trimesh.creation.icosphere(subdivisions=s, radius=1.0)
        return np.asarray(m.vertices) * radii, np.asarray(m.faces, np.int32)
    if t in (G.mjGEOM_CYLINDER, G.mjGEOM_CAPSULE):
        r, half = float(size[0]), float(size[1])
        sections = max(16, math.ceil(math.pi / math.acos(max(1.0 - tol / r, -1.0))))
        if t == G.mjGEOM_CYLINDER:
            m = trimesh.creation.cylinder(radius=r, height=2 * half, sections=sections)
        else:
            m = trimesh.creation.capsule(height=2 * half, radius=r, count=[sections, sections])
        return np.asarray(m.vertices), np.asarray(m.faces, np.int32)
    return None


def static_mesh_from_model(
    model: mujoco.MjModel, data: mujoco.MjData, tol: float = 2.5e-4, plane_half: float = 2000.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World-frame triangles (V (V,3), F (F,3) int32, geom id per face (F,)) of every visible
    geom welded to the world body (needs ``data`` after ``mj_forward``/``mj_kinematics``)."""
    verts, faces, gids = [], [], []
    offset = 0
    for g in range(model.ngeom):
        if model.body_weldid[model.geom_bodyid[g]] != 0 or not _geom_visible(model, g):
            continue
        local = _local_mesh(model, g, tol, plane_half)
        if local is None:
            continue
        v, f = local
        R = data.geom_xmat[g].reshape(3, 3)
        verts.append(v @ R.T + data.geom_xpos[g])
        faces.append(f + offset)
        gids.append(np.full(len(f), g, np.int32))
        offset += len(v)
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int32), np.zeros(0, np.int32)
    return np.concatenate(verts), np.concatenate(faces), np.concatenate(gids)


class EmbreeRays:
    """Static scene in Embree, moving bodies through MuJoCo (``flg_static=0``).

    ``static_mesh``: optional (V, F, geom_id per face) world-frame triangles, e.g. from
    ``World.static_mesh()``; default: tessellated from ``model``/``data``. Embree runs in
    float32, so vertices are stored relative to their centroid to keep precision. The
    cast reuses its input buffers between calls: one instance is not for concurrent
    threads (processes, as ``sim.parallel`` runs them, are fine).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        bodyexclude: int = -1,
        static_mesh: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
        tessellation_tol: float = 2.5e-4,
    ):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        self.model = model
        V, F, G = (
            static_mesh
            if static_mesh is not None
            else static_mesh_from_model(model, data, tessellation_tol)
        )
        self.face_geom = np.append(np.asarray(G, np.int32), -1)  # index -1 (miss) → -1
        self.center = np.asarray(V, float).mean(axis=0) if len(V) else np.zeros(3)
        # unit face normals in float64 (index −1, a miss, → zeros): cheaper and more exact
        # than normalising Embree's float32 geometric normal per hit
        Vd = np.asarray(V, float)
        Fi = np.asarray(F, np.int64)
        if len(Fi):
            fn = np.cross(Vd[Fi[:, 1]] - Vd[Fi[:, 0]], Vd[Fi[:, 2]] - Vd[Fi[:, 0]])
            ln = np.linalg.norm(fn, axis=1, keepdims=True)
            fn = np.where(ln > 0, fn / np.where(ln > 0, ln, 1.0), 0.0)
        else:
            fn = np.zeros((0, 3))
        self.face_normal = np.concatenate([fn, np.zeros((1, 3))])
        self.scene = None
        if len(F):
            self.scene = rtcore_scene.EmbreeScene()
            TriangleMesh(
                self.scene,
                (np.asarray(V, float) - self.center).astype(np.float32),
                np.ascontiguousarray(F, np.int32),
            )
        self.dyn_geoms = np.array(
            [
                g
                for g in range(model.ngeom)
                if model.body_weldid[model.geom_bodyid[g]] != 0
                and model.body_rootid[model.geom_bodyid[g]] != bodyexclude
                and _geom_visible(model, g)
            ],
            dtype=np.int64,
        )
        self.mujoco = (
            MujocoRays(model, bodyexclude, flg_static=False) if self.dyn_geoms.size else None
        )
        self._dyn_rbound = np.ascontiguousarray(model.geom_rbound[self.dyn_geoms], np.float64)
        self._origin32 = np.zeros(3, np.float32)  # the cast's origin, relative to center
        # per ray count n: (origins, tmax) views (a two-site side-scan alternates three n)
        self._views: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def cast_static(self, origins: np.ndarray, dirs: np.ndarray, cutoff: float) -> RayHits:
        """Rays from many origins (N, 3) world m against the static scene only (secondary
        rays of target corner returns)."""
        n = dirs.shape[0]
        if self.scene is None or n == 0:
            return RayHits(np.full(n, np.inf), np.full(n, -1, np.int32), np.zeros((n, 3)))
        o = (np.asarray(origins, float) - self.center).astype(np.float32)
        tmax = np.full(n, cutoff, np.float32)
        res = self.scene.run(o, np.ascontiguousarray(dirs, np.float32), tmax, output=1)
        prim = res["primID"]
        dist = np.where(prim >= 0, res["tfar"], np.inf).astype(np.float64)
        return RayHits(dist, self.face_geom[prim], self.face_normal[prim])

    def cast(
        self,
        data: mujoco.MjData,
        origin: np.ndarray,
        dirs: np.ndarray,
        cutoff: float,
        cones: RayCones | None = None,
    ) -> RayHits:
        """``dirs`` (N, 3) unit world directions (float64 or float32); ``cones``: optional
        world-frame bounding cones of ``dirs`` (:func:`ray_cones`, rotated with the
        sensor), which restrict the moving-body test to the rays of chunks whose cone
        meets a moving geom's bounding sphere (same rays found, far fewer tested)."""
        n = dirs.shape[0]
        if self.scene is not None:
            o, tmax = self._ray_buffers(origin, n, cutoff)
            res = self.scene.run(o, np.ascontiguousarray(dirs, np.float32), tmax, output=1)
            dist, geom, normal = gather_hits(
                res["primID"], res["tfar"], self.face_geom, self.face_normal
            )
        else:
            dist = np.full(n, np.inf)
            geom = np.full(n, -1, np.int32)
            normal = np.zeros((n, 3))
        if self.mujoco is not None:
            idx = self._near_moving(data, origin, dirs, cutoff, cones)
            if idx.size:
                h = self.mujoco.cast(data, origin, dirs[idx], cutoff)
                closer = h.dist < dist[idx]
                k = idx[closer]
                dist[k] = h.dist[closer]
                geom[k] = h.geom[closer]
                normal[k] = h.normal[closer]
        return RayHits(dist, geom, normal)

    def _ray_buffers(self, origin, n: int, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
        """Embree's inputs for n rays from ``origin``: the origins (n, 3) float32, a
        zero-stride view of one buffer (Embree only reads it), and the far limits (n,)
        float32 (``cutoff``; Embree writes the hit distances there), reused between casts."""
        if n not in self._views:
            if len(self._views) >= 4:
                self._views.clear()
            o = as_strided(self._origin32, shape=(n, 3), strides=(0, 4), writeable=True)
            self._views[n] = (o, np.empty(n, np.float32))
        np.subtract(origin, self.center, out=self._origin32, casting="same_kind")
        o, tmax = self._views[n]
        tmax.fill(cutoff)
        return o, tmax

    def _near_moving(self, data, origin, dirs, cutoff, cones) -> np.ndarray:
        """Indices of the rays passing within a moving geom's bounding sphere (those go to
        MuJoCo). With ``cones``, only the rays of chunks whose cone can meet a sphere are
        tested ray by ray."""
        c = data.geom_xpos[self.dyn_geoms] - origin  # (G, 3)
        d = np.asarray(dirs, np.float64)
        if cones is None:
            return near_rays(d, None, c, self._dyn_rbound, float(cutoff))
        return cones.near(d, c, self._dyn_rbound, cutoff)


def make_backend(
    kind: str,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    bodyexclude: int,
    static_mesh: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> RayBackend:
    """``kind``: "mujoco", "embree" (static part in Embree, moving bodies in MuJoCo)."""
    if kind == "mujoco":
        return MujocoRays(model, bodyexclude)
    if kind == "embree":
        return EmbreeRays(model, data, bodyexclude, static_mesh)
    raise ValueError(f"backend = {kind!r}; allowed: 'mujoco', 'embree'")
