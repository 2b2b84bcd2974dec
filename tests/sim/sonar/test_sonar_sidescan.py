"""Side-scan sonar: geometry, shadows, intensity law, speckle, labels, determinism, errors."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy import stats

from sim.sonar import (
    SideScanSonar,
    SideScanWaterfall,
    mosaic,
    preset,
    sample_ground_positions,
    slant_to_ground,
)
from sim.sonar.acoustics import absorption_db_per_m
from sim.sonar.effects import all_off
from sim.sonar.scenes import SceneObject, build_scene

QUIET = dict(
    speckle="none", noise_level_db=-100.0, tvg="none", log_compression=False, specular_db=None
)


def _sonar(scene, backend="embree", site="sss", **over):
    return scene.sidescan(preset("deepeye680d", **over), site, backend=backend)


# every realism effect switched off must leave the analytic checks below intact
REALISM_OFF = pytest.mark.parametrize("realism", [None, all_off()], ids=["plain", "realism_off"])


def _altitude(scene, site="sss"):
    return float(scene.data.site_xpos[scene.sites[site], 2])


@pytest.mark.parametrize("backend", ["embree", "mujoco"])
def test_flat_seabed_first_return_at_altitude_both_sides(flat_scene, backend):
    """Analytic: over a flat seabed the first bottom return is at slant range h (±1 bin)."""
    son = _sonar(flat_scene, backend)
    ping = son.ping(flat_scene.data, np.random.default_rng(0))
    h = _altitude(flat_scene)
    bw = son.bin_width
    expected = int(np.floor(h / bw))
    for side in ("port", "starboard"):
        S = ping.samples_per_side
        lab = ping.labels[:S][::-1] if side == "port" else ping.labels[S:]
        first = int(np.flatnonzero(lab == 0)[0])
        assert abs(first - expected) <= 1, (side, first, expected)
        # intensity: water column dark, bottom bright
        inten = ping.side(side)
        assert inten[: expected - 2].max() < 0.2
        assert np.median(inten[expected + 5 : expected + 200]) > 0.3
    assert ping.altitude == pytest.approx(h, abs=1e-3)


def test_flat_seabed_ground_range_matches_hits(flat_scene):
    """Analytic: the hit point of sample i lies at horizontal distance sqrt(r_i² − h²)."""
    son = _sonar(flat_scene)
    ping = son.ping(flat_scene.data, np.random.default_rng(0))
    h = _altitude(flat_scene)
    p0 = ping.sensor_position[0]
    ok = ping.labels == 0
    r = ping.slant_range[ok]
    g_true = np.linalg.norm(ping.hit_position[ok, :2] - p0[:2], axis=1)
    far = r > h + 1.0  # near nadir one bin spans a wide ground interval
    g_formula = np.sqrt(np.maximum(r**2 - h**2, 0.0))
    assert np.max(np.abs(g_true - g_formula)[far]) < 2 * son.bin_width
    # sample_ground_positions (flat-seabed georeferencing) agrees with the ray-cast truth
    wf = SideScanWaterfall.from_pings([ping])
    xy = sample_ground_positions(wf)[0]
    err = np.linalg.norm(xy[ok] - ping.hit_position[ok, :2], axis=1)
    assert np.max(err[far]) < 2 * son.bin_width


@REALISM_OFF
def test_box_shadow_length_similar_triangles(box_scene, realism):
    """Similar triangles: a box of height H whose top far edge is at ground range g under a
    sensor at altitude h shadows the seabed from g to g·h/(h − H): length g·H/(h − H)."""
    son = _sonar(box_scene, acoustic=dict(realism=realism))
    ping = son.ping(box_scene.data, np.random.default_rng(0))
    h = _altitude(box_scene)
    H, g2 = 2.0, 15.0
    S = ping.samples_per_side
    lab = ping.labels[:S][::-1]  # port, near → far
    r = ping.slant_range[S:]
    obj = np.flatnonzero(lab == 1)
    assert obj.size > 0
    after = np.arange(obj[-1] + 1, S)
    resume = after[lab[after] == 0][0]
    assert np.all(lab[obj[-1] + 1 : resume] == -1)  # the shadow holds no return
    g_end = np.sqrt(r[resume] ** 2 - h**2)
    shadow = g_end - g2
    predicted = g2 * H / (h - H)
    assert abs(shadow - predicted) / predicted < 0.05, (shadow, predicted)
    inten = ping.side("port")
    assert inten[obj].max() > np.median(inten[resume : resume + 100])  # ascending face bright


@REALISM_OFF
def test_mean_intensity_follows_spreading_absorption_backscatter_law(flat_scene, realism):
    """Closed form for a flat seabed (rect beams, Lambert): per range bin δr at slant r,
    ground range x, I = SL·μ·(h/r)²·(β r · r δr / x)·r⁻⁴·10^(−2αr/10); simulated within 1 dB."""
    over = dict(
        acoustic=dict(QUIET, realism=realism),
        beam_pattern="rect",
        vertical_beamwidth_deg=179.0,
        depression_deg=45.0,
        along_track_beamwidth_deg=1.0,
        max_range=80.0,
        samples_per_side=800,
    )
    son = _sonar(flat_scene, **over)
    ping = son.ping(flat_scene.data, np.random.default_rng(0))
    cfg = son.config
    h = _altitude(flat_scene)
    r = son.ranges
    x = np.sqrt(np.maximum(r**2 - h**2, 1e-9))
    alpha = absorption_db_per_m(cfg.frequency_hz, flat_scene.water, flat_scene.water.depth - h)
    sl = 10 ** (cfg.acoustic.source_level_db / 10)
    mu = 10 ** (cfg.acoustic.lambert_mu_db / 10)
    beta = np.deg2rad(cfg.along_track_beamwidth_deg)
    expected = (
        sl
        * mu
        * (h / r) ** 2
        * (beta * r * r * son.bin_width / x)
        * r**-4
        * 10 ** (-0.2 * alpha * r)
    )
    sel = (r > 1.5 * h) & (r < cfg.max_range - 1.0)
    for side in ("port", "starboard"):
        sim = ping.side(side).astype(float)
        err_db = 10 * np.log10(sim[sel] / expected[sel])
        assert np.max(np.abs(err_db)) < 1.0, (side, err_db.min(), err_db.max())
    # absorption matters over this span (guards against a law that ignores it)
    assert 20 * alpha * 60.0 / 10 > 1.0


def _patch_amplitudes(scene, speckle, n_pings=60, realism=None):
    cfg_ac = dict(QUIET, speckle=speckle, k_shape=1.0, realism=realism)
    son = _sonar(scene, acoustic=cfg_ac)
    rng = np.random.default_rng(7)
    inten = np.stack([son.ping(scene.data, rng).side("starboard") for _ in range(n_pings)])
    patch = inten[:, 400:480].astype(float)  # uniform patch: same range cells, many pings
    return np.sqrt(patch / patch.mean(axis=0, keepdims=True)).ravel()


@REALISM_OFF
def test_speckle_amplitude_is_rayleigh(flat_scene, realism):
    """Goodness of fit (KS, scipy.stats): amplitude normalised by its local RMS is Rayleigh
    with σ = 1/√2; the K-distributed option (shape 1) is clearly rejected by the same test."""
    a = _patch_amplitudes(flat_scene, "rayleigh", realism=realism)
    p = stats.kstest(a, stats.rayleigh(scale=1 / np.sqrt(2)).cdf).pvalue
    assert p > 0.01
    k = _patch_amplitudes(flat_scene, "k")
    assert stats.kstest(k, stats.rayleigh(scale=1 / np.sqrt(2)).cdf).pvalue < 1e-4


def test_seeded_runs_are_bit_identical(box_scene):
    """Determinism: same seed → same bytes; another seed → different speckle."""
    son = _sonar(box_scene, acoustic=dict(speckle="k"))
    a = son.ping(box_scene.data, np.random.default_rng(3))
    b = _sonar(box_scene, acoustic=dict(speckle="k")).ping(box_scene.data, np.random.default_rng(3))
    c = son.ping(box_scene.data, np.random.default_rng(4))
    assert a.intensity.tobytes() == b.intensity.tobytes()
    assert a.labels.tobytes() == b.labels.tobytes()
    assert a.intensity.tobytes() != c.intensity.tobytes()


def test_one_rotation_of_the_stacked_fan_equals_separate_products(box_scene):
    """Second formulation: the ping rotates its fan, probe and derivatives with one product
    of the stacked local array; the world directions and derivatives are the same bytes
    as ``fan.directions @ R.T`` and ``fan.d_directions @ R.T`` taken apart, for the
    first ping (fan built after the probe) and a cached-fan ping."""
    son = _sonar(box_scene)
    d = box_scene.data
    p, R = son.mount.pose(d, son.mount.site_ids[0])
    for _ in range(2):
        _, fan, dirs, d_dirs, _ = son._cast_ping(d, p, R)
        assert dirs.tobytes() == (fan.directions @ R.T).tobytes()
        assert d_dirs.tobytes() == (fan.d_directions @ R.T).tobytes()


def test_label_centroid_maps_back_to_object_position():
    """Ground truth: the labelled samples of a small sphere, over a survey line, have hit
    positions whose centroid lies within (radius + one bin + ping spacing) of its centre."""
    centre = np.array([0.0, -12.0, 0.25])
    radius = 0.25
    scene = build_scene(
        altitude=8.0, objects=[SceneObject("sphere", tuple(centre), (radius,))], seabed_cells=20
    )
    son = _sonar(scene)
    rng = np.random.default_rng(0)
    pings = []
    xs = np.arange(-1.0, 1.0, 0.05)
    for x in xs:
        scene.move_vehicle(x)
        pings.append(son.ping(scene.data, rng))
    wf = SideScanWaterfall.from_pings(pings)
    lab = wf.labels == 1
    assert lab.sum() > 10
    assert np.all(np.isfinite(wf.hit_position[lab]))
    pts = wf.hit_position[lab]
    assert np.all(np.linalg.norm(pts - centre, axis=1) < radius + son.bin_width)
    c = pts[:, :2].mean(axis=0)
    assert np.linalg.norm(c - centre[:2]) < radius + son.bin_width + 0.05
    # port/starboard: a sphere at negative y is on the starboard (right) half
    assert np.all(np.flatnonzero(lab.any(axis=0)) >= wf.samples_per_side)


def test_ground_range_image_and_mosaic(box_scene):
    """Slant-range correction removes the water column; the mosaic is north-up: the box
    (north of the track, y = 14 m) shows in the upper half at the right row."""
    son = _sonar(box_scene)
    rng = np.random.default_rng(0)
    pings = []
    for x in np.arange(-3.0, 3.0, 0.2):
        box_scene.move_vehicle(x)
        pings.append(son.ping(box_scene.data, rng))
    box_scene.move_vehicle(0.0)
    wf = SideScanWaterfall.from_pings(pings)
    gr = slant_to_ground(wf)
    G = gr.image.shape[1] // 2
    assert np.median(gr.image[:, G : G + 10]) > 0.2  # seabed right at zero ground range
    mo = mosaic(wf, resolution=0.25)
    h = _altitude(box_scene)
    # shadow behind the box: cells at y in (15.5, 15 h/(h−2) − 0.5) near x = 0 are dark
    ys = np.arange(15.5, 15 * h / (h - 2) - 0.5, 0.25)
    i = np.floor((mo.y_max - ys) / mo.resolution).astype(int)
    j = int(np.floor((0.0 - mo.x_min) / mo.resolution))
    assert np.all(mo.image[i, j] < 0.1)
    ii = np.floor((mo.y_max - np.array([20.0, -20.0])) / mo.resolution).astype(int)
    assert np.all(mo.image[ii, j] > 0.2)


def test_embree_and_mujoco_pings_agree(box_scene):
    """Second implementation: both ray backends give the same labels and intensities."""
    a = _sonar(box_scene, "embree").ping(box_scene.data, np.random.default_rng(1))
    b = _sonar(box_scene, "mujoco").ping(box_scene.data, np.random.default_rng(1))
    assert np.mean(a.labels == b.labels) > 0.999
    both = (a.labels >= 0) & (b.labels >= 0)
    np.testing.assert_allclose(a.intensity[both], b.intensity[both], atol=0.02)


def test_two_site_sss_matches_single_site_geometry(flat_scene):
    """Port/starboard on separate sites: first return still at each transducer's altitude."""
    cfg = preset("deepeye680d")
    sc = flat_scene
    son = SideScanSonar(
        cfg,
        sc.model,
        sc.data,
        (sc.sites["sss_port"], sc.sites["sss_starboard"]),
        sc.geom_object_id,
        sc.geom_reflectivity,
        sc.water,
    )
    ping = son.ping(sc.data, np.random.default_rng(0))
    h = float(sc.data.site_xpos[sc.sites["sss_port"], 2])
    S = ping.samples_per_side
    for lab in (ping.labels[:S][::-1], ping.labels[S:]):
        assert abs(int(np.flatnonzero(lab == 0)[0]) - int(h / son.bin_width)) <= 1
    np.testing.assert_allclose(ping.sensor_position[:, 1], [0.2, -0.2])


