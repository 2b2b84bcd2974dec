"""Ray backends: Embree (static) + MuJoCo (moving) against pure MuJoCo mj_multiRay."""

from __future__ import annotations

import mujoco
import numpy as np

from sim.sonar.rays import EmbreeRays, MujocoRays, ray_cones, static_mesh_from_model
from sim.sonar.scenes import SceneObject, build_scene


def _rays(origin, targets, spread, n, seed):
    rng = np.random.default_rng(seed)
    d = np.repeat(targets - origin, n // len(targets), axis=0) + rng.normal(size=(n, 3)) * spread
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_embree_and_mujoco_same_hits_to_1mm():
    """Second implementation: on a rolling mesh seabed with a static box and moving (free
    joint) sphere and box, both backends return the same geom and distance within 1 mm for
    every ray, after the moving bodies moved."""
    objs = [
        SceneObject("box", (3.0, 12.0, 1.0), (1.0, 1.5, 1.0), euler_deg=(0, 0, 30)),
        SceneObject("sphere", (-4.0, -9.0, 1.0), (0.8,), moving=True),
        SceneObject("box", (6.0, -14.0, 0.6), (0.5, 0.5, 0.5), moving=True),
    ]
    sc = build_scene(altitude=10.0, objects=objs, seabed_cells=60, relief=1.0)
    m, d = sc.model, sc.data
    emb = EmbreeRays(m, d, sc.vehicle_body)
    muj = MujocoRays(m, sc.vehicle_body)
    # move the free bodies after the Embree scene was built
    d.qpos[sc.qpos_adr("obj2") + np.arange(3)] += [0.5, -0.3, 0.2]
    d.qpos[sc.qpos_adr("obj3") + np.arange(3)] += [-0.4, 0.6, 0.1]
    mujoco.mj_kinematics(m, d)
    o = d.site_xpos[sc.sites["sss"]].copy()
    targets = np.array(
        [[3.0, 12.0, 1.0], [-3.5, -9.3, 1.2], [5.6, -13.4, 0.7], [0, 30, 0], [0, -30, 0]]
    )
    dirs = _rays(o, targets, 0.15, 20000, 0)
    a = emb.cast(d, o, dirs, 100.0)
    b = muj.cast(d, o, dirs, 100.0)
    assert {1, 2, 3} <= set(np.unique(b.geom))
    np.testing.assert_array_equal(a.geom, b.geom)
    hit = np.isfinite(b.dist)
    assert np.all(np.isfinite(a.dist) == hit)
    assert np.max(np.abs(a.dist[hit] - b.dist[hit])) < 1e-3
    dot = np.abs(np.sum(a.normal[hit] * b.normal[hit], axis=1))
    assert np.min(dot) > 1 - 1e-4


def test_tessellated_static_primitives_within_tolerance():
    """Static curved primitives are tessellated (chord ≤ 0.5 mm): away from silhouettes the
    hits agree with MuJoCo's analytic ones within 1 mm for ≥ 99 % of rays."""
    objs = [
        SceneObject("sphere", (0.0, 12.0, 1.0), (1.0,)),
        SceneObject("cylinder", (4.0, -12.0, 1.0), (0.5, 1.0), euler_deg=(90, 0, 0)),
    ]
    sc = build_scene(altitude=10.0, objects=objs, seabed_cells=20)
    m, d = sc.model, sc.data
    _, _, G = static_mesh_from_model(m, d)
    assert set(np.unique(G)) == {0, 1, 2}
    o = d.site_xpos[sc.sites["sss"]].copy()
    dirs = _rays(o, np.array([[0.0, 12.0, 1.0], [4.0, -12.0, 1.0]]), 0.3, 10000, 1)
    a = EmbreeRays(m, d, sc.vehicle_body).cast(d, o, dirs, 100.0)
    b = MujocoRays(m, sc.vehicle_body).cast(d, o, dirs, 100.0)
    obj = (b.geom >= 1) & (a.geom == b.geom)
    assert np.mean(a.geom == b.geom) > 0.99
    assert np.mean(np.abs(a.dist[obj] - b.dist[obj]) < 1e-3) > 0.99


def _near_brute(dirs, centres, radii, cutoff):
    """Rays passing within each sphere's radius before the cutoff, ray by ray (the
    definition: closest approach t along the ray, distance² |c|² − t²)."""
    out = []
    for i, d in enumerate(dirs):
        for c, r in zip(centres, radii):
            t = float(d @ c)
            if float(c @ c) - t * t <= r * r and t >= -r and t - r <= cutoff:
                out.append(i)
                break
    return np.array(out, np.int64)


def test_ray_cones_keep_every_ray_near_a_sphere():
    """The chunk cones only prune: on ordered fans (consecutive rays close in angle, as
    the sonars cast them) and on shuffled rays, every ray that passes within a sphere
    (brute force, ray by ray) is among the candidates, for spheres ahead, beside, behind
    and out of reach; a sphere around the origin asks for every ray."""
    rng = np.random.default_rng(3)
    th = np.linspace(-1.2, 1.2, 700)
    ps = np.linspace(-0.05, 0.05, 3)
    T, P = np.meshgrid(th, ps)
    fan = np.stack([np.sin(P), np.cos(P) * np.cos(T), -np.cos(P) * np.sin(T)], -1).reshape(-1, 3)
    shuffled = rng.normal(size=(1500, 3))
    shuffled /= np.linalg.norm(shuffled, axis=1, keepdims=True)
    for dirs in (fan, shuffled):
        cones = ray_cones(dirs, chunk=64)
        for _ in range(40):
            centres = rng.normal(size=(3, 3)) * rng.uniform(2.0, 40.0)
            radii = rng.uniform(0.2, 2.0, 3)
            want = _near_brute(dirs, centres, radii, 30.0)
            cand = cones.candidates(centres, radii, 30.0)
            got = np.arange(len(dirs)) if cand is None else cand
            assert np.all(np.isin(want, got))
            assert np.all(got < len(dirs))
        assert cones.candidates(np.zeros((1, 3)), np.array([1.0]), 30.0) is None
    # a sphere beside a narrow fan is pruned entirely; one out of reach as well
    cones = ray_cones(fan[:700])  # ψ = −0.05 row: the plane x = −0.05 y-z
    assert cones.candidates(np.array([[20.0, 0.0, 0.0]]), np.array([1.0]), 100.0).size == 0
    assert cones.candidates(np.array([[0.0, 80.0, 0.0]]), np.array([1.0]), 30.0).size == 0


def test_cast_with_cones_equals_cast_without():
    """Embree backend with the moving-body test restricted by cones returns the same bytes
    as the full ray-by-ray test, with a moving box inside the fan."""
    objs = [SceneObject("box", (0.0, 8.0, 0.6), (0.6, 0.6, 0.6), moving=True)]
    sc = build_scene(altitude=6.0, objects=objs, seabed_cells=40, relief=0.5)
    m, d = sc.model, sc.data
    emb = EmbreeRays(m, d, sc.vehicle_body)
    o = d.site_xpos[sc.sites["sss"]].copy()
    th = np.linspace(0.05, 1.5, 3000)
    dirs = np.stack([0.02 * np.sin(40 * th), np.cos(th), -np.sin(th)], -1)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    a = emb.cast(d, o, dirs, 40.0)
    b = emb.cast(d, o, dirs, 40.0, ray_cones(dirs))
    assert np.any(np.isin(a.geom, emb.dyn_geoms))  # the moving box is hit
    for x, y in ((a.dist, b.dist), (a.geom, b.geom), (a.normal, b.normal)):
        assert x.tobytes() == y.tobytes()


def test_embree_cast_equals_bare_embreex_with_array_post_processing():
    """Second implementation: the backend's compiled hit gather and reused Embree buffers
    give the same bytes as bare ``EmbreeScene.run`` on fresh (N, 3) float32 origins with
    the array post-processing (float64 distances, inf and geom −1 for misses, the face's
    float64 normal; geom ids int32 as RayHits documents), over consecutive casts of different sizes; with a moving box in
    the fan the MuJoCo hits replace exactly the rays that the ray-by-ray sphere test
    sends there."""
    objs = [SceneObject("box", (0.0, 8.0, 0.6), (0.6, 0.6, 0.6), moving=True)]
    sc = build_scene(altitude=6.0, objects=objs, seabed_cells=40, relief=0.5)
    m, d = sc.model, sc.data
    emb = EmbreeRays(m, d, sc.vehicle_body)
    o = d.site_xpos[sc.sites["sss"]].copy()
    for n in (3000, 1200, 3000):
        th = np.linspace(0.05, 1.5, n)
        dirs = np.stack([0.02 * np.sin(40 * th), np.cos(th), -np.sin(th)], -1)
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        got = emb.cast(d, o, dirs, 40.0, ray_cones(dirs))
        o32 = np.empty((n, 3), np.float32)
        o32[:] = (o - emb.center).astype(np.float32)
        res = emb.scene.run(o32, dirs.astype(np.float32), np.full(n, 40.0, np.float32), output=1)
        prim = res["primID"]
        dist = res["tfar"].astype(np.float64)
        dist[prim < 0] = np.inf
        geom = emb.face_geom[prim].astype(np.int32)  # RayHits.geom: int32
        normal = emb.face_normal[prim]
        c = d.geom_xpos[emb.dyn_geoms] - o
        rb = m.geom_rbound[emb.dyn_geoms]
        t = dirs @ c.T
        d2 = np.sum(c * c, axis=1)[None, :] - t * t
        near = np.flatnonzero(((d2 <= rb * rb) & (t >= -rb) & (t - rb <= 40.0)).any(axis=1))
        assert near.size > 0
        h = emb.mujoco.cast(d, o, dirs[near], 40.0)
        closer = h.dist < dist[near]
        k = near[closer]
        dist[k], geom[k], normal[k] = h.dist[closer], h.geom[closer], h.normal[closer]
        for x, y in ((got.dist, dist), (got.geom, geom), (got.normal, normal)):
            assert x.tobytes() == y.tobytes()
