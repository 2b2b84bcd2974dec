"""FastSLAM 2.0 step by step against independent answers.

Expectations come from: a batch linear Kalman filter (information form) for a static
vehicle; a joint 5-state EKF for the FastSLAM 2.0 proposal; finite-difference Jacobians for
the prediction; float64 underflow limits for the log-weight test.
"""

import numpy as np
import pytest
from slam_reference_models import R_DEFAULT, WELL_SEPARATED_LANDMARKS, drive_well_separated
from slam_reference_models import motion as _motion
from slam_reference_models import num_jac as _num_jac
from slam_reference_models import range_bearing as _h

from slam.estimators.base import SlamEstimator
from slam.estimators.fastslam2 import FastSLAM2, FastSLAM2Config, observation_model
from slam.types import Odometry, RangeBearing, wrap_angle


def _state(f: FastSLAM2):
    return [a.copy() for a in (f._xv, f._Pv, f._logw, f._m, f._P, f._exists, f._count)]


def test_is_a_slam_estimator():
    assert isinstance(FastSLAM2(n_particles=3, seed=0), SlamEstimator)


def test_observation_jacobians_match_finite_differences():
    x = np.array([1.0, -2.0, 0.7])
    m = np.array([6.0, 3.0])
    _, Hv, Hf = observation_model(x, m)
    np.testing.assert_allclose(Hv, _num_jac(lambda p: _h(p, m), x), atol=1e-7)
    np.testing.assert_allclose(Hf, _num_jac(lambda q: _h(x, q), m), atol=1e-7)


def test_predict_mean_is_the_thesis_model_and_cov_uses_finite_difference_jacobians():
    x0 = np.array([2.0, 1.0, 0.9])
    P0 = np.diag([0.3, 0.2, 0.05])
    u = np.array([1.5, 0.2, 0.1])
    Q = np.diag([0.01, 0.004, 0.002])
    f = FastSLAM2(n_particles=4, seed=0, x0=x0, P0=P0)
    f.predict(Odometry(u, Q))
    Jx = _num_jac(lambda p: _motion(p, u), x0)
    Ju = _num_jac(lambda q: _motion(x0, q), u)
    for i in range(4):
        np.testing.assert_allclose(f._xv[i], _motion(x0, u), atol=1e-12)
        np.testing.assert_allclose(f._Pv[i], Jx @ P0 @ Jx.T + Ju @ Q @ Ju.T, atol=1e-9)
    x, P = f.pose()  # identical particles: the mixture is the single Gaussian
    np.testing.assert_allclose(x, _motion(x0, u), atol=1e-12)
    np.testing.assert_allclose(P, Jx @ P0 @ Jx.T + Ju @ Q @ Ju.T, atol=1e-9)


def test_static_vehicle_landmark_equals_batch_linear_kalman_filter():
    """Known pose, 400 observations of one landmark: each particle's landmark EKF must equal
    the information-form linear KF (linearized at the truth) with an uninformative prior:
    P = (n HᵀR⁻¹H)⁻¹, m = m_true + P Σ HᵀR⁻¹ (z_i − h(m_true))."""
    rng = np.random.default_rng(11)
    m_true = np.array([8.0, 6.0])
    x = np.zeros(3)
    f = FastSLAM2(n_particles=5, rng=np.random.default_rng(1), association="known")
    zs = []
    for _ in range(400):
        z = _h(x, m_true) + rng.multivariate_normal(np.zeros(2), R_DEFAULT)
        zs.append(z)
        res = f.update([RangeBearing(z, R_DEFAULT, label=7)])
    assert res.associations.tolist() == [0] and not res.new[0]
    _, _, H = observation_model(x, m_true)
    Ri = np.linalg.inv(R_DEFAULT)
    info = len(zs) * H.T @ Ri @ H
    P_kf = np.linalg.inv(info)
    innov = np.array(zs) - _h(x, m_true)
    innov[:, 1] = wrap_angle(innov[:, 1])
    m_kf = m_true + P_kf @ (H.T @ Ri @ innov.sum(axis=0))
    M, C = f.landmarks()
    assert M.shape == (1, 2)
    np.testing.assert_allclose(C[0], P_kf, rtol=0.02)
    sigma = np.sqrt(np.linalg.eigvalsh(P_kf).min())
    assert np.linalg.norm(M[0] - m_kf) < 0.05 * sigma
    # every particle holds the same landmark (the pose is exact, so no sampling spread)
    np.testing.assert_allclose(f._m[:, 0], np.broadcast_to(M[0], (5, 2)), atol=1e-12)
    assert f.landmark_labels().tolist() == [7]


