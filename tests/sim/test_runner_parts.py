"""Runner building blocks: lagged SLAM feeding, increment composition, metrics, output dir."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.runner.lagged import LaggedSlam, apply_increment, compose_increments
from sim.runner.metrics import landmark_metrics, match_landmarks, pose_metrics
from sim.runner.output import OutputExistsError, RunDirectory, dumps_canonical
from slam.types import Odometry, RangeBearing

inc = st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-3, 3)).map(
    lambda t: np.array(t, dtype=float)
)


@settings(max_examples=50, deadline=None)
@given(inc, inc, st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-3, 3)))
def test_composed_increment_equals_sequential_application(d1, d2, p0):
    """Composition is exact for the mean: applying d1 then d2 equals applying compose(d1, d2)."""
    pose = np.array(p0)
    seq = apply_increment(apply_increment(pose, d1), d2)
    d, _ = compose_increments(d1, np.zeros((3, 3)), d2, np.zeros((3, 3)))
    one = apply_increment(pose, d)
    assert np.allclose(seq[:2], one[:2], atol=1e-9)
    assert np.isclose(np.cos(seq[2] - one[2]), 1.0)


def test_composed_covariance_matches_monte_carlo(rng):
    """First-order covariance of a composed increment agrees with sampling (small noise)."""
    d1, d2 = np.array([1.0, 0.2, 0.3]), np.array([2.0, -0.5, 0.1])
    C1, C2 = np.diag([1e-4, 2e-4, 1e-5]), np.diag([3e-4, 1e-4, 2e-5])
    _, C = compose_increments(d1, C1, d2, C2)
    n = 40000
    a = d1 + rng.multivariate_normal(np.zeros(3), C1, n)
    b = d2 + rng.multivariate_normal(np.zeros(3), C2, n)
    c, s = np.cos(a[:, 2]), np.sin(a[:, 2])
    samples = np.column_stack(
        [
            a[:, 0] + c * b[:, 0] - s * b[:, 1],
            a[:, 1] + s * b[:, 0] + c * b[:, 1],
            a[:, 2] + b[:, 2],
        ]
    )
    assert np.allclose(np.cov(samples.T), C, rtol=0.05, atol=2e-6)


class _Recorder:
    """Minimal estimator: integrates odometry, records each call with the pose at that time."""

    name = "recorder"

    def __init__(self):
        self.x = np.zeros(3)
        self.P = np.zeros((3, 3))
        self.calls = []

    def predict(self, odometry):
        self.x = apply_increment(self.x, odometry.delta)
        self.calls.append(("predict", odometry.t))

    def update(self, observations):
        self.calls.append(("update", observations[0].t, self.x.copy()))

    def pose(self):
        return self.x.copy(), self.P.copy()

    def landmarks(self):
        return np.zeros((0, 2)), np.zeros((0, 2, 2))


def test_late_observation_applied_at_pose_of_its_ping():
    """A detection made at t=0.3 but delivered at t=1.0 updates the filter when its pose is
    the pose at t=0.3 (vehicle moving 1 m per 0.1 s along x: x = 3 m), not at t=1.0."""
    est = _Recorder()
    lag = LaggedSlam(est)
    for k in range(1, 11):
        lag.add_odometry(Odometry([1.0, 0, 0], np.eye(3) * 1e-4, t=0.1 * k))
    obs = RangeBearing([5.0, np.pi / 2], np.eye(2) * 0.01, t=0.3)
    lag.add_observations(0.3, [obs])
    lag.release(0.5)
    upd = [c for c in est.calls if c[0] == "update"]
    assert len(upd) == 1 and np.isclose(upd[0][2][0], 3.0)
    assert np.isclose(lag.t_done, 0.5)
    t, cur = lag.current_pose()  # lagged estimate + queued odometry = pose now
    assert np.isclose(t, 1.0) and np.isclose(cur[0], 10.0)
    with pytest.raises(ValueError, match="older than the released horizon"):
        lag.add_observations(0.2, [obs])


def test_odometry_between_observations_is_one_predict_unless_a_history_node_is_due():
    """With no observation, increments are composed into one predict; with record_dt = 2 s
    the history gets nodes at 2 s and 4 s and at the end (5 s), and the final pose is the
    same either way (composition is exact for the mean)."""
    poses = []
    for record_dt, n_pred in ((100.0, 1), (2.0, 3)):
        est = _Recorder()
        lag = LaggedSlam(est, record_dt=record_dt)
        for k in range(1, 6):
            lag.add_odometry(Odometry([1.0, 0, 0.1], np.eye(3) * 1e-4, t=float(k)))
        lag.release(5.0)
        assert [c[0] for c in est.calls] == ["predict"] * n_pred and lag.t_done == 5.0
        poses.append(est.x)
    assert np.allclose(poses[0], poses[1])
    assert [r.t for r in lag.history] == [2.0, 4.0, 5.0]


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


@pytest.mark.parametrize("kind", ["alister9", "saga"])
def test_vehicle_display_mesh_matches_reference_dimensions(kind):
    """The rerun mesh built from the vehicle's MuJoCo geoms spans the REFERENCE.md
    length/width/height (Table 6.5: Alister 9 2.0 x 0.22 x 0.22 m, SAGA 0.42 x 0.33 x 0.27 m)."""
    from sim.runner.core import vehicle_body_mesh
    from sim.world import SeabedSpec, WorldSpec, build_world

    w = build_world(
        WorldSpec(seabed=SeabedSpec(size_xy=(20.0, 20.0), resolution=2.0), vehicles=(kind,))
    )
    v, f, c = vehicle_body_mesh(w.model, w.data, w.vehicles[kind].body_id)
    ext = v.max(axis=0) - v.min(axis=0)
    ref = {"alister9": (2.0, 0.22, 0.22), "saga": (0.42, 0.33, 0.27)}[kind]
    assert np.allclose(ext, ref, rtol=0.1)
    assert f.max() < len(v) and c.shape == (len(v), 3)
