"""FastSLAM 2.0 and iSAM2 on the same loop data: a tiny seeded circle scenario generated here
and the reference's dense-loop map from ``slam.sim2d`` (first loop in CI, two loops slow).

Bounds and why:
* SLAM must map better than dead reckoning: each estimator's landmark RMSE must be below
  the RMSE of the map built by placing every landmark from the dead-reckoned pose of its
  last sighting, computed from the same odometry and observations.
* iSAM2 is a (nearly) consistent smoother: at least 90 % of its landmarks must lie inside
  their 99 % (χ²₂ = 9.21) marginal ellipse; its association must neither duplicate nor
  (beyond the ambiguous-zone discards) miss landmarks.
* FastSLAM 2.0 with 100 particles is known to be inconsistent (Bailey, Nieto and Nebot,
  ICRA 2006); on the dense loop its bar is the reference's own FastSLAM 2.0 result (thesis
  Table 6.1: 7.5 m and 10.0 m errors for landmarks A and B).
"""

import importlib.util

import numpy as np
import pytest

from slam.estimators.fastslam2 import FastSLAM2
from slam.estimators.isam2 import ISAM2SLAM
from slam.experiments import runner
from slam.sim2d import Sim2DConfig, dense_loop_map, simulate_run
from slam.types import Odometry, RangeBearing, wrap_angle

HAVE_GTSAM = importlib.util.find_spec("gtsam") is not None

CHI2_2DOF_99 = 9.21


def circle_scenario(seed: int, n_loops: float = 1.25):
    """Vehicle on a circle of radius 30 m at 3 m/s, dt 0.1 s, 12 landmarks 10 m inside and
    outside the circle; odometry noise σ_v 0.3 m/s, σ_lateral 0.02 m/s, σ_ω 3°/s;
    range-bearing sensor 30 m forward half-disc, σ_r 0.1 m, σ_b 1°, a scan every 3 steps.
    Returns (landmarks (12, 2), truth poses at scans (S, 3), [(odometry list, observations)])."""
    rng = np.random.default_rng(seed)
    radius, speed, dt = 30.0, 3.0, 0.1
    ang = np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
    rad = np.where(np.arange(12) % 2 == 0, radius - 10.0, radius + 10.0)
    lm = np.stack([rad * np.cos(ang), radius + rad * np.sin(ang)], axis=1)
    omega = speed / radius
    Q = np.diag([(0.3 * dt) ** 2, (0.02 * dt) ** 2, (np.deg2rad(3.0) * dt) ** 2])
    R = np.diag([0.1**2, np.deg2rad(1.0) ** 2])
    x = np.zeros(3)
    scans, truth, odos = [], [], []
    n_steps = round(n_loops * 2 * np.pi / omega / dt)
    for k in range(n_steps):
        u = np.array([speed * dt, 0.0, omega * dt])
        odos.append(Odometry(u + rng.multivariate_normal(np.zeros(3), Q), Q))
        c, s = np.cos(x[2]), np.sin(x[2])
        x = np.array([x[0] + u[0] * c, x[1] + u[0] * s, float(wrap_angle(x[2] + u[2]))])
        if (k + 1) % 3:
            continue
        d = lm - x[:2]
        r = np.hypot(d[:, 0], d[:, 1])
        b = wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - x[2])
        obs = []
        for i in np.nonzero((r < 30.0) & (np.abs(b) < np.pi / 2))[0]:
            z = np.array([r[i], b[i]]) + rng.multivariate_normal(np.zeros(2), R)
            obs.append(RangeBearing([z[0], float(wrap_angle(z[1]))], R, label=int(i)))
        scans.append((odos, obs))
        truth.append(x.copy())
        odos = []
    return lm, np.array(truth), scans


def dead_reckoning_map_rmse(landmarks, scans) -> float:
    """RMSE of the map from dead reckoning: each landmark placed from its last sighting."""
    x = np.zeros(3)
    last = {}
    for odos, obs in scans:
        for o in odos:
            d = o.delta
            c, s = np.cos(x[2]), np.sin(x[2])
            x = np.array([x[0] + d[0] * c - d[1] * s, x[1] + d[0] * s + d[1] * c, x[2] + d[2]])
        for ob in obs:
            a = x[2] + ob.z[1]
            last[ob.label] = x[:2] + ob.z[0] * np.array([np.cos(a), np.sin(a)])
    labs = sorted(last)
    err = np.array([last[i] for i in labs]) - landmarks[labs]
    return float(np.sqrt(np.mean(np.sum(err**2, axis=1))))


def run_estimator(est, scans):
    for odos, obs in scans:
        for o in odos:
            est.predict(o)
        if obs:
            res = est.update(obs)
            assert res.associations.shape == (len(obs),)
    return est


