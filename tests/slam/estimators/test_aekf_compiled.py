"""The AEKF's compiled per-scan steps against their NumPy formulation
(``tests/helpers/aekf_numpy_steps.py``, the code they replaced): call by call on random
states, and swapped into the filter for a whole dense-loop run (same associations, same
states to rounding); the input checks against the eigenvalue rule they replaced; and a
seeded run bit-identical run to run."""

from __future__ import annotations

import aekf_numpy_steps as ref
import numpy as np
import pytest

import slam.estimators.aekf as aekf_mod
import slam.estimators.jcbb as jcbb_mod
import slam.estimators.rb_model as rb_mod
from slam.estimators import aekf_kernels as K
from slam.estimators import rb_kernels as RK
from slam.estimators.aekf import AEKFSlam, _check_cov
from slam.experiments import get_experiment
from slam.sim2d import simulate_run

TOL = 1e-12


def _close(got, want, rtol=TOL):
    """Equal to ``rtol`` relative to the array's magnitude (entries near zero are
    sums of large terms: their rounding scales with the array, not with themselves)."""
    got, want = np.asarray(got, float), np.asarray(want, float)
    scale = max(1.0, float(np.abs(want).max()) if want.size else 1.0)
    np.testing.assert_allclose(got, want, rtol=0, atol=rtol * scale)


def _state(rng, n):
    x = np.concatenate([rng.normal(0, 3, 2), [rng.uniform(-3, 3)], rng.normal(0, 25, 2 * n)])
    A = rng.standard_normal((x.size, x.size + 2)) * rng.uniform(0.05, 1.0)
    return x, A @ A.T + 1e-3 * np.eye(x.size)


def _scan(rng, k):
    z = np.column_stack([rng.uniform(2, 30, k), rng.uniform(-3, 3, k)])
    R = np.empty((k, 2, 2))
    for j in range(k):
        B = rng.standard_normal((2, 2)) * [[0.3], [0.03]]
        R[j] = B @ B.T + np.diag([0.01, 1e-4])
    return z, R


def test_predict_equals_numpy(rng):
    for _ in range(200):
        x, P = _state(rng, int(rng.integers(0, 40)))
        u = rng.normal(0, [1.0, 0.3, 0.2])
        B = rng.standard_normal((3, 3)) * 0.1
        Q = B @ B.T
        refpose = x[:3] + rng.normal(0, 0.5, 3)
        xa, Pa, xb, Pb = x.copy(), P.copy(), x.copy(), P.copy()
        K.predict_inplace(xa, Pa, u, Q, refpose)
        ref.predict_inplace(xb, Pb, u, Q, refpose)
        _close(xa, xb)
        _close(Pa, Pb)
        assert np.array_equal(Pa, Pa.T)


def test_update_gain_and_downdate_equal_numpy(rng):
    for _ in range(200):
        n = int(rng.integers(1, 40))
        x, P = _state(rng, n)
        k = int(rng.integers(1, min(n, 5) + 1))
        idx = rng.choice(n, k, replace=False).astype(np.intp)
        z, R = _scan(rng, k)
        xl = x + rng.normal(0, 0.3, x.size) if rng.random() < 0.5 else x
        got = K.ekf_gain(x, P, z, R, idx, xl)
        want = ref.ekf_gain(x, P, z, R, idx, xl)
        assert got[0] and want[0]
        for g, w in zip(got[1:], want[1:], strict=True):
            _close(g, w)
        Pa, Pb = P.copy(), P.copy()
        K.downdate(Pa, got[4])
        ref.downdate(Pb, want[4])
        _close(Pa, Pb)
        assert np.array_equal(Pa, Pa.T)
        xa, xb = x.copy(), x.copy()
        K.add_step(xa, got[5])
        ref.add_step(xb, want[5])
        _close(xa, xb)
        gate = float(rng.uniform(0.0, 2.0))
        step = got[5] * rng.uniform(0, 30)
        assert K.surely_linear(x, step, idx, R, gate) == ref.surely_linear(x, step, idx, R, gate)