def test_proposal_samples_the_joint_ekf_pose_posterior():
    """FastSLAM 2.0 samples x ~ p(x | x_{k-1}, u, z, m). With identical particles and a
    known landmark this Gaussian is the pose marginal of a joint [pose, landmark] EKF update;
    4000 samples must reproduce its mean (4 standard errors) and covariance (10 %)."""
    n = 4000
    f = FastSLAM2(n_particles=n, rng=np.random.default_rng(5), association="known")
    m_true = np.array([10.0, 4.0])
    z0 = _h(np.zeros(3), m_true)
    f.update([RangeBearing(z0, R_DEFAULT, label=1)])  # exact pose: landmark from z0
    Pf = f._P[0, 0].copy()
    mf = f._m[0, 0].copy()
    u = np.array([2.0, 0.0, 0.05])
    Q = np.diag([0.2**2, 0.1**2, np.deg2rad(4.0) ** 2])
    f.predict(Odometry(u, Q))
    xp, Pp = f._xv[0].copy(), f._Pv[0].copy()
    z1 = np.array([8.3, -0.25])
    f.update([RangeBearing(z1, R_DEFAULT, label=1)])
    # second implementation: joint EKF on s = [x, y, phi, mx, my]
    s = np.concatenate([xp, mf])
    Ps = np.zeros((5, 5))
    Ps[:3, :3], Ps[3:, 3:] = Pp, Pf
    zhat = _h(s[:3], s[3:])
    H = _num_jac(lambda q: _h(q[:3], q[3:]), s)
    S = H @ Ps @ H.T + R_DEFAULT
    K = Ps @ H.T @ np.linalg.inv(S)
    v = z1 - zhat
    v[1] = wrap_angle(v[1])
    s_post = s + K @ v
    P_post = (np.eye(5) - K @ H) @ Ps
    x_exp, P_exp = s_post[:3], P_post[:3, :3]
    assert f.n_resamples == 0  # identical particles, equal weights
    samples = f.particle_poses
    se = np.sqrt(np.diag(P_exp) / n)
    assert np.all(np.abs(samples.mean(axis=0) - x_exp) < 4 * se)
    C = np.cov(samples.T)
    np.testing.assert_allclose(np.sqrt(np.diag(C)), np.sqrt(np.diag(P_exp)), rtol=0.1)
    # the proposal really samples: the spread is the posterior's, not zero and not the prior's
    assert np.linalg.det(C) < 0.5 * np.linalg.det(Pp)
    assert np.linalg.det(C) > 0.7 * np.linalg.det(P_exp)
    # pose() is the Rao-Blackwellized estimate: the proposal Gaussian itself, which for
    # identical particles is exactly the joint EKF posterior (not the sample spread)
    x_rb, P_rb = f.pose()
    np.testing.assert_allclose(x_rb, x_exp, atol=1e-9)
    np.testing.assert_allclose(P_rb, P_exp, atol=1e-9)


def _loop_filter(n=50, seed=0, **kw):
    """A filter that has mapped two landmarks with some pose uncertainty."""
    f = FastSLAM2(n_particles=n, rng=np.random.default_rng(seed), association="known", **kw)
    lms = np.array([[10.0, 3.0], [12.0, -4.0]])
    rng = np.random.default_rng(seed + 100)
    x = np.zeros(3)
    Q = np.diag([0.05**2, 0.02**2, np.deg2rad(1.0) ** 2])
    for _ in range(5):
        obs = [
            RangeBearing(
                _h(x, lm) + rng.multivariate_normal(np.zeros(2), R_DEFAULT), R_DEFAULT, label=i
            )
            for i, lm in enumerate(lms)
        ]
        f.update(obs)
        u = np.array([0.5, 0.0, 0.0])
        x = _motion(x, u)
        f.predict(Odometry(u + rng.multivariate_normal(np.zeros(3), Q), Q))
    return f, lms, x


