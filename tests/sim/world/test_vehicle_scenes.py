"""Every vehicle: the stand-alone scene compiles; in a world it steps 10 s under random
thrust with no MuJoCo warning and no NaN; mass and bounding dimensions match
REFERENCE.md (thesis Table 6.5) within 1 %; sensor sites sit on or outside the hull."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from sim.world import SeabedSpec, VehicleSpec, WorldSpec, build_world
from sim.world.vehicles import ASSETS, SENSOR_SITES

# REFERENCE.md, Table 6.5 (RexROV: UUV Simulator's rexrov_description)
REFERENCE = {
    "alister9": ((2.0, 0.22, 0.22), 70.0),
    "ixn": ((1.9, 0.5, 0.3), 150.0),
    "naiad": ((0.84, 0.6, 0.25), 30.0),
    "saga": ((0.42, 0.33, 0.27), 10.0),
    "rexrov": ((2.6, 1.5, 1.6), 1862.87),
}
SMALL = SeabedSpec(kind="ripples", size_xy=(60.0, 60.0), resolution=0.5, depth=30.0, seed=4)


@pytest.mark.parametrize("kind", list(REFERENCE))
def test_scene_xml_compiles_and_steps(kind):
    m = mujoco.MjModel.from_xml_path(str(ASSETS / kind / "scene.xml"))
    d = mujoco.MjData(m)
    assert m.opt.density == 0 and m.opt.viscosity == 0 and m.opt.gravity[2] < 0
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_step(m, d, nstep=50)
    assert np.isfinite(d.qpos).all()


@pytest.mark.parametrize("kind", list(REFERENCE))
def test_vehicle_steps_10s_random_thrust_without_warning_or_nan(kind, rng):
    w = build_world(WorldSpec(seabed=SMALL, vehicles=(VehicleSpec(kind, position=(0, 0, -12)),)))
    v = w.vehicles[kind]
    for _ in range(20):  # new random command every 0.5 s
        v.set_thruster_commands(rng.uniform(-1, 1, v.n_thrusters))
        w.step(50)
        s = v.state()
        assert np.isfinite(s.position).all() and np.isfinite(s.velocity_body).all()
    assert w.time == pytest.approx(10.0)
    assert all(w.data.warning[i].number == 0 for i in range(len(w.data.warning)))


def _vehicle_bbox(model: mujoco.MjModel, body_id: int) -> np.ndarray:
    """Extent of all geoms of the body, in the body frame, from MuJoCo's geom AABBs."""
    lo = np.full(3, np.inf)
    hi = -lo
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    for g in np.flatnonzero(model.geom_bodyid == body_id):
        c, h = model.geom_aabb[g, :3], model.geom_aabb[g, 3:]
        r = np.empty(9)
        mujoco.mju_quat2Mat(r, model.geom_quat[g])
        p = (c + corners * h) @ r.reshape(3, 3).T + model.geom_pos[g]
        lo = np.minimum(lo, p.min(0))
        hi = np.maximum(hi, p.max(0))
    return hi - lo


@pytest.mark.parametrize("kind", list(REFERENCE))
def test_mass_and_bounding_dimensions_match_reference_within_1_percent(kind):
    dims, mass = REFERENCE[kind]
    w = build_world(WorldSpec(seabed=SMALL, vehicles=(kind,)))
    v = w.vehicles[kind]
    assert w.model.body_subtreemass[v.body_id] == pytest.approx(mass, rel=0.01)
    np.testing.assert_allclose(_vehicle_bbox(w.model, v.body_id), dims, rtol=0.01)


@pytest.mark.parametrize("kind", list(REFERENCE))
def test_sensor_sites_exist_and_rays_from_them_miss_the_own_hull(kind):
    """A ray leaving each sensor site in its looking direction hits nothing of its own
    vehicle (the sonar casts from these sites)."""
    w = build_world(WorldSpec(seabed=SMALL, vehicles=(VehicleSpec(kind, position=(0, 0, -10)),)))
    v = w.vehicles[kind]
    assert set(v.site_ids) == set(SENSOR_SITES)
    m, d = w.model, w.data
    rot = d.xmat[v.body_id].reshape(3, 3)
    looks = {
        "sss_port": [(0, 1, -0.3), (0, 1, -1), (0, 1, 0)],
        "sss_starboard": [(0, -1, -0.3), (0, -1, -1), (0, -1, 0)],
        "fls": [(1, 0, -0.2), (1, 0.7, 0), (1, -0.7, 0)],
        "msis": [(np.cos(a), np.sin(a), 0) for a in np.linspace(0, 2 * np.pi, 12, endpoint=False)],
        "dvl": [(0, 0, -1), (0.5, 0, -1), (0, 0.5, -1)],
        "pressure": [(0, 0, 1)],
    }
    gid = np.zeros(1, np.int32)
    own = set(np.flatnonzero(m.geom_bodyid == v.body_id))
    for site, dirs in looks.items():
        p = d.site_xpos[v.site_ids[site]].copy()
        for dvec in dirs:
            dw = rot @ (np.asarray(dvec, float) / np.linalg.norm(dvec))
            mujoco.mj_ray(m, d, p, dw, None, 1, -1, gid)
            assert gid[0] not in own, f"{kind}/{site} ray {dvec} hits its own hull"
    # sites carry the body orientation
    for sid in v.site_ids.values():
        np.testing.assert_allclose(d.site_xmat[sid].reshape(3, 3), rot, atol=1e-12)


@pytest.mark.parametrize("kind", list(REFERENCE))
def test_standalone_motors_push_like_the_thruster_model(kind):
    """The viewer-only motors of the stand-alone scene and sim.thrusters use the same site
    axes: 1 N on motor i gives MuJoCo's generalized force = configuration column i."""
    m = mujoco.MjModel.from_xml_path(str(ASSETS / kind / "scene.xml"))
    d = mujoco.MjData(m)
    w = build_world(WorldSpec(seabed=SMALL, vehicles=(kind,)))
    names = w.vehicles[kind].thruster_names
    for i in range(m.nu):
        d.ctrl[:] = 0.0
        d.ctrl[i] = 1.0
        mujoco.mj_forward(m, d)  # home keyframe not applied: identity attitude, body = world axes
        col = w.thrusters.columns[names.index(m.actuator(i).name)]
        np.testing.assert_allclose(d.qfrc_actuator[:6], col, atol=1e-12)
    assert w.model.nu == 0  # sim.world strips them