def test_gain_reports_indefinite_innovation_covariance():
    x = np.array([0.0, 0.0, 0.0, 10.0, 0.0])
    P = np.zeros((5, 5))
    R = np.zeros((1, 2, 2))  # S = 0: not positive definite
    ok = K.ekf_gain(x, P, np.array([[10.0, 0.0]]), R, np.array([0], np.intp), x)[0]
    assert not ok
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        aekf_mod.update(x, P, [[10.0, 0.0]], R, [0])


def test_association_scores_equal_numpy(rng):
    for _ in range(100):
        n = int(rng.integers(1, 60))
        x, P = _state(rng, n)
        z, R = _scan(rng, int(rng.integers(1, 6)))
        xl = x + rng.normal(0, 0.3, x.size) if rng.random() < 0.5 else x
        nis, nd = RK.nis_scores(x, P, z, R, xl, True)
        nis_ref, nd_ref = ref.nis_scores(x, P, z, R, xl, True)
        np.testing.assert_allclose(nis, nis_ref, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(nd, nd_ref, rtol=1e-10, atol=1e-12)


def test_pair_covariance_and_joint_nis_equal_numpy(rng):
    for _ in range(100):
        n = int(rng.integers(2, 30))
        x, P = _state(rng, n)
        k = int(rng.integers(1, 5))
        z, R = _scan(rng, k)
        c = int(rng.integers(1, min(7, k * n + 1)))  # distinct pairs, as JCBB's candidates are
        flat = rng.choice(k * n, c, replace=False)
        obs, lms = (flat // n).astype(np.intp), (flat % n).astype(np.intp)
        nu, S = RK.pair_covariance(x, P, z, R, obs, lms)
        nu_ref, S_ref = ref.pair_covariance(x, P, z, R, obs, lms)
        _close(nu, nu_ref)
        _close(S, S_ref)
        rows = np.flatnonzero(rng.random(2 * c) < 0.7).astype(np.intp)
        d2, d2_ref = RK.joint_nis(S, nu, rows), ref.joint_nis(S, nu, rows)
        assert (d2 < 0) == (d2_ref < 0)
        if d2_ref >= 0:
            assert d2 == pytest.approx(d2_ref, rel=1e-9, abs=1e-12)


def test_jcbb_outcome_equals_numpy(rng):
    for _ in range(200):
        k, n = int(rng.integers(1, 6)), int(rng.integers(0, 30))
        scores = rng.exponential(20.0, (k, n))
        if n and rng.random() < 0.2:
            scores[0, 0] = 25.0  # exactly at the gate
        pairs = np.where(rng.random(k) < 0.5, rng.integers(0, max(n, 1), k), -1)
        pairs = np.where(n > 0, pairs, -1).astype(np.intp)
        ambiguous = rng.random(k) < 0.2
        got = K.jcbb_outcome(scores, pairs, ambiguous, 25.0)
        want = ref.jcbb_outcome(scores, pairs, ambiguous, 25.0)
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)


def test_jcbb_easy_decides_as_the_python_steps(rng):
    """The compiled pre-search part of JCBB against the Python steps it replaced, on
    scans observing the state's own landmarks (noise of 0.5–3 σ, some pairs of landmarks
    close together so observations have several candidates): same status (decided /
    search / not positive definite), same pairs, same scores and joint NIS; every status
    occurs."""
    from slam.estimators.jcbb import chi2_limits
    from slam.estimators.rb_model import observe

    statuses = set()
    for _ in range(300):
        n = int(rng.integers(0, 12))
        x, P = _state(rng, n)
        P *= 0.05
        if n >= 2 and rng.random() < 0.4:  # a near twin of landmark 0
            x[5:7] = x[3:5] + rng.normal(0, 0.5, 2)
        k = int(rng.integers(0, min(n, 4) + 1)) if n else int(rng.integers(0, 3))
        idx = rng.choice(max(n, 1), k, replace=False) if n else np.zeros(0, np.intp)
        if n:
            zhat, _, _ = observe(x, idx)
            z = zhat + rng.normal(0, 1, (k, 2)) * rng.uniform(0.5, 3.0) * [0.3, 0.02]
        else:
            z = np.column_stack([rng.uniform(2, 30, k), rng.uniform(-3, 3, k)])
        z[:, 0] = np.abs(z[:, 0]) + 0.1
        R = np.broadcast_to(np.diag([0.3**2, 0.02**2]), (k, 2, 2)).copy()
        limits = chi2_limits(0.99, max(k, 1))
        got = RK.jcbb_easy(x, P, z, R, limits[0], limits)
        want = ref.jcbb_easy(x, P, z, R, limits[0], limits)
        statuses.add(got[0])
        assert got[0] == want[0]
        np.testing.assert_array_equal(got[1], want[1])
        np.testing.assert_allclose(got[2], want[2], rtol=1e-10, atol=1e-12)
        assert got[3] == pytest.approx(want[3], rel=1e-9, abs=1e-12)
        assert got[4] == want[4]
    assert statuses >= {0, 1}
    # one candidate each whose joint covariance is indefinite (cross-covariance of the two
    # landmarks beyond their variances): -1 from both, and jcbb raises as it did
    x = np.array([0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 10.0])
    P = np.zeros((7, 7))
    P[3:, 3:] = np.eye(4)
    P[3, 6] = P[6, 3] = 5.0
    P[4, 5] = P[5, 4] = -5.0
    z = np.array([[10.0, 0.0], [10.0, np.pi / 2]])
    R = np.broadcast_to(np.diag([0.01, 1e-4]), (2, 2, 2)).copy()
    limits = chi2_limits(0.99, 2)
    assert RK.jcbb_easy(x, P, z, R, limits[0], limits)[0] == -1
    assert ref.jcbb_easy(x, P, z, R, limits[0], limits)[0] == -1
    with pytest.raises(np.linalg.LinAlgError, match="not positive definite"):
        jcbb_mod.jcbb(x, P, z, R)


def _eig_rule_rejects(C, tol=1e-9):
    """The replaced rule: symmetric part's smallest eigenvalue below -tol * scale."""
    scale = max(1.0, float(np.abs(C).max()))
    return np.linalg.eigvalsh(0.5 * (C + C.T)).min() < -tol * scale


@pytest.mark.parametrize("d", [3, 5])
def test_covariance_check_decides_as_the_eigenvalue_rule(rng, d):
    """Random PSD-or-not matrices with the smallest eigenvalue at multiples of the
    tolerance on both sides of it (the Cholesky test's halved shift sends the band between
    to the eigenvalues): the compiled check accepts and rejects exactly what the eigenvalue
    rule did."""
    for factor in (-100.0, -3.0, -1.2, -0.9, -0.6, -0.4, -0.1, 0.0, 1.0, 1e6):
        for _ in range(30):
            V, _ = np.linalg.qr(rng.standard_normal((d, d)))
            w = rng.uniform(0.1, 50.0, d)
            scale_guess = max(1.0, w.max())
            w[0] = factor * 1e-9 * scale_guess
            C = (V * w) @ V.T
            C = 0.5 * (C + C.T)
            if np.any(np.diag(C) < 0):
                continue
            rejects = _eig_rule_rejects(C)
            if rejects:
                with pytest.raises(ValueError, match="positive semi-definite"):
                    _check_cov("Q", C)
            else:
                _check_cov("Q", C)


@pytest.mark.parametrize(
    ("u", "Q", "match"),
    [
        ([0.1, 0.0, np.nan], np.eye(3), "u .* must be finite"),
        ([0.1, 0.0, 0.0], np.diag([1.0, -1.0, 1.0]), "negative variance"),
        ([0.1, 0.0, 0.0], np.array([[1.0, 0.5, 0], [0.0, 1, 0], [0, 0, 1]]), "symmetric"),
        ([0.1, 0.0, 0.0], np.array([[1.0, 2, 0], [2, 1, 0], [0, 0, 1]]), "semi-definite"),
    ],
)
def test_predict_rejects_bad_odometry_with_the_field_named(u, Q, match):
    f = AEKFSlam()
    with pytest.raises(ValueError, match=match):
        f.predict_arrays(u, Q)
    assert np.array_equal(f.P, np.zeros((3, 3)))


def _dense_loop_run(seed):
    spec = get_experiment("dense-loop")
    ss = np.random.SeedSequence(seed)
    run = simulate_run(
        spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(ss.spawn(2)[0])
    )
    odo = [run.odometry(i) for i in range(run.n_scans)]
    obs = [run.observations(i) for i in range(run.n_scans)]

    def drive():
        f = AEKFSlam(preset="consistent", provisional_misses=3)
        poses, assoc = [], []
        for i in range(run.n_scans):
            f.predict(odo[i])
            assoc.append(f.update(obs[i]).associations)
            poses.append(f.x[:3].copy())
        return f.x.copy(), f.P.copy(), np.array(poses), np.concatenate(assoc)

    return drive


def test_dense_loop_equals_numpy_formulation_and_repeats_bit_identically(monkeypatch):
    """The consistent preset (FEJ, JCBB, iterated loop-closure updates) over the dense
    loop, seed 0: compiled twice (bit-identical), then with every compiled step swapped for
    its NumPy formulation. Same associations in every scan; states equal to rounding
    accumulated over 1,931 scans (each step agrees to ~1e-15)."""
    drive = _dense_loop_run(0)
    a = drive()
    b = drive()
    for u, v in zip(a, b, strict=True):
        assert np.array_equal(u, v)
    for mod, name in [
        (aekf_mod, "predict_inplace"),
        (aekf_mod, "ekf_gain"),
        (aekf_mod, "add_step"),
        (aekf_mod, "downdate"),
        (aekf_mod, "surely_linear"),
        (aekf_mod, "jcbb_outcome"),
        (rb_mod, "nis_scores"),
        (jcbb_mod, "jcbb_easy"),
        (jcbb_mod, "pair_covariance"),
        (jcbb_mod, "joint_nis"),
    ]:
        monkeypatch.setattr(mod, name, getattr(ref, name))
    c = drive()
    assert np.array_equal(a[3], c[3])  # associations, scan by scan
    for u, v in zip(a[:3], c[:3], strict=True):
        _close(u, v, rtol=1e-11)


def test_fej_linearization_state_kept_between_scans_is_the_definition():
    """The FEJ linearization state the filter keeps between scans equals its definition,
    ``[current pose, first landmark estimates]``, after every scan of a run that adds,
    removes (a miss footprint wider than the sensor) and may fuse landmarks."""
    spec = get_experiment("dense-loop")
    ss = np.random.SeedSequence(2)
    run = simulate_run(
        spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(ss.spawn(2)[0])
    )
    f = AEKFSlam(
        preset="consistent",
        provisional_misses=3,
        max_misses=2,
        max_range_m=300.0,  # a footprint wider than the sensor's: unseen landmarks go
        fov_half_angle_rad=np.pi,
        merge_gate=9.0,
        merge_every=5,
    )
    sizes = set()
    for i in range(700):
        f.predict(run.odometry(i))
        f.update(run.observations(i))
        want = np.concatenate([f.x[:3], f._lm_first.reshape(-1)])
        assert np.array_equal(f._x_lin(), want)
        sizes.add(f.n_landmarks)
    assert f.n_removed + f.n_merged > 0 and len(sizes) > 3  # the set changed both ways
