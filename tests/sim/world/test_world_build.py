"""World builder: seabed kinds, object library, labels, static mesh, cache, bad input.
Each test names its independent expectation."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.world import (
    OBJECT_KINDS,
    SEABED_KINDS,
    ObjectSpec,
    SeabedSpec,
    VehicleSpec,
    WorldSpec,
    build_world,
)
from sim.world.objects import OBJECT_CLASSES, object_mesh
from sim.world.seabed import generate_seabed


@pytest.fixture(autouse=True)
def _tmp_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("UNDERSEA_CACHE_DIR", str(tmp_path / "cache"))


def small(kind="flat", **kw):
    base = dict(kind=kind, size_xy=(40.0, 30.0), resolution=0.5, depth=20.0, seed=1)
    base.update(kw)
    return SeabedSpec(**base)


# ---------------------------------------------------------------- seabed
@pytest.mark.parametrize("kind", [k for k in SEABED_KINDS if k != "grid"])
def test_seabed_kinds_are_seeded_and_deterministic(kind):
    a = generate_seabed(small(kind))
    b = generate_seabed(small(kind))
    c = generate_seabed(small(kind, seed=2))
    assert a.z.tobytes() == b.z.tobytes()
    assert np.isfinite(a.z).all()
    assert a.z.tobytes() != c.z.tobytes()


def test_flat_seabed_mean_depth_is_spec_depth():
    sb = generate_seabed(small("flat", roughness=0.02))
    assert sb.z.mean() == pytest.approx(-20.0, abs=0.01)
    assert sb.z.std() == pytest.approx(0.02, rel=0.05)


def test_slope_gradient_matches_tan_of_slope_angle():
    """Least-squares plane fit of the grid recovers tan(slope) along the given direction."""
    sb = generate_seabed(small("slope", slope_deg=8.0, slope_direction_deg=30.0, roughness=0.0))
    X, Y = np.meshgrid(sb.x, sb.y)
    A = np.column_stack([X.ravel(), Y.ravel(), np.ones(X.size)])
    gx, gy, _ = np.linalg.lstsq(A, sb.z.ravel(), rcond=None)[0]
    th = np.deg2rad(30.0)
    np.testing.assert_allclose(
        [gx, gy], -np.tan(np.deg2rad(8.0)) * np.array([np.cos(th), np.sin(th)]), atol=1e-9
    )


def test_ripples_dominant_wavelength_from_fft():
    """Peak of the 2-D spectrum lies at the ripple wavelength (±15 %, crest wander spreads it)."""
    sb = generate_seabed(
        small(
            "ripples",
            ripple_wavelength=1.0,
            ripple_height=0.1,
            roughness=0.0,
            resolution=0.1,
            size_xy=(30.0, 30.0),
        )
    )
    z = sb.z - sb.z.mean()
    spec = np.abs(np.fft.rfft2(z)) ** 2
    ky = np.fft.fftfreq(z.shape[0], d=0.1)
    kx = np.fft.rfftfreq(z.shape[1], d=0.1)
    spec[0, 0] = 0
    iy, ix = np.unravel_index(np.argmax(spec), spec.shape)
    lam = 1.0 / np.hypot(kx[ix], ky[iy])
    assert lam == pytest.approx(1.0, rel=0.15)
    assert 0.08 <= np.ptp(z) <= 0.13  # crest-to-trough ≈ ripple_height, ±30 % slow modulation


def test_rock_field_only_adds_material_above_the_bed():
    flat = generate_seabed(small("flat"))
    rocks = generate_seabed(small("rocks", rock_density=0.05))
    bump = rocks.z - flat.z
    assert bump.min() >= -1e-12
    assert bump.max() > 0.1 and (bump > 0.01).mean() > 0.005


def test_grid_roundtrip_from_npy(tmp_path):
    rng = np.random.default_rng(0)
    depth = 25.0 + rng.uniform(0, 1, (21, 31))
    p = tmp_path / "bathy.npy"
    np.save(p, depth)
    sb = generate_seabed(SeabedSpec(kind="grid", grid_path=str(p), resolution=0.5))
    np.testing.assert_array_equal(sb.z, -depth)
    assert sb.x.size == 31 and sb.y.size == 21


def test_seabed_height_agrees_with_mj_ray_on_the_mesh():
    """Second implementation: MuJoCo's ray-triangle intersection on the seabed mesh."""
    w = build_world(WorldSpec(seabed=small("ripples", resolution=0.25)))
    rng = np.random.default_rng(3)
    xy = rng.uniform([-19, -14], [19, 14], (200, 2))
    h = w.seabed_height(xy)
    gid = np.zeros(1, np.int32)
    sid = w.model.geom("seabed").id
    for (x, y), z in zip(xy, h):
        d = mujoco.mj_ray(
            w.model, w.data, np.array([x, y, 0.0]), np.array([0, 0, -1.0]), None, 1, -1, gid
        )
        assert gid[0] == sid
        assert -d == pytest.approx(z, abs=1e-4)  # MuJoCo stores mesh vertices as float32