def nearest_errors(est_lm, true_lm):
    """Distance from each true landmark to its nearest estimate, and that estimate's index."""
    d = np.linalg.norm(est_lm[:, None] - true_lm[None], axis=2)
    j = d.argmin(axis=0)
    return d[j, np.arange(true_lm.shape[0])], j


@pytest.fixture(scope="module")
def circle_ml_run():
    """FastSLAM 2.0 with its default (maximum-likelihood) association driven over
    ``circle_scenario(seed)``, made once per module: the circle tests below check the same
    run (rng ``default_rng(seed)``) for different things."""
    done = {}

    def get(seed: int):
        if seed not in done:
            _, _, scans = circle_scenario(seed)
            done[seed] = run_estimator(FastSLAM2(rng=np.random.default_rng(seed)), scans)
        return done[seed]

    return get


def _estimators(seed, circle_ml_run):
    """(name, estimator already driven over ``circle_scenario(seed)``)."""
    _, _, scans = circle_scenario(seed)
    known = FastSLAM2(rng=np.random.default_rng(seed), association="known")
    ests = [("fastslam2-known", run_estimator(known, scans))]
    ests.append(("fastslam2-ml", circle_ml_run(seed)))
    if HAVE_GTSAM:  # the optional baselines extra
        ests.append(("isam2-ml", run_estimator(ISAM2SLAM(), scans)))
    return ests


@pytest.mark.parametrize("seed", [0, 1])
def test_circle_loop_both_estimators_map_better_than_dead_reckoning(seed, circle_ml_run):
    lm, _, scans = circle_scenario(seed)
    dr = dead_reckoning_map_rmse(lm, scans)
    for name, est in _estimators(seed, circle_ml_run):
        M, C = est.landmarks()
        assert np.all(np.isfinite(M)) and np.all(np.isfinite(C)), name
        err, j = nearest_errors(M, lm)
        rmse = float(np.sqrt(np.mean(err**2)))
        assert rmse < dr, f"{name}: landmark RMSE {rmse:.2f} m not below dead reckoning {dr:.2f} m"
        assert M.shape[0] == 12, name  # FastSLAM ML: the loop-closure allowance re-associates
        if name == "isam2-ml":
            d = M[j] - lm
            md2 = np.einsum("ni,nij,nj->n", d, np.linalg.inv(C[j]), d)
            assert np.mean(md2 < CHI2_2DOF_99) >= 0.9
        if name.startswith("fastslam2"):
            w = est.weights
            assert np.all(np.isfinite(w)) and w.sum() == pytest.approx(1.0)


def _dense_loop_run(n_loops: int, seed: int):
    try:
        m = dense_loop_map()
    except (FileNotFoundError, OSError) as exc:  # pragma: no cover - map file missing
        pytest.skip(f"dense loop map unavailable: {exc}")
    cfg = Sim2DConfig(n_loops=n_loops)
    return simulate_run(m.landmarks, m.waypoints, cfg, np.random.default_rng(seed))


def _drive(est, run):
    for i in range(run.n_scans):
        est.predict(run.odometry(i))
        est.update(run.observations(i))
    return est


def _dense_dead_reckoning_rmse(run) -> float:
    x = np.zeros(3)
    last = {}
    for i in range(run.n_scans):
        d = run.odom_u[i]
        c, s = np.cos(x[2]), np.sin(x[2])
        x = np.array([x[0] + d[0] * c - d[1] * s, x[1] + d[0] * s + d[1] * c, x[2] + d[2]])
        z, lab = run.scan(i)
        for zz, ll in zip(z, lab):
            a = x[2] + zz[1]
            last[int(ll)] = x[:2] + zz[0] * np.array([np.cos(a), np.sin(a)])
    labs = sorted(last)
    err = np.array([last[i] for i in labs]) - run.landmarks[labs]
    return float(np.sqrt(np.mean(np.sum(err**2, axis=1))))