def test_huge_innovation_keeps_log_weights_finite_and_normalized():
    """A loop-closure-like observation 60 m off: its NIS is so large that exp(-NIS/2)
    underflows to exactly 0 in float64 for every particle (so linear weights, as in Bailey's
    MATLAB code, would all be zero); the log-form weights must stay a valid distribution."""
    f, lms, x = _loop_filter()
    z = _h(x, lms[0]) + np.array([60.0, 0.0])
    res = f.update([RangeBearing(z, R_DEFAULT, label=0)])
    assert res.nis[0] > 2 * 745.0  # exp(-nis/2) < 1e-323: linear weights all underflow
    w = f.weights
    assert np.all(np.isfinite(w)) and np.all(w >= 0) and w.sum() == pytest.approx(1.0)
    assert np.all(np.isfinite(f.log_weights))
    x_est, P = f.pose()
    assert np.all(np.isfinite(x_est)) and np.all(np.isfinite(P))
    M, C = f.landmarks()
    assert np.all(np.isfinite(M)) and np.all(np.isfinite(C))


def test_unknown_association_matches_well_separated_landmarks_without_duplicates():
    """Landmarks >= 10 m apart, σ_r 0.1 m: every unlabelled re-observation must either land on
    the slot its first sighting created or be discarded between the gates (NIS in [4, 25],
    which a correct χ²₂ match does with probability e⁻² ≈ 13.5 %); never a wrong landmark,
    never a duplicate."""
    lms = WELL_SEPARATED_LANDMARKS
    f = FastSLAM2(n_particles=30, rng=np.random.default_rng(4))
    first, n_matched, n_discarded = drive_well_separated(f)
    assert n_discarded <= 0.25 * (n_matched + n_discarded)
    M, _ = f.landmarks()
    assert M.shape == (4, 2)
    assert np.all(f._count == 4)  # no particle created a duplicate
    assert np.all(f.landmark_labels() == -1)
    err = np.linalg.norm(M[[first[i] for i in range(4)]] - lms, axis=1)
    assert np.all(err < 0.5)


def test_between_the_gates_the_observation_is_discarded():
    """NIS between reject_gate and augment_gate: neither matched nor a new landmark."""
    f = FastSLAM2(n_particles=5, rng=np.random.default_rng(0))
    f.update([RangeBearing([10.0, 0.0], R_DEFAULT)])
    P = f._P[0, 0]
    _, _, Hf = observation_model(np.zeros(3), f._m[0, 0])
    S = Hf @ P @ Hf.T + R_DEFAULT
    # choose a range offset giving NIS = 10 (between 4 and 25)
    dr = np.sqrt(10.0 / np.linalg.inv(S)[0, 0])
    res = f.update([RangeBearing([10.0 + dr, 0.0], R_DEFAULT)])
    assert res.associations.tolist() == [-1] and not res.new[0]
    assert f.landmarks()[0].shape == (1, 2)


def test_same_seed_same_result_and_rng_is_the_only_randomness():
    a, _, _ = _loop_filter(seed=2)
    np.random.seed(123)  # noqa: NPY002 - the global RNG must not matter
    b, _, _ = _loop_filter(seed=2)
    np.testing.assert_array_equal(a.particle_poses, b.particle_poses)
    c, _, _ = _loop_filter(seed=3)
    assert not np.array_equal(a.particle_poses, c.particle_poses)


