"""Display meshes of the vehicles (rerun recordings, env renders)."""

from __future__ import annotations

import mujoco
import numpy as np
import trimesh


def vehicle_body_mesh(model, data, body_id: int):
    """Triangle mesh of a vehicle's geoms in its root body frame (for display):
    (vertices (V, 3) m, faces (F, 3), vertex colours (V, 3) uint8). Primitive geoms
    (sphere, capsule, ellipsoid, cylinder, box) via trimesh, mesh geoms from the model;
    None if the body has no displayable geom."""
    R0 = data.xmat[body_id].reshape(3, 3)
    p0 = data.xpos[body_id]
    vs, fs, cs = [], [], []
    off = 0
    T = mujoco.mjtGeom
    for g in range(model.ngeom):
        if model.body_rootid[model.geom_bodyid[g]] != body_id:
            continue
        t, sz = int(model.geom_type[g]), model.geom_size[g]
        if t == T.mjGEOM_SPHERE:
            m = trimesh.creation.icosphere(subdivisions=1, radius=sz[0])
        elif t == T.mjGEOM_CAPSULE:
            m = trimesh.creation.capsule(height=2 * sz[1], radius=sz[0], count=[12, 6])
        elif t == T.mjGEOM_ELLIPSOID:
            m = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
            m.vertices = m.vertices * sz[:3]
        elif t == T.mjGEOM_CYLINDER:
            m = trimesh.creation.cylinder(radius=sz[0], height=2 * sz[1], sections=16)
        elif t == T.mjGEOM_BOX:
            m = trimesh.creation.box(extents=2 * sz[:3])
        elif t == T.mjGEOM_MESH:
            mid = model.geom_dataid[g]
            va, vn = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
            fa, fn = model.mesh_faceadr[mid], model.mesh_facenum[mid]
            m = trimesh.Trimesh(
                model.mesh_vert[va : va + vn].copy(),
                model.mesh_face[fa : fa + fn].copy(),
                process=False,
            )
        else:
            continue
        Rg = data.geom_xmat[g].reshape(3, 3)
        world = np.asarray(m.vertices) @ Rg.T + data.geom_xpos[g]
        vs.append((world - p0) @ R0)
        fs.append(np.asarray(m.faces) + off)
        cs.append(np.tile((model.geom_rgba[g, :3] * 255).astype(np.uint8), (len(m.vertices), 1)))
        off += len(m.vertices)
    if not vs:
        return None
    return np.concatenate(vs), np.concatenate(fs), np.concatenate(cs)


def box_mesh(L: float, W: float, H: float) -> tuple[np.ndarray, np.ndarray]:
    v = np.array(
        [[x, y, z] for x in (-L / 2, L / 2) for y in (-W / 2, W / 2) for z in (-H / 2, H / 2)]
    )
    f = np.array(
        [
            [0, 1, 3],
            [0, 3, 2],
            [4, 6, 7],
            [4, 7, 5],
            [0, 4, 5],
            [0, 5, 1],
            [2, 3, 7],
            [2, 7, 6],
            [0, 2, 6],
            [0, 6, 4],
            [1, 5, 7],
            [1, 7, 3],
        ]
    )
    return v, f