def test_dense_loop_first_loop_fastslam2_and_isam2_run_the_same_data():
    """CI variant on the reference's dense-loop map (Bailey's simulator, first loop, seed 0).
    FastSLAM 2.0 (known association, like the reference's run) maps all seen landmarks with
    an RMSE below the reference's FastSLAM error for landmark B (10.0 m); iSAM2 (unknown
    association) is consistent (>= 90 % inside the 99 % ellipse), duplicates nothing and
    keeps >= 90 % of the seen landmarks (the rest fall in the ambiguous zone between gates)."""
    run = _dense_loop_run(1, 0)
    seen = np.unique(run.obs_label)
    fs = _drive(FastSLAM2(rng=np.random.default_rng(1), association="known"), run)
    M, C = fs.landmarks()
    assert np.array_equal(np.sort(fs.labels), seen)
    err = np.linalg.norm(M - run.landmarks[fs.labels], axis=1)
    assert np.all(np.isfinite(C))
    assert np.sqrt(np.mean(err**2)) < 10.0
    w = fs.weights
    assert np.all(np.isfinite(w)) and w.sum() == pytest.approx(1.0)

    pytest.importorskip("gtsam", reason="iSAM2 needs the undersea[baselines] extra")
    est = _drive(ISAM2SLAM(), run)
    M, C = est.landmarks()
    assert 0.9 * seen.size <= M.shape[0] <= seen.size
    # consistency: each estimate against its nearest true landmark
    d = np.linalg.norm(M[:, None] - run.landmarks[None, seen], axis=2)
    t = d.argmin(axis=1)
    assert np.unique(t).size == M.shape[0], "two estimates claim the same true landmark"
    e = M - run.landmarks[seen][t]
    md2 = np.einsum("ni,nij,nj->n", e, np.linalg.inv(C), e)
    assert np.mean(md2 < CHI2_2DOF_99) >= 0.9


@pytest.mark.slow
def test_dense_loop_two_loops_five_seeds():
    """Full dense-loop runs (2 loops, seeds 0-4, unknown association for iSAM2, known for
    FastSLAM 2.0 as in the reference's run):
    * iSAM2: median landmark RMSE below the 1 m the issue sets for the AEKF; every run below
      dead reckoning and with >= 90 % of landmarks inside their 99 % ellipse; at most one
      duplicated landmark per run (a true re-observation at loop closure can exceed the
      linearized augment gate: NIS 25.5 was seen).
    * FastSLAM 2.0 (100 particles): median RMSE below the median dead-reckoning map RMSE
      (single runs can be worse: particle depletion makes it inconsistent, and its run-to-run
      spread is large, 2-14 m over the runner's seeds 0-11); valid weights in every run."""
    pytest.importorskip("gtsam", reason="iSAM2 needs the undersea[baselines] extra")
    fs_rmse, is_rmse, dr_rmse = [], [], []
    for seed in range(5):
        run = _dense_loop_run(2, seed)
        seen = np.unique(run.obs_label)
        dr = _dense_dead_reckoning_rmse(run)
        dr_rmse.append(dr)
        fs = _drive(FastSLAM2(rng=np.random.default_rng(seed + 100), association="known"), run)
        M, _ = fs.landmarks()
        fs_rmse.append(np.sqrt(np.mean(np.sum((M - run.landmarks[fs.labels]) ** 2, axis=1))))
        assert np.all(np.isfinite(fs.weights))
        est = _drive(ISAM2SLAM(), run)
        M, C = est.landmarks()
        assert seen.size - 1 <= M.shape[0] <= seen.size + 1
        err, _ = nearest_errors(M, run.landmarks[seen])
        is_rmse.append(np.sqrt(np.mean(err**2)))
        assert is_rmse[-1] < dr
        t = np.linalg.norm(M[:, None] - run.landmarks[None, seen], axis=2).argmin(axis=1)
        e = M - run.landmarks[seen][t]
        md2 = np.einsum("ni,nij,nj->n", e, np.linalg.inv(C), e)
        assert np.mean(md2 < CHI2_2DOF_99) >= 0.9
    assert np.median(is_rmse) < 1.0, is_rmse
    assert np.median(fs_rmse) < np.median(dr_rmse), (fs_rmse, dr_rmse)


def test_circle_ml_loop_closure_allowance_reassociates_where_plain_gating_duplicates(
    circle_ml_run,
):
    """Maximum-likelihood association per particle on the circle world (1.25 loops, seeds
    0-3). Independent expectation: the map has exactly the 12 true landmarks. With the
    loop-closure allowance (default ``loop_drift_100m``) every run re-associates the first
    landmarks; with it switched off (plain gates on the particle's predict covariance) the
    same data duplicate them in at least 3 of the 4 runs, which shows what the allowance
    fixes (measured: 12 landmarks in 16/16 runs at 1.25 and 2 loops with it, duplicates in
    14/16 without)."""
    dup_without = 0
    for seed in range(4):
        lm, _, scans = circle_scenario(seed)
        dr = dead_reckoning_map_rmse(lm, scans)
        f = circle_ml_run(seed)
        M, _ = f.landmarks()
        assert M.shape[0] == 12, f"seed {seed}: {M.shape[0]} landmarks"
        err, j = nearest_errors(M, lm)
        assert np.unique(j).size == 12  # one estimate per true landmark
        assert np.sqrt(np.mean(err**2)) < dr
        g = run_estimator(FastSLAM2(rng=np.random.default_rng(seed), loop_drift_100m=0.0), scans)
        dup_without += g.landmarks()[0].shape[0] > 12
    assert dup_without >= 3