# --- bad input ------------------------------------------------------------------------

WORLD_SITE_XML = """<mujoco><worldbody><site name="s" pos="0 0 5"/>
<geom type="plane" size="10 10 1"/>
<body name="v" pos="0 0 5"><freejoint/><geom type="box" size="1 .2 .2"/>
<site name="far" pos="0 3 0"/><site name="ok" pos="0 0.2 0"/></body></worldbody></mujoco>"""


def _world_site_scene():
    m = mujoco.MjModel.from_xml_string(WORLD_SITE_XML)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    return m, d, np.array([0, -1], np.int32), np.ones(2)


@pytest.mark.parametrize(("site", "match"), [("s", "world body"), ("far", "outside its vehicle")])
def test_bad_mount_raises(site, match):
    from sim.sonar import Water

    m, d, oid, refl = _world_site_scene()
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
    with pytest.raises(ValueError, match=match):
        SideScanSonar(preset("deepeye680d"), m, d, sid, oid, refl, Water())


def test_good_mount_accepted_and_bad_site_index():
    from sim.sonar import Water

    m, d, oid, refl = _world_site_scene()
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "ok")
    SideScanSonar(preset("deepeye680d"), m, d, sid, oid, refl, Water(), backend="mujoco")
    with pytest.raises(ValueError, match="site_id"):
        SideScanSonar(preset("deepeye680d"), m, d, 99, oid, refl, Water())