# ---------------------------------------------------------------- objects and labels
def _object_world(**kw):
    objs = tuple(
        ObjectSpec(
            k,
            position_xy=(-15 + 5 * i, 5.0 if i % 2 else -5.0),
            yaw_deg=20 * i,
            seed=i,
            size=(8.0, 2.5, 2.0) if k == "shipwreck" else None,
        )
        for i, k in enumerate(OBJECT_KINDS)
    )
    return build_world(WorldSpec(seabed=small("flat", seed=9), objects=objs, **kw))


def test_objects_are_labelled_with_class_and_reflectivity():
    w = _object_world(vehicles=("saga",))
    assert [o.class_name for o in w.objects] == list(OBJECT_KINDS)
    assert [o.id for o in w.objects] == list(range(1, len(OBJECT_KINDS) + 1))
    assert w.geom_object_id.shape == (w.model.ngeom,) and w.geom_object_id.dtype == np.int32
    assert w.geom_reflectivity.shape == (w.model.ngeom,)
    assert w.geom_object_id[w.model.geom("seabed").id] == 0
    for o in w.objects:
        gs = np.flatnonzero(w.geom_object_id == o.id)
        assert gs.size >= 1
        np.testing.assert_allclose(
            w.geom_reflectivity[gs], OBJECT_CLASSES[o.class_name].reflectivity
        )
    veh = np.flatnonzero(w.model.geom_bodyid == w.vehicles["saga"].body_id)
    assert (w.geom_object_id[veh] == -1).all()
    assert ((w.geom_reflectivity >= 0) & (w.geom_reflectivity <= 1)).all()


def test_objects_rest_on_the_seabed_and_rays_hit_their_label():
    """Object base at the local seabed height; a ray straight down onto the object's
    centre returns a geom labelled with the object's id (rendered label = registry)."""
    w = _object_world()
    gid = np.zeros(1, np.int32)
    for o in w.objects:
        assert o.position[2] == pytest.approx(w.seabed_height(o.position[None, :2])[0], abs=1e-9)
        x, y = o.position[:2]
        if o.class_name in ("pipe", "tyre", "tree_branch"):
            continue  # hollow / thin: the centre ray may pass through
        mujoco.mj_ray(
            w.model, w.data, np.array([x, y, 0.0]), np.array([0, 0, -1.0]), None, 1, -1, gid
        )
        assert w.geom_object_id[gid[0]] == o.id, o.class_name


def test_static_mesh_holds_seabed_and_static_objects_in_world_frame():
    w = _object_world()
    v, f, g = w.static_mesh()
    assert v.dtype == np.float64 and f.dtype == np.int32 and g.dtype == np.int32
    assert f.max() < len(v) and len(g) == len(f)
    labels = set(w.geom_object_id[np.unique(g)])
    static_ids = {o.id for o in w.objects if o.static}
    assert labels == {0} | static_ids
    mannequin = next(o for o in w.objects if o.class_name == "mannequin")
    assert not mannequin.static and mannequin.id not in labels
    # world-frame placement: MuJoCo's geom AABB of each static object contains its vertices
    for o in w.objects:
        if not o.static:
            continue
        gid = np.flatnonzero(w.geom_object_id == o.id)[0]
        vv = v[np.unique(f[g == gid])]
        c = w.data.geom_xpos[gid]
        r = w.data.geom_xmat[gid].reshape(3, 3)
        local = (vv - c) @ r
        half = w.model.geom_aabb[gid, 3:]
        ctr = w.model.geom_aabb[gid, :3]
        assert (np.abs(local - ctr) <= half + 1e-6).all(), o.class_name


def test_mannequin_is_articulated_and_stays_posed():
    w = _object_world()
    joints = [w.model.joint(i).name for i in range(w.model.njnt)]
    hinges = [j for j in joints if "mannequin" in j]
    assert len(hinges) >= 10
    q0 = w.data.qpos.copy()
    w.step(200)
    assert np.isfinite(w.data.qpos).all()
    np.testing.assert_allclose(w.data.qpos, q0, atol=0.02)