def _runner_rmse(seeds, params):
    spec = runner.get_experiment("dense-loop", dt=0.025)
    out = []
    for seed in seeds:
        r = runner.run_once(spec, "fastslam2", seed, params)
        assert np.isfinite(r.landmark_rmse) and np.all(np.isfinite(r.nees))
        out.append(r)
    return out


def test_dense_loop_known_association_default_within_baileys_median():
    """CI variant of the next test (3 of its 5 runs, ~3 runs' CPU instead of 10): dense
    loop, 2 loops, dt 0.025 s, 100 particles, known association with the DEFAULT
    parameters, the runner's seeds 0-2 (the first three, not picked). Independent
    expectation: Tim Bailey's FastSLAM 2.0 (Octave) reaches a median landmark RMSE of
    3.39 m over its 15 finite runs of 20 (REFERENCE.md); the median of these three runs
    must be below it (measured 2.68 m: 2.68, 1.91, 5.11 m), with no duplicated landmark
    and finite NEES in every scan. Three runs give a noisier median than five (one run
    of three above 3.4 m is allowed, two are not); the comparison with Bailey's
    resampling rule on the same data needs all five seeds and is in the slow test."""
    ours = _runner_rmse(range(3), {"association": "known"})
    med = float(np.median([r.landmark_rmse for r in ours]))
    assert med < 3.4, [r.landmark_rmse for r in ours]
    assert all(r.n_duplicates == 0 for r in ours)


@pytest.mark.slow
def test_dense_loop_known_association_default_beats_baileys_median():
    """Dense loop, 2 loops, dt 0.025 s, 100 particles, known association with the DEFAULT
    parameters, the runner's seeds 0-4 (the CLI's data). Independent expectations: Tim
    Bailey's FastSLAM 2.0 (Octave) reaches a median landmark RMSE of 3.39 m over its 15
    finite runs of 20 (REFERENCE.md), and the same filter with Bailey's resampling rule
    (N_eff < 75) on the same data does worse (4.9 m median on these seeds, 6.25 m over
    20) — the known-association default never resamples: the log-weighted particles stay
    the path hypotheses the loop closure chooses among. Its pose covariance stays positive
    definite (finite NEES in every scan)."""
    ours = _runner_rmse(range(5), {"association": "known"})
    bailey = _runner_rmse(range(5), {"association": "known", "resample_threshold": 0.75})
    med = float(np.median([r.landmark_rmse for r in ours]))
    med_b = float(np.median([r.landmark_rmse for r in bailey]))
    assert med < 3.4, med
    assert med < med_b, (med, med_b)
    assert all(r.n_duplicates == 0 for r in ours)


def _merged_or_duplicated(r) -> bool:
    """A run whose final map is not one estimate per true landmark ever observed: the
    runner's one-to-one assignment (50 m gate) against the simulator's landmarks left an
    estimate unmatched (duplicate) or a true landmark without estimate (two merged, or one
    never mapped)."""
    return r.n_duplicates > 0 or r.n_missed > 0


def test_dense_loop_ml_association_neither_merges_nor_duplicates_where_it_did():
    """CI version of the 20-run check: maximum-likelihood association (defaults) on the
    dense-loop run (seed 20 of the tuning seeds 20-39) where a landmark first seen at the
    loop's end was discarded as ambiguous for all its 65 sightings — its NIS against an
    old landmark 20 m away, with the loop-closure allowance (σ ≈ 11 m), lay between the
    reject gate and the augment gate (9-26) — so the map ended with 29 of 30 landmarks.
    With ``loop_augment_gate`` it is a new landmark. Independent expectation: the
    simulator's landmarks, one estimate each (fails on the code before the gate)."""
    runs = _runner_rmse([20], {})
    assert not any(_merged_or_duplicated(r) for r in runs), [
        (r.seed, r.n_duplicates, r.n_missed) for r in runs
    ]


@pytest.mark.slow
def test_dense_loop_twenty_runs_known_and_ml():
    """The issue's 20-run checks (seeds 0-19, dt 0.025 s, 100 particles), a few minutes:
    known association with the default parameters (no resampling): median landmark RMSE
    <= 3.4 m (Bailey's median) with valid weights and finite NEES in every run;
    maximum-likelihood association (default 75 % resampling rule) re-associates at loop
    closure with no run that duplicates or merges a landmark (independent expectation:
    the simulator's landmarks, one estimate each; before ``loop_augment_gate`` 2 of these
    20 runs lost a landmark, before the loop-closure allowance all 20 duplicated ~29)."""
    known = _runner_rmse(range(20), {"association": "known"})
    assert float(np.median([r.landmark_rmse for r in known])) <= 3.4
    ml = _runner_rmse(range(20), {})
    bad = [(r.seed, r.n_duplicates, r.n_missed) for r in ml if _merged_or_duplicated(r)]
    assert not bad, bad
