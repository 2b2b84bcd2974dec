"""Runner building blocks: metrics, output dir, figures."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sim.runner.metrics import landmark_metrics, match_landmarks, pose_metrics
from sim.runner.output import OutputExistsError, RunDirectory, dumps_canonical


def test_landmark_metrics_known_case():
    """Two objects; three estimates: one at 0.3 m, one duplicate near object 0, one at 0.4 m.
    Hungarian matching keeps the closest per object: RMSE = sqrt((0.09 + 0.16) / 2)."""
    truth = np.array([[0.0, 0.0], [10.0, 0.0]])
    est = np.array([[0.3, 0.0], [0.0, 1.5], [10.0, 0.4]])
    r = landmark_metrics(est, np.tile(np.eye(2), (3, 1, 1)), truth)
    assert np.isclose(r["rmse_m"], np.sqrt((0.09 + 0.16) / 2))
    assert r["n_spurious"] == 1 and r["n_duplicated_objects"] == 1
    ei, _, _ = match_landmarks(est, truth, match_radius=0.2)
    assert len(ei) == 0


def test_pose_nees_of_consistent_samples_is_near_dof(rng):
    """Errors drawn from the stated covariance give a mean NEES near 3 (3 dof)."""
    n = 4000
    P = np.diag([0.5, 0.2, 0.01])
    truth = np.zeros((n, 3))
    est = rng.multivariate_normal(np.zeros(3), P, n)
    r = pose_metrics(np.arange(n), est, np.tile(P, (n, 1, 1)), truth)
    assert abs(r["nees_mean"] - 3.0) < 0.2
    assert 0.93 < r["nees_in_95_interval"] < 0.97


def test_run_directory_never_looks_complete_until_finalized(tmp_path):
    out = tmp_path / "run"
    rd = RunDirectory(out)
    rd.write_json("metrics.json", {"complete": False})
    assert not out.exists() and rd.staging.name.startswith(".run.partial")
    rd.finalize()
    assert json.loads((out / "metrics.json").read_text()) == {"complete": False}
    with pytest.raises(OutputExistsError, match="--overwrite"):
        RunDirectory(out)
    rd2 = RunDirectory(out, overwrite=True)
    rd2.write_json("metrics.json", {"complete": True})
    assert json.loads((out / "metrics.json").read_text())["complete"] is False  # old one intact
    rd2.finalize()
    assert json.loads((out / "metrics.json").read_text())["complete"] is True


def test_canonical_json_is_stable_and_nan_is_null():
    a = dumps_canonical({"b": np.float64(np.nan), "a": np.arange(2)})
    assert a == dumps_canonical({"a": [0, 1], "b": None})
    assert json.loads(a) == {"a": [0, 1], "b": None}


def test_mosaic_grid_means_and_sample_positions():
    """Two values in one cell average; a starboard sample of a vehicle heading east lies
    south of it (y = -g), a port sample north."""
    from sim.runner.figures import mosaic_grid, sss_sample_world_xy

    g = mosaic_grid(
        np.array([[0.2, 0.2], [0.4, 0.3], [5.0, 5.0]]),
        np.array([1.0, 3.0, 7.0]),
        (0, 10, 0, 10),
        1.0,
    )
    assert g[9, 0] == 2.0 and g[5, 5] == 7.0 and np.isnan(g[0, 0])
    xy = sss_sample_world_xy(np.array([[10.0, 20.0, 0.0]]), np.array([[1.0, 5.0]]))
    assert np.allclose(xy[0], [[10, 25], [10, 21], [10, 19], [10, 15]])


def test_figures_written(tmp_path, rng):
    from sim.runner.figures import VehiclePlotData, plot_sss_mosaic, plot_trajectory_map

    v = VehiclePlotData(
        "a",
        rng.normal(size=(20, 2)),
        rng.normal(size=(20, 2)),
        np.zeros((1, 2)),
        np.eye(2)[None],
        np.zeros((1, 2)),
    )
    p = plot_trajectory_map(tmp_path / "t.png", [v], [("rock", np.zeros(3), np.ones(3))])
    m = plot_sss_mosaic(
        tmp_path / "m.png",
        {"a/sss": (rng.random((10, 10)), (0, 10, 0, 10))},
        {"a/sss": np.ones((1, 2))},
        [],
    )
    assert p.stat().st_size > 1000 and m.stat().st_size > 1000


def test_run_directory_refuses_a_file_path(tmp_path):
    f = tmp_path / "afile"
    f.write_text("x")
    with pytest.raises(OutputExistsError, match="is a file"):
        RunDirectory(f)


def test_turn_pings_fill_their_footprints_not_spokes():
    """A vehicle turning on the spot by 3° per kept ping: the starboard swath between the
    first and last ping is an annular sector (independent expectation: its cells). Plain
    sample positions leave most far cells empty (spokes 2 m apart at 40 m); footprints fill
    every cell of the sector and none outside it."""
    from sim.runner.figures import mosaic_grid, sss_footprints, sss_sample_world_xy

    P, S, cell = 11, 160, 0.5
    yaw = np.deg2rad(3.0) * np.arange(P)
    poses = np.column_stack([np.zeros(P), np.zeros(P), yaw])
    g = np.tile((np.arange(S) + 0.5) * 0.25, (P, 1))  # 0 .. 40 m
    inten = np.ones((P, 2 * S))
    ext = (-45.0, 45.0, -45.0, 45.0)
    xs = ext[0] + (np.arange(180) + 0.5) * cell
    ys = ext[3] - (np.arange(180) + 0.5) * cell
    X, Y = np.meshgrid(xs, ys)
    r = np.hypot(X, Y)
    # starboard points along -y rotated by yaw: bearing = yaw - 90°
    ang = (np.arctan2(Y, X) + np.pi / 2) % (2 * np.pi)
    inner = (r > 5.0) & (r < 39.0) & (ang > 0.02) & (ang < yaw[-1] - 0.02)
    spokes = mosaic_grid(sss_sample_world_xy(poses, g).reshape(-1, 2), inten.reshape(-1), ext, cell)
    xy, v = sss_footprints(poses, g, inten, cell)
    foot = mosaic_grid(xy, v, ext, cell)
    assert np.isfinite(spokes[inner]).mean() < 0.6
    assert np.isfinite(foot[inner]).all()
    m = 0.02 + cell / r  # a cell's angular half-width and a margin
    outside = ((r > 41.0) | ((ang > yaw[-1] + m) & (ang < np.pi - m))) & (r > 2.0)
    assert not np.isfinite(foot[outside]).any()