def test_resampling_runs_only_when_effective_sample_size_drops_below_75_percent():
    """Particles spread 2 m along x with exact poses: a precise observation gives very unequal
    weights (N_eff << 75), so resampling must run and reset the weights to uniform.
    Identical particles get equal weights (N_eff = N): no resampling. (Bailey's rule, set
    explicitly: with known association the default is never to resample.)"""
    f, lms, x = _loop_filter(n=100, seed=1, resample_threshold=0.75)
    f._xv = np.tile(x, (100, 1))
    f._Pv[:] = 0.0
    f._m[:], f._P[:] = f._m[0], f._P[0]
    obs = [RangeBearing(_h(x, lms[i]), R_DEFAULT, label=i) for i in range(2)]
    before = f.n_resamples
    f.update(obs)
    assert f.n_resamples == before
    f._xv = np.tile(x, (100, 1))
    f._xv[:, 0] += np.linspace(-1.0, 1.0, 100)
    f._Pv[:] = 0.0
    f.update(obs)
    assert f.n_resamples == before + 1
    np.testing.assert_allclose(f.weights, np.full(100, 0.01))


def test_default_resampling_rule_is_bailey_75_percent_except_with_labels():
    """The thesis's and Bailey's rule (resample when N_eff < 75 of 100) by default with
    maximum-likelihood or auto association; with known association the default never
    resamples (0.0); an explicit value wins everywhere. The same very unequal weights as
    above must trigger resampling only where the rule says so."""
    assert FastSLAM2(n_particles=4, seed=0, association="ml")._threshold == 0.75
    assert FastSLAM2(n_particles=4, seed=0, association="auto")._threshold == 0.75
    assert FastSLAM2(n_particles=4, seed=0, association="known")._threshold == 0.0
    assert FastSLAM2Config(association="known").resample_threshold == 0.0
    assert (
        FastSLAM2(n_particles=4, seed=0, association="known", resample_threshold=0.75)._threshold
        == 0.75
    )
    f, lms, x = _loop_filter(n=100, seed=1, resample_threshold=0.0)
    f._xv = np.tile(x, (100, 1))
    f._xv[:, 0] += np.linspace(-1.0, 1.0, 100)
    f._Pv[:] = 0.0
    f._m[:], f._P[:] = f._m[0], f._P[0]
    before = f.n_resamples
    f.update([RangeBearing(_h(x, lms[i]), R_DEFAULT, label=i) for i in range(2)])
    assert f.n_resamples == before
    assert f.effective_sample_size() < 75.0  # it would have resampled under Bailey's rule
    assert np.isclose(f.weights.sum(), 1.0) and np.all(np.isfinite(f.log_weights))


@pytest.mark.parametrize(
    "cov, match",
    [
        (np.diag([0.1, -0.01, 0.1]), "negative variances"),
        (np.array([[1.0, 2.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "semi-definite"),
        (np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), "symmetric"),
    ],
)
def test_bad_odometry_covariance_rejected_state_unchanged(cov, match):
    f, _, _ = _loop_filter(n=10)
    before = _state(f)
    with pytest.raises(ValueError, match=match):
        f.predict(Odometry(np.array([1.0, 0.0, 0.0]), cov))
    for a, b in zip(before, _state(f)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize(
    "bad, match",
    [
        (RangeBearing([5.0, 0.1], np.diag([0.01, 0.0])), "positive definite"),
        (RangeBearing([5.0, 0.1], np.diag([0.01, -1e-4])), "negative variances"),
        ((5.0, 0.1), "RangeBearing"),
        (RangeBearing([5.0, 0.1], R_DEFAULT, label="a"), "label"),
    ],
)
def test_bad_observation_rejected_state_unchanged(bad, match):
    f, lms, x = _loop_filter(n=10)
    before = _state(f)
    rng_state = f.rng.bit_generator.state
    good = RangeBearing(_h(x, lms[0]), R_DEFAULT, label=0)
    with pytest.raises(ValueError, match=match):
        f.update([good, bad])
    for a, b in zip(before, _state(f)):
        np.testing.assert_array_equal(a, b)
    assert f.rng.bit_generator.state == rng_state


def test_zero_range_and_non_finite_inputs_are_rejected_at_the_boundary():
    with pytest.raises(ValueError, match="range"):
        RangeBearing([0.0, 0.1], R_DEFAULT)
    with pytest.raises(ValueError, match="finite"):
        Odometry([np.nan, 0.0, 0.0], np.eye(3))
    with pytest.raises(ValueError, match="single one"):
        FastSLAM2(n_particles=2, seed=0).update(RangeBearing([1.0, 0.0], R_DEFAULT))


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"n_particles": 0}, "n_particles"),
        ({"resample_threshold": 1.5}, "resample_threshold"),
        ({"weighting": "joint"}, "weighting"),
        ({"reject_gate": -1.0}, "reject_gate"),
        ({"augment_gate": 1.0}, "augment_gate"),
        ({"resampler": "multinomial"}, "resampler"),
        ({"map_estimate": "mean"}, "map_estimate"),
        ({"association": "nn"}, "association"),
    ],
)
def test_bad_config_rejected(kw, match):
    with pytest.raises(ValueError, match=match):
        FastSLAM2Config(**kw)
    with pytest.raises(ValueError, match=match):
        FastSLAM2(**kw)