@pytest.mark.parametrize(
    ("over", "field"),
    [
        (dict(max_range=0.0), "max_range"),
        (dict(max_range=-5.0), "max_range"),
        (dict(samples_per_side=10000), "samples_per_side"),
        (dict(frequency_hz=2e6), "frequency_hz"),
        (dict(vertical_beamwidth_deg=0.0), "vertical_beamwidth_deg"),
        (dict(bogus=1), "bogus"),
    ],
)
def test_bad_config_raises_naming_field(over, field):
    with pytest.raises(ValueError, match=field):
        preset("deepeye680d", **over)


def test_unknown_preset_lists_allowed():
    with pytest.raises(ValueError, match="deepeye340d"):
        preset("edgetech")


def test_absorption_validity_checked_at_construction(flat_scene):
    """340 kHz with 35.07 PSU (the thesis's fjord) is outside F–G's 30–35 PSU below 500 kHz;
    Ainslie–McColm accepts it."""
    from sim.sonar import Water

    sc = flat_scene
    w = Water(salinity_psu=35.07)
    with pytest.raises(ValueError, match="salinity_psu"):
        SideScanSonar(
            preset("deepeye340d"),
            sc.model,
            sc.data,
            sc.sites["sss"],
            sc.geom_object_id,
            sc.geom_reflectivity,
            w,
        )
    SideScanSonar(
        preset("deepeye340d", acoustic=dict(absorption_model="ainslie_mccolm")),
        sc.model,
        sc.data,
        sc.sites["sss"],
        sc.geom_object_id,
        sc.geom_reflectivity,
        w,
    )


