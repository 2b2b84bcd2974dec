"""rerun logging read back with rerun's own reader (rerun.chunk.RrdReader)."""

from __future__ import annotations

import numpy as np
import pytest
import rerun as rr

from sim.viz import rerun_log as L


@pytest.fixture(autouse=True)
def _strict():
    """Make rerun raise on bad input instead of warning, so a wrong call fails the test."""
    rr.set_strict_mode(True)
    yield
    rr.set_strict_mode(False)


def _synthetic_recording(path, rng, n_steps=5, n_lm=3):
    rec = L.open_recording(
        path, blueprint=L.default_blueprint({"alister9": ["sss"], "saga": ["fls"]})
    )
    L.log_annotations(rec)
    verts = rng.uniform(-10, 10, (25, 3))
    faces = np.array([[0, 1, 2], [2, 3, 4], [5, 6, 7]])
    L.log_seabed(rec, verts, faces)
    L.log_objects(rec, [1, 2], ["shipwreck", "rock"], np.zeros((2, 3)), np.ones((2, 3)))
    L.log_vehicle_mesh(rec, "alister9", rng.uniform(-1, 1, (8, 3)), faces[:2])
    path_xyz = []
    for i in range(n_steps):
        L.set_time(rec, 0.5 * i)
        p = np.array([float(i), 0.0, -5.0])
        path_xyz.append(p)
        L.log_vehicle_pose(rec, "alister9", p, [1.0, 0.0, 0.0, 0.0])
        L.log_trajectory(rec, "alister9", "true", np.array(path_xyz))
        L.log_landmarks(
            rec,
            "alister9",
            rng.uniform(0, 5, (n_lm, 2)),
            np.tile(np.diag([1.0, 0.25]), (n_lm, 1, 1)),
        )
        img = rng.rayleigh(1.0, (16, 32)).astype(np.float32)
        seg = np.zeros((16, 32), np.uint16)
        seg[4:8, 10:14] = L.class_id("shipwreck")
        L.log_sonar_image(rec, "alister9", "sss", img, seg)
        L.log_scalars(rec, "alister9", {"ate_m": float(i), "skipped": float("nan")})
    L.log_detections(rec, "alister9", "sss", np.array([[1.0, 2.0, -30.0]]), ["shipwreck"])
    L.close_recording(rec)


def test_entities_counts_and_values_read_back(tmp_path, rng):
    """Every logged entity is in the file with the number of rows we logged, static data is
    static, and scalar values come back exactly."""
    p = tmp_path / "r.rrd"
    _synthetic_recording(p, rng, n_steps=5)
    ents = L.read_recording(p)
    assert ents["/world/seabed"].static and ents["/world/objects/shipwreck_1"].static
    assert ents["/world/alister9/mesh"].static
    assert ents["/world/alister9"].rows == 5 and not ents["/world/alister9"].static
    assert "Transform3D:translation" in ents["/world/alister9"].components
    assert ents["/world/alister9/sonar/sss/image"].rows == 5
    assert ents["/world/alister9/sonar/sss/segmentation"].rows == 5
    assert ents["/world/slam/alister9/landmark_cov"].rows == 5
    assert ents["/world/trajectories/alister9/true"].rows == 5
    assert ents["/world/detections/alister9/sss"].rows == 1
    assert "/metrics/alister9/skipped" not in ents  # NaN metrics are not logged
    vals = L.read_component(p, "metrics/alister9/ate_m", "Scalars:scalars")
    assert [v[0] for v in vals] == [0.0, 1.0, 2.0, 3.0, 4.0]
    tr = L.read_component(p, "world/alister9", "Transform3D:translation")
    assert np.allclose([t[0] for t in tr], [[i, 0, -5] for i in range(5)])


def test_blueprint_is_stored(tmp_path, rng):
    from rerun.chunk import RrdReader

    p = tmp_path / "r.rrd"
    _synthetic_recording(p, rng, n_steps=1)
    assert len(RrdReader(str(p)).blueprints()) == 1


def test_ellipse_axes_analytic():
    """Diagonal covariance diag(4, 1): 2-sigma half axes (4, 2) along x; rotated by 90° when
    the variances swap; a rotated covariance gives back its rotation angle."""
    half, ang = L.ellipse_axes(np.array([np.diag([4.0, 1.0]), np.diag([1.0, 4.0])]))
    assert np.allclose(half, [[4.0, 2.0], [4.0, 2.0]])
    assert np.isclose(abs(np.cos(ang[0])), 1.0) and np.isclose(abs(np.sin(ang[1])), 1.0)
    a = 0.6
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    _, ang2 = L.ellipse_axes((R @ np.diag([9.0, 1.0]) @ R.T)[None])
    assert np.isclose(np.tan(ang2[0]), np.tan(a))


def test_display_conversion_range_and_monotone(rng):
    """Log display mapping is monotone in intensity and spans 0..255."""
    a = np.sort(rng.exponential(1.0, 1000)).astype(np.float32)
    d = L.to_display_uint8(a)
    assert d.dtype == np.uint8 and np.all(np.diff(d.astype(int)) >= 0) and d.max() == 255


def test_bad_segmentation_shape_rejected(tmp_path):
    rec = L.open_recording(None)
    with pytest.raises(ValueError, match="segmentation shape"):
        L.log_sonar_image(rec, "v", "s", np.ones((4, 4), np.float32), np.zeros((3, 4)))


def test_bad_trajectory_kind_rejected():
    rec = L.open_recording(None)
    with pytest.raises(ValueError, match="'true' or 'estimated'"):
        L.log_trajectory(rec, "v", "guess", np.zeros((2, 3)))


def test_fixed_db_mapping_is_the_same_for_every_window(rng):
    """db_to_uint8 maps lo -> 0, hi -> 255 and is affine in between, whatever else is in
    the image (a per-image stretch would move the grey of 0 dB with the window's content)."""
    span = (-10.0, 20.0)
    a = np.array([[-10.0, 20.0, 5.0, -40.0, 99.0, np.nan]])
    assert L.db_to_uint8(a, span).tolist() == [[0, 255, 128, 0, 255, 0]]
    quiet = rng.normal(0.0, 1.0, (8, 8))
    loud = np.concatenate([quiet, rng.normal(15.0, 1.0, (8, 8))], axis=1)
    assert np.array_equal(L.db_to_uint8(quiet, span), L.db_to_uint8(loud, span)[:, :8])