def test_weighted_map_estimate_is_the_mixture_over_particles():
    """With known association, map_estimate='weighted' returns Σ w m_i and Σ w (P_i + d dᵀ)."""
    f, _, _ = _loop_filter(n=40, seed=4)
    g = FastSLAM2(n_particles=40, rng=np.random.default_rng(0), map_estimate="weighted")
    for attr in ("_xv", "_Pv", "_logw", "_m", "_P", "_exists", "_count", "_slot_label"):
        setattr(g, attr, getattr(f, attr).copy())
    w = f.weights
    M, C = g.landmarks()
    mu = np.einsum("i,ijk->jk", w, f._m[:, :2])
    np.testing.assert_allclose(M, mu)
    d = f._m[:, :2] - mu
    np.testing.assert_allclose(
        C,
        np.einsum("i,ijk,ijl->jkl", w, d, d) + np.einsum("i,ijkl->jkl", w, f._P[:, :2]),
        atol=1e-14,
    )


def test_association_modes_use_or_ignore_labels():
    """'ml' ignores labels (two labels on one spot → one landmark), 'known' trusts them (two
    landmarks) and rejects an unlabelled observation, 'auto' uses a label when present."""
    z = [
        RangeBearing([10.0, 0.0], R_DEFAULT, label=1),
        RangeBearing([20.0, 0.5], R_DEFAULT, label=2),
    ]
    again = [RangeBearing([10.0, 0.0], R_DEFAULT, label=5)]
    ml = FastSLAM2(n_particles=3, seed=0)
    ml.update(z)
    assert ml.update(again).associations.tolist() == [0]
    assert ml.labels.tolist() == [-1, -1]
    kn = FastSLAM2(n_particles=3, seed=0, association="known")
    kn.update(z)
    assert kn.update(again).new.tolist() == [True]
    assert kn.labels.tolist() == [1, 2, 5]
    with pytest.raises(ValueError, match="label on every observation"):
        kn.update([RangeBearing([10.0, 0.0], R_DEFAULT)])
    au = FastSLAM2(n_particles=3, seed=0, association="auto")
    au.update(z)
    assert au.update([RangeBearing([10.0, 0.0], R_DEFAULT)]).associations.tolist() == [0]


def test_factory_builds_fastslam2_with_keyword_parameters():
    from slam.estimators import make_estimator

    f = make_estimator("fastslam2", n_particles=7, rng=np.random.default_rng(0), reject_gate=3.0)
    assert isinstance(f, FastSLAM2) and f.n_particles == 7 and f.config.reject_gate == 3.0