def test_object_geometry_is_cached_by_parameters(tmp_path):
    spec = ObjectSpec("rock", seed=7)
    v1, f1 = object_mesh(spec)
    files = list((tmp_path / "cache" / "meshes").glob("rock-*.npz"))
    assert len(files) == 1
    v2, f2 = object_mesh(spec)
    np.testing.assert_array_equal(v1, v2)
    np.testing.assert_array_equal(f1, f2)
    object_mesh(ObjectSpec("rock", seed=8))
    assert len(list((tmp_path / "cache" / "meshes").glob("rock-*.npz"))) == 2


# ---------------------------------------------------------------- vehicles in the world
def test_altitude_is_height_above_seabed_below():
    w = build_world(
        WorldSpec(seabed=small("ripples"), vehicles=(VehicleSpec("naiad", position=(3, 2, -15)),))
    )
    s = w.vehicles["naiad"].state()
    assert s.altitude == pytest.approx(-15 - w.seabed_height(np.array([[3.0, 2.0]]))[0], abs=1e-6)


def test_heavy_vehicle_lands_on_the_seabed_and_does_not_sink_through():
    """Contact with the collision hfield: a 10 % heavy vehicle rests on the bottom."""
    w = build_world(
        WorldSpec(
            seabed=small("flat", roughness=0.0),
            vehicles=(VehicleSpec("saga", position=(0, 0, -19.0), net_buoyancy=-0.1),),
        )
    )
    w.step(500)
    s = w.vehicles["saga"].state()
    bottom = s.position[2] + 0.06 - 0.135  # saga hull box: centre 6 cm above CG, half-height 0.135
    assert -20.02 < bottom < -19.98  # resting on the bed at z = -20 (small contact penetration)
    assert abs(s.velocity_body).max() < 0.05


