"""AEKF-SLAM on Bailey's simulator (dense loop = example_webmap): accuracy against the
truth, consistency against its own covariance, and data association against the
simulator's labels (known answers)."""

from __future__ import annotations

import numpy as np
import pytest

from slam.estimators import make_estimator
from slam.estimators.aekf import AEKFSlam
from slam.experiments import get_experiment, run_once
from slam.sim2d import simulate_run


@pytest.fixture(autouse=True, scope="module")
def _single_blas_thread():
    """Small matrices: oversubscribed BLAS threads on a shared machine only slow down."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


@pytest.fixture(scope="module")
def two_loop_run():
    spec = get_experiment("dense-loop")
    return simulate_run(spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(11))


@pytest.fixture(scope="module")
def consistent_fine_run():
    """``run_once`` of the "consistent" AEKF on dense-loop run ``seed`` at the thesis's dt
    0.0125 s, computed once per module: the 10-run accuracy test and the filter side of
    the smoother comparison drive the same filter on the same data (``run_once`` draws
    run ``seed``'s data from ``SeedSequence(seed).spawn(2)[0]``, as the comparison does)."""
    spec = get_experiment("dense-loop", dt=0.0125)
    done = {}

    def get(seed: int):
        if seed not in done:
            done[seed] = run_once(spec, "aekf", seed, {"preset": "consistent"})
        return done[seed]

    return get


def _drive(f, run):
    """Run the filter; return rows (scan, observation label, label of the landmark it was
    associated with) for every associated observation."""
    rows = []
    for i in range(run.n_scans):
        f.predict(run.odometry(i))
        res = f.update(run.observations(i))
        lab = run.scan(i)[1]
        ok = (res.associations >= 0) & ~res.new
        rows.append(
            np.stack([np.full(ok.sum(), i), lab[ok], f.labels[res.associations[ok]]], axis=1)
        )
    return np.concatenate(rows)


def test_standard_ekf_gated_association_makes_no_false_match(two_loop_run):
    """Well-separated landmarks (>= 19.5 m apart): every association of the standard EKF
    with the default gates agrees with the simulator's label. (On this seed its
    overconfidence makes it duplicate 14 landmarks at loop closure instead — the
    reference's inconsistency; see the FEJ test below.)"""
    rows = _drive(AEKFSlam(preset="reference"), two_loop_run)
    assert rows.shape[0] > 0.5 * two_loop_run.obs_z.shape[0]
    np.testing.assert_array_equal(rows[:, 1], rows[:, 2])


@pytest.mark.parametrize(("jacobians", "min_used"), [("fej", 0.8)])
def test_gated_association_makes_no_false_match_and_closes_the_loop(
    two_loop_run, jacobians, min_used
):
    """Landmarks of example_webmap are >= 19.5 m apart (well separated): with the default
    ML gates (4, 25) every association agrees with the simulator's label, each seen
    landmark exists exactly once, and landmarks seen again after the loop (a gap of more
    than 500 scans between sightings) are matched to their first estimate, not duplicated.
    The overconfident standard EKF rejects many observations between the gates (about 40 %
    here), FEJ few (about 16 %, of which 1.5 % are the 30 new landmarks; a consistent
    filter rejects 13.5 % at gate 4). Seed 11: over seeds 0-7 of this simulator the gated
    association duplicated landmarks at loop closure in 2 runs (standard) and 1 run (FEJ)."""
    run = two_loop_run
    f = AEKFSlam(preset="reference", jacobians=jacobians)
    rows = _drive(f, run)
    assert rows.shape[0] > min_used * run.obs_z.shape[0]
    np.testing.assert_array_equal(rows[:, 1], rows[:, 2])  # no false association
    seen = np.unique(run.obs_label)
    assert sorted(f.labels.tolist()) == seen.tolist()  # one landmark per seen label
    scan_of_obs = np.searchsorted(run.obs_offsets, np.arange(run.obs_z.shape[0]), side="right") - 1
    revisited = []
    for lab in seen:  # the few seen labels, to find the loop-closure ones
        s = scan_of_obs[run.obs_label == lab]
        gap = np.diff(s)
        if gap.size and gap.max() > 500:
            revisited.append((lab, s[np.argmax(gap) + 1]))
    assert len(revisited) >= 1
    for lab, back in revisited:
        later = rows[(rows[:, 0] >= back) & (rows[:, 1] == lab)]
        assert later.shape[0] > 0  # associated again after the loop


def test_fej_known_association_nis_is_chi_square_2(two_loop_run):
    """With FEJ and known association the innovations are consistent: mean NIS ≈ 2 (χ²₂
    mean) and ≈ 86.5 % of them below 4 (χ²₂ CDF at 4 = 1 - e⁻²)."""
    f = AEKFSlam(preset="reference", jacobians="fej", association="known")
    nis = []
    for i in range(two_loop_run.n_scans):
        f.predict(two_loop_run.odometry(i))
        r = f.update(two_loop_run.observations(i))
        nis.append(r.nis[np.isfinite(r.nis)])
    nis = np.concatenate(nis)
    assert nis.size > 1500
    assert abs(nis.mean() - 2.0) < 0.2
    assert abs(np.mean(nis < 4.0) - (1 - np.exp(-2))) < 0.03


def test_dense_loop_reference_parameters_accuracy_and_3sigma(consistent_fine_run):
    """Reference parameters (dt 0.0125 as the thesis, two loops as Bailey), gated ML
    association without labels, the "consistent" preset (FEJ, joint-compatibility
    association, iterated loop-closure updates), 10 seeded runs (the CI variant of the
    50-run table): median landmark RMSE below 1 m (measured 0.79 m), >= 95 % of landmarks
    inside their 3σ ellipse (99.7 %), no duplicated landmark.

    Per run the RMSE exceeds 1 m in some runs (seeds 0-2 here: 1.22, 1.96, 1.16 m), and so
    does the smoother's on the same data (see the next test): the bound is the information
    in the data, not the filter."""
    runs = [consistent_fine_run(s) for s in range(10)]
    assert np.median([r.landmark_rmse for r in runs]) < 1.0
    assert np.mean([r.frac_in_3sigma for r in runs]) >= 0.95
    assert all(r.n_duplicates == 0 for r in runs)


@pytest.mark.parametrize("seed", [pytest.param(1, marks=pytest.mark.slow), 5])
def test_dense_loop_filter_is_as_accurate_as_the_smoother(seed, consistent_fine_run):
    """Second implementation: iSAM2 (GTSAM; the full-trajectory MAP smoother, known
    association) on the same data. The filter's landmark RMSE is within 15 % of it: over 50
    runs the ratio's median is about 1.0 (measured). Seed 1 is the worst run of seeds
    0-19 for both — 1.96 vs 1.86 m, above 1 m for the smoother too; seed 5 is a loop
    closure correcting 7 m of drift in one observation, where the one-shot EKF update
    leaves the filter overconfident (RMSE 1.39 m; with the older individual gating also a
    duplicated landmark) and the iterated update matches the smoother (0.52 vs 0.47 m).
    CI runs seed 5 (filter against smoother, and iterated against one-shot updates); seed
    1 (the smoother alone costs ~40 s CPU per seed) is ``slow``."""
    pytest.importorskip("gtsam")
    spec = get_experiment("dense-loop", dt=0.0125)
    ss = np.random.SeedSequence(seed)
    run = simulate_run(
        spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(ss.spawn(2)[0])
    )
    filt = consistent_fine_run(seed)  # the same data: run_once's own draw of run ``seed``
    smoother = run_once(spec, "isam2", seed, {"association": "known"}, sim_run=run)
    assert filt.n_duplicates == 0
    assert filt.landmark_rmse < 1.15 * smoother.landmark_rmse
    if seed == 1:
        assert smoother.landmark_rmse > 1.0  # the 1 m bound is beyond this run's data
    one_shot = run_once(spec, "aekf", seed, {"preset": "consistent", "iterations": 1}, sim_run=run)
    assert filt.landmark_rmse <= one_shot.landmark_rmse + 1e-9


@pytest.mark.parametrize("seed", [2, pytest.param(6, marks=pytest.mark.slow)])
def test_segmentation_loop_clustered_landmarks_need_joint_compatibility(seed):
    """The segmentation-loop map is cluttered (54 landmarks, some 1.7-6.6 m apart). At the
    loop closure of seeds 2 and 6 the pose uncertainty (σ ≈ 2.9 m) spans landmarks 30
    and 48 (6.6 m apart) and landmark 30 is seen once, alone: individual gating (ML with
    the unambiguous rule) pairs it with 48 and keeps doing so (> 100 false associations).
    Joint compatibility with ambiguity rejection (the "consistent" preset) waits until
    the scan's observations decide: every association agrees with the simulator's label
    and no landmark is duplicated. CI runs seed 2; seed 6, the same case again, is
    ``slow``."""
    spec = get_experiment("segmentation-loop")
    ss = np.random.SeedSequence(seed)
    run = simulate_run(
        spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(ss.spawn(2)[0])
    )
    individual = _drive(
        AEKFSlam(preset="reference", jacobians="fej", unambiguous_gate=25.0, iterations=10), run
    )
    assert np.sum(individual[:, 1] != individual[:, 2]) > 50  # the control fails
    f = AEKFSlam(preset="consistent")
    joint = _drive(f, run)
    np.testing.assert_array_equal(joint[:, 1], joint[:, 2])
    assert joint.shape[0] > 0.8 * run.obs_z.shape[0]
    assert sorted(f.labels.tolist()) == np.unique(run.obs_label).tolist()


def test_standard_ekf_is_overconfident_where_fej_is_not(two_loop_run):
    """The reference's inconsistency (§6.1.2) shows in NEES: over two loops the standard
    EKF's mean pose NEES exceeds FEJ's (same data)."""
    spec = get_experiment("dense-loop")
    std = run_once(spec, "aekf", 11, {"preset": "reference"}, sim_run=two_loop_run)
    fej = run_once(
        spec, "aekf", 11, {"preset": "reference", "jacobians": "fej"}, sim_run=two_loop_run
    )
    assert np.nanmean(fej.nees) < np.nanmean(std.nees)
    assert fej.frac_in_3sigma >= std.frac_in_3sigma


def test_state_reduction_removes_a_corrupted_landmark(two_loop_run):
    """A spurious landmark planted on the path is predicted inside the footprint, never
    re-observed, and removed after max_misses scans; the real ones stay."""
    run = two_loop_run
    f = AEKFSlam(preset="reference", max_misses=5)
    f.predict(run.odometry(0))
    f.update(run.observations(0))
    n0 = f.n_landmarks
    f.update_arrays([[15.0, 0.0]], run.R)  # ghost straight ahead
    assert f.n_landmarks == n0 + 1
    for i in range(1, 12):
        f.predict(run.odometry(i))
        f.update(run.observations(i))
    assert f.n_removed == 1
    assert -1 not in f.labels.tolist()


def test_factory_builds_estimators_and_rejects_unknown():
    assert isinstance(make_estimator("aekf", reject_gate=4.0), AEKFSlam)
    fs = make_estimator("fastslam2", n_particles=5, rng=np.random.default_rng(0))
    assert fs.name == "fastslam2"
    with pytest.raises(ValueError, match="allowed: aekf, fastslam2, isam2"):
        make_estimator("ukf")


@pytest.mark.slow
def test_fifty_run_average_nees_fej_known_association_dense_loop():
    """50 Monte Carlo runs of the full dense loop (dt 0.025): the time-mean of the average
    pose NEES of FEJ with known association lies inside the 95 % bounds for n = 3, 50 runs
    ([2.36, 3.72]); the standard EKF's does not (measured 22.4 with gated association)."""
    from slam.experiments import run_monte_carlo

    spec = get_experiment("dense-loop")
    mc = run_monte_carlo(
        spec, "aekf", runs=50, seed=0, estimator_params={"jacobians": "fej", "association": "known"}
    )
    lo, hi = mc.nees_bounds
    assert lo <= float(np.nanmean(mc.avg_nees)) <= hi
    assert mc.nees_frac_inside > 0.7


@pytest.mark.slow
@pytest.mark.parametrize("dt", [0.025, 0.0125])
def test_fifty_run_average_nees_consistent_preset_gated_association(dt):
    """50 Monte Carlo runs of the full dense loop with gated ML association (no labels) and
    the "consistent" preset: the time-mean of the average pose NEES lies inside the 95 %
    bounds for n = 3, 50 runs ([2.36, 3.72]; measured 3.25 at dt 0.025, 2.82 at 0.0125),
    the median landmark RMSE is below 1 m at the thesis's dt 0.0125 (measured 0.76 m), and
    at most 2 of 50 runs duplicate a landmark (measured 1 and 1)."""
    from slam.experiments import run_monte_carlo

    spec = get_experiment("dense-loop", dt=dt)
    mc = run_monte_carlo(spec, "aekf", runs=50, seed=0, estimator_params={"preset": "consistent"})
    lo, hi = mc.nees_bounds
    assert lo <= float(np.nanmean(mc.avg_nees)) <= hi
    assert mc.nees_frac_inside > 0.8
    assert sum(r.n_duplicates > 0 for r in mc.runs) <= 2
    if dt == 0.0125:
        assert np.median([r.landmark_rmse for r in mc.runs]) < 1.0


def test_factory_isam2_without_gtsam_names_the_extra(monkeypatch):
    """With gtsam unimportable, asking for iSAM2 fails with the install hint."""
    import sys

    monkeypatch.setitem(sys.modules, "gtsam", None)
    monkeypatch.delitem(sys.modules, "slam.estimators.isam2", raising=False)
    with pytest.raises(ImportError, match="baselines"):
        make_estimator("isam2")


def test_default_aekf_is_the_consistent_preset_and_reference_stays_available():
    """Issue 12: ``make_estimator("aekf")`` without a preset is the consistent filter
    (FEJ + JCBB + iterated closures, AEKF_PRESETS["consistent"]); Bailey's filter is
    ``preset="reference"`` (the AEKFConfig defaults); keywords override the preset."""
    from slam.estimators.aekf import AEKF_PRESETS, AEKFConfig

    d = make_estimator("aekf").config
    for k, v in AEKF_PRESETS["consistent"].items():
        assert getattr(d, k) == v
    assert make_estimator("aekf", preset="reference").config == AEKFConfig()
    assert make_estimator("aekf", iterations=1).config.jacobians == "fej"
    assert make_estimator("aekf", iterations=1).config.iterations == 1
