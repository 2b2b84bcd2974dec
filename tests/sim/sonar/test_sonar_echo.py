"""Echo binning: the closed-form box splat against a brute-force overlap sum; form_echo
against its pre-compiled array version (tests/helpers/legacy_echo.py)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.sonar.echo import _splat_energy
from sim.sonar.echo_image import label_cells


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 300))
def test_box_splat_equals_bruteforce_overlap(seed, n):
    """Second implementation: each cell gets Σ E·|[a,b) ∩ [k,k+1)| / (b − a); spans partly
    outside the range axis lose exactly the outside part (energy conservation)."""
    rng = np.random.default_rng(seed)
    n_bins, n_rows = 40, 3
    a = rng.uniform(-5, n_bins + 2, n)
    b = a + rng.uniform(0.5, 12, n)
    e = rng.uniform(0.1, 10, n)
    rows = rng.integers(0, n_rows, n)
    out = _splat_energy(rows, a, b, e, n_rows, n_bins)
    k = np.arange(n_bins)
    ov = (
        np.clip(np.minimum(b[:, None], k + 1.0) - np.maximum(a[:, None], k), 0, None)
        / (b - a)[:, None]
    )
    ref = np.zeros((n_rows, n_bins))
    np.add.at(ref, rows, e[:, None] * ov)
    np.testing.assert_allclose(out, ref, rtol=1e-9, atol=1e-9 * e.sum())


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_label_cells_follow_the_covering_spans(seed):
    """Brute force: cell k of row r is 0 when a seabed background footprint's cell span
    [floor(a), ceil(b)) of that row contains it, else −2 when an unlabelled geom's does,
    else −1; object (label ≥ 1) and missed (−1) footprints label nothing."""
    rng = np.random.default_rng(seed)
    n = 60
    a = rng.uniform(-3.0, 32.0, n)
    b = a + rng.uniform(0.0, 8.0, n)
    rows = rng.integers(0, 2, n)
    lab = rng.choice(np.array([0, -2, 3, -1], np.int32), n)
    bg = (lab == 0) | (lab == -2)
    labels, start, end = label_cells(rows, a, b, lab, 2, 30)
    s = np.clip(np.floor(a), 0, 30).astype(int)
    e = np.clip(np.ceil(b), 0, 30).astype(int)
    np.testing.assert_array_equal(start, s)
    np.testing.assert_array_equal(end, e)
    k = np.arange(30)
    for r in (0, 1):
        inside = (rows[:, None] == r) & (s[:, None] <= k) & (k < e[:, None]) & bg[:, None]
        ref = np.where(
            (inside & (lab[:, None] == 0)).any(0),
            0,
            np.where((inside & (lab[:, None] == -2)).any(0), -2, -1),
        )
        np.testing.assert_array_equal(labels[r], ref)


def test_form_echo_same_bytes_as_the_array_version():
    """Second implementation: on side-scan and forward-looking fans over a rolling seabed
    with static objects and a moving box (background, objects, vehicle-free hits, wide
    sub-boxed footprints, neighbour links), the compiled scatters give the same mean,
    labels and hit positions, byte for byte, as the array version they replaced — also
    with the realistic preset's sediment seabed, facet glint and object gain, and
    without neighbour links; the FLS layout (``bins_first``) is the transpose of the
    same positions, the side-scan ping's (``ping_layout``) their rows joined, row 0
    reversed."""
    import sys
    from pathlib import Path

    from sim.sonar import ForwardLookingSonar, SideScanSonar, preset
    from sim.sonar.echo import form_echo
    from sim.sonar.scenes import SceneObject, build_scene

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "helpers"))
    from legacy_echo import form_echo as legacy_form_echo

    objs = [
        SceneObject("box", (1.0, 9.0, 0.6), (0.8, 0.6, 0.5), euler_deg=(0, 0, 30)),
        SceneObject("cylinder", (-1.0, -12.0, 0.5), (0.4, 1.5), euler_deg=(0, 90, 0)),
        SceneObject("box", (0.0, 15.0, 0.8), (0.6, 0.6, 0.6), moving=True),
        SceneObject("box", (22.0, 0.0, 1.0), (1.5, 1.5, 1.0), moving=True),  # ahead: FLS
    ]
    sc = build_scene(altitude=8.0, objects=objs, seabed_cells=40, relief=0.6)
    m, d = sc.model, sc.data
    args = (sc.geom_object_id, sc.geom_reflectivity, sc.water)
    sss = SideScanSonar(preset("deepeye680d"), m, d, sc.sites["sss"], *args)
    fls = ForwardLookingSonar(
        preset("blueview_p900_90", n_beams=64, n_bins=200, max_range=30.0),
        m,
        d,
        sc.sites["fls"],
        *args,
    )
    mt = sss.mount
    p, R = mt.pose(d, sc.sites["sss"])
    fan = sss.ray_fan(sss.ping(d, np.random.default_rng(0)).altitude)
    dirs, dd = fan.directions @ R.T, fan.d_directions @ R.T
    hits = mt.backend.cast(d, p, dirs, mt.cutoff)
    common = (mt.geom_object_id, mt.geom_reflectivity, mt.alpha_db_m, mt.specular, 1.0)
    cases = [
        (
            hits,
            p,
            dirs,
            dd,
            fan.gain,
            fan.rows,
            2,
            1000,
            0.0,
            sss.bin_width,
            *common,
            fan.neighbours,
        )
    ]
    rz = SideScanSonar(preset("deepeye680d_realistic"), m, d, sc.sites["sss"], *args).mount
    assert rz.seabed is not None and rz.object_specular is not None
    realistic = (rz.seabed, rz.object_specular, 2.0)  # object gain ≠ 1: its branch too
    cases.append((*cases[0][:10], *common, fan.neighbours, *realistic))
    cases.append((*cases[0][:10], *common, None))  # no links: the −3/r slope of wide boxes
    fm = fls.mount
    pf, Rf = fm.pose(d, sc.sites["fls"])
    df, ddf = fls._d_local @ Rf.T, fls._dd_local @ Rf.T
    hf = fm.backend.cast(d, pf, df, fm.cutoff)
    c = fls.config
    cases.append(
        (
            hf,
            pf,
            df,
            ddf,
            fls._gain,
            fls._rows,
            c.n_beams,
            c.n_bins,
            c.min_range,
            fls.bin_width,
            fm.geom_object_id,
            fm.geom_reflectivity,
            fm.alpha_db_m,
            fm.specular,
            1.0,
            fls._neighbours,
        )
    )
    for case in cases:
        new = form_echo(*case)
        old = legacy_form_echo(*case)
        assert (old.labels >= 1).any() and (old.labels == 0).any()
        for x, y in ((new.mean, old.mean), (new.labels, old.labels)):
            assert x.tobytes() == y.tobytes()
        assert new.hit_position.tobytes() == old.hit_position.tobytes()
        t = form_echo(*case, bins_first=True).hit_position
        assert t.tobytes() == np.ascontiguousarray(old.hit_position.transpose(1, 0, 2)).tobytes()
        if case[6] == 2:  # the side-scan ping's layout: row 0 reversed, then row 1
            p = form_echo(*case, ping_layout=True).hit_position
            ref = np.concatenate([old.hit_position[0, ::-1], old.hit_position[1]])
            assert p.tobytes() == ref.tobytes()


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), kind=st.sampled_from(["mixed", "objects", "misses"]))
def test_form_echo_same_bytes_on_synthetic_fans(seed, kind):
    """Second implementation (legacy_echo): random two-row fans whose hits are a mix of
    seabed, objects, unlabelled geoms and misses — or only objects (no background
    footprint centre anywhere), or only misses — give the same bytes, in all layouts."""
    import sys
    from pathlib import Path

    from sim.sonar.echo import form_echo
    from sim.sonar.rays import RayHits

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "helpers"))
    from legacy_echo import form_echo as legacy_form_echo

    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 200))
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    normal = rng.normal(size=(n, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    d_dirs = 0.01 * rng.normal(size=(n, 3))
    geom_object_id = np.array([0, 2, 5, -1], np.int32)  # seabed, two objects, unlabelled
    pick = {"mixed": [-1, 0, 1, 2, 3], "objects": [1, 2], "misses": [-1]}[kind]
    geom = rng.choice(np.array(pick, np.int32), n)
    dist = np.where(geom >= 0, rng.uniform(0.5, 30.0, n), np.inf)
    hits = RayHits(dist, geom, np.where(geom[:, None] >= 0, normal, 0.0))
    rows = np.sort(rng.integers(0, 2, n))
    case = (
        hits, np.array([1.0, -2.0, 3.0]), dirs, d_dirs, rng.uniform(1e3, 1e6, n), rows, 2, 60,
        0.5, 0.5, geom_object_id, np.array([1.0, 0.7, 0.9, 0.5]), 0.1, (10.0, 0.2), 1.0,
        rng.uniform(size=n - 1) < 0.8,
    )  # fmt: skip
    old = legacy_form_echo(*case)
    new = form_echo(*case)
    for x, y in ((new.mean, old.mean), (new.labels, old.labels)):
        assert x.tobytes() == y.tobytes()
    assert new.hit_position.tobytes() == old.hit_position.tobytes()
    t = form_echo(*case, bins_first=True).hit_position
    assert t.tobytes() == np.ascontiguousarray(old.hit_position.transpose(1, 0, 2)).tobytes()
    p = form_echo(*case, ping_layout=True).hit_position
    ref = np.concatenate([old.hit_position[0, ::-1], old.hit_position[1]])
    assert p.tobytes() == ref.tobytes()