def test_importance_weight_is_the_joint_predictive_density_of_the_scan():
    """Observations of one scan share the pose uncertainty: the weight must be the joint
    Gaussian N(z; ẑ, Hv Pv Hvᵀ + blockdiag(Hf Pf Hfᵀ + R)) — checked against
    scipy.stats.multivariate_normal with finite-difference Jacobians — not the product of
    the per-observation densities (which it must differ from here)."""
    from scipy.stats import multivariate_normal

    lms = np.array([[10.0, 3.0], [6.0, -7.0]])
    f = FastSLAM2(
        n_particles=2, rng=np.random.default_rng(0), association="known", resample_threshold=0.0
    )
    f.update([RangeBearing(_h(np.zeros(3), lm), R_DEFAULT, label=i) for i, lm in enumerate(lms)])
    Q = np.diag([0.3**2, 0.2**2, np.deg2rad(5.0) ** 2])
    f.predict(Odometry([1.0, 0.0, 0.0], Q))
    f._xv[1] += np.array([0.4, -0.3, 0.05])
    xs, Pvs = f._xv.copy(), f._Pv.copy()
    ms, Ps = f._m[:, :2].copy(), f._P[:, :2].copy()
    z = np.array([_h(np.array([1.1, 0.1, 0.02]), lm) for lm in lms])
    f.update([RangeBearing(z[i], R_DEFAULT, label=i) for i in range(2)])
    joint, product = [], []
    for p in range(2):
        zhat = np.concatenate([_h(xs[p], ms[p, i]) for i in range(2)])
        Hv = np.vstack([_num_jac(lambda q, i=i, p=p: _h(q, ms[p, i]), xs[p]) for i in range(2)])
        S = Hv @ Pvs[p] @ Hv.T
        for i in range(2):
            Hf = _num_jac(lambda q, i=i, p=p: _h(xs[p], q), ms[p, i])
            S[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] += Hf @ Ps[p, i] @ Hf.T + R_DEFAULT
        v = z.reshape(-1) - zhat
        v[1::2] = wrap_angle(v[1::2])
        joint.append(multivariate_normal(np.zeros(4), S).logpdf(v))
        product.append(
            sum(
                multivariate_normal(np.zeros(2), S[2 * i : 2 * i + 2, 2 * i : 2 * i + 2]).logpdf(
                    v[2 * i : 2 * i + 2]
                )
                for i in range(2)
            )
        )
    lw = f.log_weights
    assert lw[1] - lw[0] == pytest.approx(joint[1] - joint[0], rel=1e-6)
    # the product of marginals would miss the tolerance above by far
    assert abs((product[1] - product[0]) - (joint[1] - joint[0])) > 1e3 * 1e-6 * abs(
        joint[1] - joint[0]
    )


def test_proposal_weighting_is_baileys_2004_sample_weight():
    """``weighting="proposal"`` (Bailey's 2004 fastslam2): after sampling ``xs`` from the
    proposal N(xq, Pq), ``log w += log N(z; h(xs, m), Hf Pf Hfᵀ + R) + log N(xs; x0, Pv0)
    - log N(xs; xq, Pq)``. Checked with scipy.stats.multivariate_normal, finite-difference
    Jacobians and the proposal recomputed independently as a one-observation EKF in
    information form (Bailey's sample_proposal), from each particle's sampled pose."""
    from scipy.stats import multivariate_normal

    lm = np.array([10.0, 3.0])
    f = FastSLAM2(
        n_particles=2,
        rng=np.random.default_rng(0),
        association="known",
        resample_threshold=0.0,
        weighting="proposal",
    )
    f.update([RangeBearing(_h(np.zeros(3), lm), R_DEFAULT, label=0)])
    Q = np.diag([0.3**2, 0.2**2, np.deg2rad(5.0) ** 2])
    f.predict(Odometry([1.0, 0.0, 0.0], Q))
    f._xv[1] += np.array([0.4, -0.3, 0.05])
    x0s, P0s = f._xv.copy(), f._Pv.copy()
    ms, Ps = f._m[:, 0].copy(), f._P[:, 0].copy()
    lw0 = f.log_weights
    z = _h(np.array([1.1, 0.1, 0.02]), lm)
    f.update([RangeBearing(z, R_DEFAULT, label=0)])
    xs = f.particle_poses
    expect = []
    for p in range(2):
        Hv = _num_jac(lambda q, p=p: _h(q, ms[p]), x0s[p])
        Hf = _num_jac(lambda q, p=p: _h(x0s[p], q), ms[p])
        Sf_inv = np.linalg.inv(Hf @ Ps[p] @ Hf.T + R_DEFAULT)
        v = z - _h(x0s[p], ms[p])
        v[1] = wrap_angle(v[1])
        Pq = np.linalg.inv(Hv.T @ Sf_inv @ Hv + np.linalg.inv(P0s[p]))
        xq = x0s[p] + Pq @ Hv.T @ Sf_inv @ v
        Hf_s = _num_jac(lambda q, p=p: _h(xs[p], q), ms[p])
        vs = z - _h(xs[p], ms[p])
        vs[1] = wrap_angle(vs[1])
        like = multivariate_normal(np.zeros(2), Hf_s @ Ps[p] @ Hf_s.T + R_DEFAULT).logpdf(vs)
        prior = multivariate_normal(x0s[p], P0s[p]).logpdf(xs[p])
        prop = multivariate_normal(xq, Pq).logpdf(xs[p])
        expect.append(lw0[p] + like + prior - prop)
    lw = f.log_weights
    assert lw[1] - lw[0] == pytest.approx(expect[1] - expect[0], rel=1e-5, abs=1e-6)
    assert abs(expect[1] - expect[0]) > 1e-2  # not equal weights: the check can fail