def test_every_sample_whose_ray_hit_object_k_carries_k():
    """Ground truth at ray level: cast the ping's own rays, and every range cell holding the
    hit of a ray on object k (k = 1, 2) is labelled k; cells holding only seabed hits are 0."""
    from sim.sonar.echo import form_echo

    objs = [
        SceneObject("box", (0.0, 12.0, 0.8), (1.0, 1.0, 0.8)),
        SceneObject("sphere", (0.0, -15.0, 0.6), (0.6,)),
    ]
    sc = build_scene(altitude=9.0, objects=objs, seabed_cells=20)
    son = _sonar(sc)
    son.ping(sc.data, np.random.default_rng(0))
    ping = son.ping(sc.data, np.random.default_rng(0))
    fan = son.ray_fan(ping.altitude)
    d_loc, dd_loc, gain, rows = fan.directions, fan.d_directions, fan.gain, fan.rows
    p, R = son.mount.pose(sc.data, sc.sites["sss"])
    dirs, dd = d_loc @ R.T, dd_loc @ R.T
    m = son.mount
    hits = m.backend.cast(sc.data, p, dirs, m.cutoff)
    echo = form_echo(
        hits,
        p,
        dirs,
        dd,
        gain,
        rows,
        2,
        son.config.samples_per_side,
        0.0,
        son.bin_width,
        m.geom_object_id,
        m.geom_reflectivity,
        m.alpha_db_m,
        m.specular,
        1.0,
        fan.neighbours,
    )
    ray_id = np.where(hits.geom >= 0, sc.geom_object_id[np.maximum(hits.geom, 0)], -1)
    cell = np.floor(hits.dist / son.bin_width)
    for k in (1, 2):
        sel = (ray_id == k) & (cell < son.config.samples_per_side)
        assert sel.sum() > 5
        assert np.all(echo.labels[rows[sel], cell[sel].astype(int)] == k)
    sb = (ray_id == 0) & (cell < son.config.samples_per_side)
    lab_sb = echo.labels[rows[sb], cell[sb].astype(int)]
    assert np.all((lab_sb == 0) | (lab_sb >= 1))  # seabed unless an object shares the cell
    assert np.mean(lab_sb == 0) > 0.9  # objects win only in the few cells they share


