"""Experiment runner, JSON/figure output and the ``undersea slam-experiment`` CLI on short
variants (one loop): the numbers are checked against the runs' own data."""

from __future__ import annotations

import json

import numpy as np
import pytest

from slam.experiments import get_experiment, run_monte_carlo, run_once, save_results
from slam.metrics import chi2_bounds


@pytest.fixture(autouse=True, scope="module")
def _single_blas_thread():
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def test_experiments_have_the_thesis_maps():
    assert get_experiment("dense-loop").map.landmarks.shape == (35, 2)
    assert get_experiment("line").map.landmarks.shape == (27, 2)
    seg = get_experiment("segmentation-loop")
    assert seg.map.landmarks.shape == (54, 2) and len(seg.named) == 8
    assert get_experiment("dense-loop", dt=0.0125).sim.dt_s == 0.0125
    with pytest.raises(ValueError, match="allowed: dense-loop, line, segmentation-loop"):
        get_experiment("circle")


def test_run_once_measures_against_the_simulated_truth():
    spec = get_experiment("line")
    r = run_once(spec, "aekf", seed=3, estimator_params={"jacobians": "fej"})
    assert r.nees.shape == (r.true_poses.shape[0],)
    assert set(r.named_errors) == {"A", "B", "C", "D"}
    # recompute the landmark RMSE from the returned arrays with the true map
    from slam.metrics import landmark_errors

    le = landmark_errors(r.lm_est, spec.map.landmarks, est_labels=r.lm_labels)
    assert le.rmse == pytest.approx(r.landmark_rmse)
    assert r.lm_labels is not None
    ate = np.sqrt(np.mean(np.sum((r.true_poses[:, :2] - r.est_poses[:, :2]) ** 2, axis=1)))
    assert r.ate == pytest.approx(ate)
    assert r.n_true_seen == 27


def test_monte_carlo_average_nees_and_outputs(tmp_path):
    spec = get_experiment("dense-loop", n_loops=1)
    mc = run_monte_carlo(spec, "aekf", runs=3, seed=0, estimator_params={"jacobians": "fej"})
    stacked = np.stack([r.nees for r in mc.runs])
    np.testing.assert_allclose(mc.avg_nees, np.nanmean(stacked, axis=0))
    assert mc.nees_bounds == chi2_bounds(3, 3)
    s = save_results(mc, spec, tmp_path)
    data = json.loads((tmp_path / "dense-loop_aekf_results.json").read_text())
    assert data["n_runs"] == 3 and data["filter"] == "aekf"
    assert (tmp_path / "dense-loop_aekf_map.png").stat().st_size > 10_000
    assert (tmp_path / "dense-loop_aekf_nees.png").stat().st_size > 10_000
    assert s["landmark_rmse_median_m"] == pytest.approx(
        float(np.median([r.landmark_rmse for r in mc.runs]))
    )


def test_fastslam2_runs_the_same_data():
    """The experiments swap estimators: FastSLAM 2.0 (other helper's) on the same run."""
    spec = get_experiment("line")
    r = run_once(spec, "fastslam2", seed=1, estimator_params={"n_particles": 10})
    a = run_once(spec, "aekf", seed=1)
    np.testing.assert_array_equal(r.true_poses, a.true_poses)
    assert r.n_landmarks > 0 and np.isfinite(r.landmark_rmse)


def test_cli_json(capsys):
    from sim.cli.main import main

    rc = main(
        [
            "slam-experiment",
            "line",
            "--runs",
            "1",
            "--seed",
            "2",
            "--json",
            "--param",
            "jacobians=fej",
        ]
    )
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["experiment"] == "line" and out["params"] == {"jacobians": "fej"}
    assert out["n_runs"] == 1 and out["dt_s"] == 0.025
    with pytest.raises(SystemExit):
        main(["slam-experiment", "line", "--dt", "0.05"])


class _FixedMapEstimator:
    """Stand-in estimator for the metric test: reports a given map and the true poses."""

    name = "fixed"

    def __init__(self, lm, poses):
        self._lm, self._poses, self._i = lm, poses, -1

    def predict(self, odometry):
        self._i += 1

    def update(self, observations):
        from slam.estimators.base import UpdateResult

        return UpdateResult(np.zeros(0, np.intp), np.zeros(0, bool), np.zeros(0))

    def pose(self):
        return self._poses[self._i].copy(), 0.01 * np.eye(3)

    def landmarks(self):
        return self._lm.copy(), np.broadcast_to(0.01 * np.eye(2), (self._lm.shape[0], 2, 2))


def test_a_duplicate_near_a_never_seen_landmark_is_counted(monkeypatch):
    """Known answer: a map holding every observed landmark exactly plus one copy of a seen
    landmark moved next to a landmark that is never observed (column 19 of example_webmap).
    The copy is a duplicate (1), not an estimate of the unseen landmark, and the RMSE over
    the observed landmarks is 0."""
    import slam.experiments.runner as runner
    from slam.sim2d import simulate_run

    spec = get_experiment("dense-loop", n_loops=1)
    run = simulate_run(spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(0))
    seen = np.unique(run.obs_label)
    assert 19 not in seen
    dup = spec.map.landmarks[19] + [3.0, 0.0]
    lm = np.concatenate([spec.map.landmarks[seen], dup[None]])
    monkeypatch.setattr(
        runner, "make_estimator", lambda name, **kw: _FixedMapEstimator(lm, run.true_poses)
    )
    r = run_once(spec, "aekf", 0, sim_run=run)
    assert r.n_duplicates == 1
    assert r.landmark_rmse == pytest.approx(0.0, abs=1e-12)
    assert r.n_missed == 0


def test_nees_comparison_script_writes_one_curve_per_variant(tmp_path, capsys):
    """scripts/nees_comparison.py on 2 short runs (line map, dt 0.1 s: 370 scans, a
    quarter of dt 0.025's): one printed line and one plotted curve per variant; the
    printed time-mean NEES equals the run's own average."""
    import matplotlib.image as mpimg
    from script_module import load_script

    mod = load_script("nees_comparison")
    out = tmp_path / "nees.png"
    args = ["--experiment", "line", "--dt", "0.1", "--runs", "2", "--out", str(out)]
    args += ["--variant", "plain:preset=reference", "--variant", "fej:jacobians=fej"]
    assert mod.main(args) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert [ln.split(":")[0] for ln in lines[:2]] == ["plain", "fej"]
    mc = run_monte_carlo(
        get_experiment("line", dt=0.1),
        "aekf",
        runs=2,
        seed=0,
        estimator_params={"jacobians": "fej"},
    )
    assert f"{np.nanmean(mc.avg_nees):.2f}" in lines[1]
    img = mpimg.imread(out)
    assert img.shape[0] > 200 and img.shape[1] > 500
    with pytest.raises(SystemExit):
        mod.main(["--variant", "no-colon-here"])