def _square_loop_then_drift(loop_drift_100m, offset=(4.0, -3.0, 0.02)):
    """Map A1, A2 at the start, drive a noiseless 150 m square (600 m of path), map and
    re-observe B on the last leg, return to the start, then shift every particle by
    ``offset`` (the drift a loop leaves) and observe A1, A2 from the true start pose."""
    f = FastSLAM2(n_particles=3, rng=np.random.default_rng(4), loop_drift_100m=loop_drift_100m)
    lms = np.array([[10.0, 3.0], [12.0, -4.0]])
    b = np.array([5.0, 30.0])
    Q = np.diag([1e-6, 1e-6, 1e-8])
    x = np.zeros(3)
    f.update([RangeBearing(_h(x, m), R_DEFAULT) for m in lms])
    for leg in range(4):
        for _ in range(100):
            x = _motion(x, np.array([1.5, 0.0, 0.0]))
            f.predict(Odometry([1.5, 0.0, 0.0], Q))
            if leg == 3 and (np.isclose(x[1], 60.0) or np.isclose(x[1], 45.0)):
                f.update([RangeBearing(_h(x, b), R_DEFAULT)])
        x = _motion(x, np.array([0.0, 0.0, np.pi / 2]))
        x[2] = wrap_angle(x[2])
        f.predict(Odometry([0.0, 0.0, np.pi / 2], Q))
    assert np.allclose(x, 0.0, atol=1e-9)
    assert f._count.tolist() == [3, 3, 3]
    f._xv += np.asarray(offset)
    f._xv_rb += np.asarray(offset)
    f.update([RangeBearing(_h(x, m), R_DEFAULT) for m in lms])
    return f, x


def test_ml_loop_closure_reassociates_and_moves_the_pose_onto_the_old_map():
    """After 600 m of path a particle's pose is 5 m off its start landmarks. Independent
    expectation (geometry): the true start pose explains both observations exactly, and two
    range-bearing landmarks fix all 3 pose dof. With the loop-closure allowance the particle
    must associate them (no new landmark), the proposal's mean (the pose estimate) must land
    within 0.3 m / 1 deg of the truth (its prior is the drift, not the few-step predict
    covariance, and the iterated update removes the linearization error of a 5 m step), and
    every sample within 4 sigma of it; without the allowance (plain gates) the 5 m innovation
    is far outside the gate: both become new landmarks and the pose stays 5 m off."""
    f, x = _square_loop_then_drift(0.7)
    assert f._count.tolist() == [3, 3, 3]
    mean, _ = f.pose()
    assert np.hypot(*(mean[:2] - x[:2])) < 0.3
    assert abs(wrap_angle(mean[2] - x[2])) < np.deg2rad(1.0)
    for i in range(3):
        d = f.particle_poses[i] - f._xv_rb[i]
        d[2] = wrap_angle(d[2])
        assert np.all(np.abs(d) < 4.0 * np.sqrt(np.diag(f._Pv_rb[i])))
    g, x = _square_loop_then_drift(0.0)
    assert g._count.tolist() == [5, 5, 5]
    err = g.particle_poses - x
    assert np.all(np.hypot(err[:, 0], err[:, 1]) > 4.5)