def test_altitude_is_vertical_when_vehicle_rolls():
    """Geometry: with 10° roll over a flat seabed the reported altitude is still the vertical
    distance to the seabed; the lowered side's first return is at h, the raised side's at
    h / cos(10°) (its fan ends 10° short of the vertical)."""
    from sim.frames import wxyz_from_euler

    sc = build_scene(altitude=10.0, seabed_cells=20)
    a = sc.qpos_adr(sc.vehicle_body)
    sc.data.qpos[a + 3 : a + 7] = wxyz_from_euler(np.deg2rad(10.0), 0.0, 0.0)
    mujoco.mj_kinematics(sc.model, sc.data)
    son = _sonar(sc)
    ping = son.ping(sc.data, np.random.default_rng(0))
    h = float(sc.data.site_xpos[sc.sites["sss"], 2])
    assert ping.altitude == pytest.approx(h, abs=0.02)
    S = ping.samples_per_side
    first_port = int(np.flatnonzero(ping.labels[:S][::-1] == 0)[0])
    first_stbd = int(np.flatnonzero(ping.labels[S:] == 0)[0])
    bw = son.bin_width
    # positive roll (about x) lowers the starboard side (−y) → starboard reaches the nadir
    assert abs(first_stbd - int(h / bw)) <= 1
    assert abs(first_port - int(h / np.cos(np.deg2rad(10.0)) / bw)) <= 2


def test_presets_overridable_including_acoustic_fields():
    """All fields overridable: geometry, ping rate and acoustic levels, directly or via
    ``acoustic=dict(...)``; overrides are validated again."""
    c = preset(
        "deepeye340d",
        frequency_hz=3.0e5,
        max_range=60.0,
        samples_per_side=800,
        along_track_beamwidth_deg=0.5,
        ping_rate_hz=5.0,
        source_level_db=205.0,
        acoustic=dict(noise_level_db=35.0),
    )
    assert (c.frequency_hz, c.max_range, c.samples_per_side, c.ping_rate_hz) == (
        3.0e5,
        60.0,
        800,
        5.0,
    )
    assert (c.acoustic.source_level_db, c.acoustic.noise_level_db) == (205.0, 35.0)
    assert preset("blueview_p900_90").horizontal_fov_deg == 90.0
    assert preset("blueview_p900_90").frequency_hz == 900e3
    assert preset("blueview_p900_90").max_range == 100.0
    assert preset("blueview_p900_90").ping_rate_hz == 15.0
    with pytest.raises(ValueError, match="source_level_db"):
        preset("msis", source_level_db=500.0)