def test_two_vehicles_of_the_same_kind_get_distinct_prefixes():
    w = build_world(
        WorldSpec(
            seabed=small(),
            vehicles=(
                VehicleSpec("saga", name="saga_a", position=(0, 0, -5)),
                VehicleSpec("saga", name="saga_b", position=(3, 0, -5)),
            ),
        )
    )
    assert w.model.site("saga_a/fls").id != w.model.site("saga_b/fls").id
    assert set(w.vehicles) == {"saga_a", "saga_b"}


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "make,match",
    [
        (lambda: VehicleSpec("nautilus"), r"vehicle kind must be one of .*alister9"),
        (lambda: ObjectSpec("submarine"), r"object kind must be one of .*shipwreck"),
        (lambda: ObjectSpec("rock", size=(1.0, -2.0, 1.0)), r"size must be 3 positive"),
        (lambda: SeabedSpec(size_xy=(-10.0, 10.0)), r"seabed.size_xy\[0\] must be > 0, got -10"),
        (lambda: SeabedSpec(resolution=0.0), r"seabed.resolution"),
        (lambda: SeabedSpec(kind="lava"), r"seabed.kind must be one of"),
        (lambda: WorldSpec(timestep=-0.01), r"timestep must be in"),
        (
            lambda: VehicleSpec("saga", mass=-3.0),
            r"mass must be a positive number of kg .* got -3.0",
        ),
        (lambda: WorldSpec(vehicles=("saga", "saga")), r"unique"),
    ],
)
def test_bad_specs_raise_value_error_naming_field_value_and_allowed(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_depth_grid_with_nan_is_rejected_naming_the_cell():
    g = np.full((5, 6), 30.0)
    g[2, 3] = np.nan
    with pytest.raises(
        ValueError, match=r"seabed.grid has 1 non-finite depths \(first at row 2, column 3: nan\)"
    ):
        build_world(WorldSpec(seabed=SeabedSpec(kind="grid", grid=g)))


def test_vehicle_below_seabed_or_outside_world_is_rejected():
    with pytest.raises(ValueError, match=r"below the seabed"):
        build_world(
            WorldSpec(seabed=small(), vehicles=(VehicleSpec("saga", position=(0, 0, -25)),))
        )
    with pytest.raises(ValueError, match=r"outside the seabed"):
        build_world(
            WorldSpec(seabed=small(), vehicles=(VehicleSpec("saga", position=(500, 0, -5)),))
        )
    with pytest.raises(ValueError, match=r"outside the seabed"):
        build_world(WorldSpec(seabed=small(), objects=(ObjectSpec("tyre", position_xy=(0, 99)),)))


def test_divergence_raises_instead_of_silent_nan(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo logs the bad-qacc warning to ./MUJOCO_LOG.TXT
    w = build_world(WorldSpec(seabed=small(), vehicles=(VehicleSpec("saga", position=(0, 0, -5)),)))
    w.vehicles["saga"].set_external_wrench([1e300, 0, 0, 0, 0, 0])
    with pytest.raises(FloatingPointError, match="diverged"):
        w.step(20)


def test_scatter_objects_is_seeded_spaced_and_buildable():
    from sim.world import scatter_objects

    a = scatter_objects(np.random.default_rng(5), 12, (-18, 18, -13, 13), min_spacing=4.0)
    b = scatter_objects(np.random.default_rng(5), 12, (-18, 18, -13, 13), min_spacing=4.0)
    assert a == b and len(a) == 12
    p = np.array([o.position_xy for o in a])
    dist = np.linalg.norm(p[:, None] - p[None], axis=-1) + np.eye(len(p)) * 1e9
    assert dist.min() >= 4.0
    w = build_world(WorldSpec(seabed=small(), objects=a))
    assert len(w.objects) == 12
    with pytest.raises(ValueError, match="holds only"):
        scatter_objects(np.random.default_rng(0), 100, (0, 5, 0, 5), min_spacing=3.0)


def test_water_depth_property_is_datum_depth_for_the_sonar():
    from sim.world import Water

    assert Water().depth == 0.0
    assert Water(surface_z=92.0).depth == 92.0


def test_world_bounds_are_the_seabed_extent():
    w = build_world(WorldSpec(seabed=small()))
    assert w.bounds == (-20.0, 20.0, -15.0, 15.0)


def test_mass_override_scales_mass_inertia_and_trimmed_volume():
    w = build_world(WorldSpec(seabed=small(), vehicles=(VehicleSpec("saga", mass=12.0),)))
    h = w.vehicles["saga"].hydro
    assert w.model.body_subtreemass[w.vehicles["saga"].body_id] == pytest.approx(12.0)
    np.testing.assert_allclose(h.inertia, np.array([0.1515, 0.2078, 0.2378]) * 1.2)
    assert h.volume == pytest.approx(12.0 / w.water.density)


def test_seabed_trimesh_is_a_single_upward_surface_of_the_grid_area():
    """Area of the triangulated grid = Lx·Ly / cos(slope) for a plane; normals point up."""
    sb = generate_seabed(small("slope", slope_deg=10.0, roughness=0.0))
    m = sb.to_trimesh()
    assert m.area == pytest.approx(40.0 * 30.0 / np.cos(np.deg2rad(10.0)), rel=1e-9)
    assert (m.face_normals[:, 2] > 0).all()


_weird = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -1.0, 1e-12, 1e12, float("nan"), float("inf")]),
)


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from(
        [
            "size_xy",
            "resolution",
            "depth",
            "roughness",
            "ripple_wavelength",
            "ripple_height",
            "slope_deg",
            "rock_density",
        ]
    ),
    _weird,
)
def test_seabed_spec_fields_either_validate_or_raise_value_error(field_name, value):
    """Property: any number in any field gives a valid spec or a ValueError naming it;
    NaN and infinities are never accepted."""
    kw = {field_name: (value, 10.0) if field_name == "size_xy" else value}
    try:
        SeabedSpec(**kw)
        assert np.isfinite(value), "a non-finite value was accepted silently"
    except ValueError as e:
        assert field_name.split("_xy")[0] in str(e)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(["position", "rpy_deg", "net_buoyancy", "mass"]), _weird)
def test_vehicle_spec_fields_either_validate_or_raise_value_error(field_name, value):
    kw = {field_name: (value, 0.0, -5.0) if field_name in ("position", "rpy_deg") else value}
    try:
        VehicleSpec("saga", **kw)
        assert np.isfinite(value), "a non-finite value was accepted silently"
    except ValueError as e:
        assert field_name in str(e)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(["position_xy", "yaw_deg", "size", "burial", "reflectivity"]), _weird)
def test_object_spec_fields_either_validate_or_raise_value_error(field_name, value):
    kw = {
        "position_xy": {"position_xy": (value, 0.0)},
        "yaw_deg": {"yaw_deg": value},
        "size": {"size": (1.0, value, 1.0)},
        "burial": {"burial": value},
        "reflectivity": {"reflectivity": value},
    }[field_name]
    try:
        ObjectSpec("rock", **kw)
        assert np.isfinite(value), "a non-finite value was accepted silently"
    except ValueError as e:
        assert field_name in str(e)