@pytest.mark.parametrize("two_sites", [False, True])
def test_probe_batched_with_the_cached_fan_gives_the_same_pings(two_sites):
    """The nadir probe is cast in one batch with the previous ping's fan (with a two-site
    sonar: with its port side, cast from the same site); a sonar whose fan cache is
    cleared before every ping probes first and casts after (the unbatched path). Both
    give the same bytes over a track that crosses a moving box and changes altitude (fan
    rebuilt)."""
    sc = build_scene(
        altitude=8.0,
        objects=[SceneObject("box", (0.0, 9.0, 0.8), (0.5, 0.8, 0.8), moving=True)],
        seabed_cells=40,
        relief=0.8,
    )
    if two_sites:
        sites = (sc.sites["sss_port"], sc.sites["sss_starboard"])
        a, b = (
            SideScanSonar(preset("deepeye680d"), sc.model, sc.data, sites, *_scene_args(sc))
            for _ in "ab"
        )
    else:
        a, b = _sonar(sc), _sonar(sc)
    ra, rb = np.random.default_rng(5), np.random.default_rng(5)
    z0 = float(sc.data.qpos[sc.qpos_adr(sc.vehicle_body) + 2])
    seen, alts = False, set()
    for k in range(8):
        sc.move_vehicle(-1.0 + 0.3 * k, z=z0 + 0.4 * (k % 3))
        pa = a.ping(sc.data, ra)
        b.clear_cache()
        pb = b.ping(sc.data, rb)
        for x, y in (
            (pa.intensity, pb.intensity),
            (pa.labels, pb.labels),
            (pa.hit_position, pb.hit_position),
        ):
            assert x.tobytes() == y.tobytes()
        assert pa.altitude == pb.altitude
        seen |= bool((pa.labels >= 1).any())
        alts.add(round(pa.altitude, 1))
    assert seen and len(alts) >= 3  # the box was imaged; the fan was rebuilt


def _scene_args(sc):
    """geom_object_id, geom_reflectivity, water of a scene (SideScanSonar arguments)."""
    return sc.geom_object_id, sc.geom_reflectivity, sc.water


def test_two_site_side_cones_find_the_same_hits_as_no_cones():
    """Second formulation: each side of a two-site sonar is cast with its own bounding
    cones (a hint restricting the moving-body test); the hits are the bytes of the same
    cast without cones, and moving boxes on both sides are hit (the test can fail)."""
    objs = [
        SceneObject("box", (0.0, 12.0, 0.8), (1.0, 1.0, 0.8), moving=True),
        SceneObject("box", (0.0, -12.0, 0.8), (1.0, 1.0, 0.8), moving=True),
    ]
    sc = build_scene(altitude=10.0, objects=objs, seabed_cells=20)
    sites = (sc.sites["sss_port"], sc.sites["sss_starboard"])
    son = SideScanSonar(preset("deepeye680d"), sc.model, sc.data, sites, *_scene_args(sc))
    fan = son.ray_fan(10.0)
    n_side = fan.directions.shape[0] // 2
    mt = son.mount
    for k, site in enumerate(mt.site_ids):
        p, R = mt.pose(sc.data, site)
        dirs = fan.directions[k * n_side : (k + 1) * n_side] @ R.T
        h1 = mt.backend.cast(sc.data, p, dirs, mt.cutoff, fan.side_cones[k].rotated(R))
        h2 = mt.backend.cast(sc.data, p, dirs, mt.cutoff)
        for x, y in ((h1.dist, h2.dist), (h1.geom, h2.geom), (h1.normal, h2.normal)):
            assert x.tobytes() == y.tobytes()
        assert (sc.geom_object_id[h1.geom[h1.geom >= 0]] >= 1).any()
