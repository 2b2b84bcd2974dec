"""AEKF-SLAM steps against independent expectations: finite-difference Jacobians, the
dense textbook Kalman filter, the information-form closed form, Bailey's looped
association, and the sparse-block claims of the thesis (eqs. 5.27, 5.47)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from slam_reference_models import observe_state_landmark as _h

from slam.estimators.aekf import (
    AEKFSlam,
    associate,
    association_scores,
    augment,
    compose_odometry,
    observe,
    predict,
    remove_landmarks,
    update,
)
from slam.types import Odometry, RangeBearing


@pytest.fixture(autouse=True, scope="module")
def _single_blas_thread():
    """Small matrices: oversubscribed BLAS threads on a shared machine only slow down."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def _random_state(rng, n=4, spread=20.0):
    x = np.concatenate([[1.0, -2.0, 0.3], rng.uniform(-spread, spread, 2 * n)])
    A = rng.standard_normal((x.size, x.size)) * 0.3
    P = A @ A.T + 0.05 * np.eye(x.size)
    return x, P


def _f(xv, u):
    c, s = math.cos(xv[2]), math.sin(xv[2])
    return np.array([xv[0] + c * u[0] - s * u[1], xv[1] + s * u[0] + c * u[1], xv[2] + u[2]])


def _num_jac(f, x, eps=1e-6):
    x = np.asarray(x, dtype=float)
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = eps
        d = f(x + e) - f(x - e)
        if d.size >= 2:
            d[1 if d.size == 2 else 2] = (d[1 if d.size == 2 else 2] + np.pi) % (2 * np.pi) - np.pi
        cols.append(d / (2 * eps))
    return np.stack(cols, axis=1)


def test_predict_matches_finite_difference_jacobians_and_touches_only_vehicle_blocks(rng):
    """P' = F P Fᵀ + G Q Gᵀ with F, G the numerical Jacobians of the motion model;
    P_mm unchanged (thesis eq. 5.27)."""
    x, P = _random_state(rng)
    u = np.array([0.7, 0.1, 0.05])
    Q = np.diag([0.01, 0.004, 0.001])
    x2, P2 = predict(x, P, u, Q)
    F = _num_jac(lambda xv: _f(xv, u), x[:3])
    G = _num_jac(lambda uu: _f(x[:3], uu), u)
    Fa = np.eye(x.size)
    Fa[:3, :3] = F
    Ga = np.zeros((x.size, 3))
    Ga[:3] = G
    np.testing.assert_allclose(P2, Fa @ P @ Fa.T + Ga @ Q @ Ga.T, atol=1e-8)
    np.testing.assert_allclose(x2[:3], _f(x[:3], u))
    np.testing.assert_array_equal(x2[3:], x[3:])
    np.testing.assert_array_equal(P2[3:, 3:], P[3:, 3:])


def test_predict_hand_computed_straight_motion():
    """Heading 0, move 1 m forward with variance 0.01 m²: x = 1, P_xx = 0.01, and the
    heading variance 0.02 rad² projects to P_yy = 1² · 0.02 (hand computed)."""
    x = np.zeros(3)
    P = np.diag([0.0, 0.0, 0.02])
    x2, P2 = predict(x, P, [1.0, 0.0, 0.0], np.diag([0.01, 0.0, 0.0]))
    np.testing.assert_allclose(x2, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(P2, [[0.01, 0, 0], [0, 0.02, 0.02], [0, 0.02, 0.02]], atol=1e-15)


def test_compose_odometry_equals_two_predictions(rng):
    """One prediction with u1 ⊕ u2 (composed covariance) equals two predictions: same
    mean and — the EKF Jacobians chain exactly — same covariance."""
    x, P = _random_state(rng)
    u1, u2 = np.array([0.5, 0.02, 0.1]), np.array([0.4, -0.03, -0.2])
    Q1, Q2 = np.diag([1e-3, 2e-4, 3e-4]), np.diag([2e-3, 1e-4, 5e-4])
    xa, Pa = predict(*predict(x, P, u1, Q1), u2, Q2)
    u, Q = compose_odometry(u1, Q1, u2, Q2)
    xb, Pb = predict(x, P, u, Q)
    np.testing.assert_allclose(xb, xa, atol=1e-12)
    np.testing.assert_allclose(Pb, Pa, atol=1e-12)


def test_observe_jacobians_match_finite_differences(rng):
    x, _ = _random_state(rng, n=3)
    for i in range(3):
        zhat, Hv, Hm = observe(x, [i])
        np.testing.assert_allclose(
            zhat[0], _h(x, i) - [0, 2 * np.pi * round(_h(x, i)[1] / (2 * np.pi))]
        )
        J = _num_jac(lambda xx, i=i: _h(xx, i), x)
        np.testing.assert_allclose(Hv[0], J[:, :3], atol=1e-7)
        np.testing.assert_allclose(Hm[0], J[:, 3 + 2 * i : 5 + 2 * i], atol=1e-7)
        others = np.delete(np.arange(3, x.size), [2 * i, 2 * i + 1])
        np.testing.assert_allclose(J[:, others], 0.0, atol=1e-9)


def _dense_H(x, idx):
    rows = []
    for i in idx:
        _, Hv, Hm = observe(x, [i])
        H = np.zeros((2, x.size))
        H[:, :3] = Hv[0]
        H[:, 3 + 2 * i : 5 + 2 * i] = Hm[0]
        rows.append(H)
    return np.vstack(rows)


@pytest.mark.parametrize("joseph", [False, True])
def test_batch_update_equals_textbook_kf_and_information_form(rng, joseph):
    """For one step the EKF is the Kalman filter of the linearized model: compare with the
    dense textbook KF (K = P Hᵀ S⁻¹, (I - K H) P) and the information form
    P⁺ = (P⁻¹ + Hᵀ R⁻¹ H)⁻¹, x⁺ = x + P⁺ Hᵀ R⁻¹ y (a second closed form)."""
    x, P = _random_state(rng)
    idx = np.array([0, 2, 3])
    R = np.diag([0.01, 3e-4])
    z = np.array([_h(x, i) for i in idx]) + rng.standard_normal((3, 2)) * [0.1, 0.02]
    x2, P2 = update(x, P, z, R, idx, joseph=joseph)
    H = _dense_H(x, idx)
    zhat, _, _ = observe(x, idx)
    y = (z - zhat).reshape(-1)
    y[1::2] = (y[1::2] + np.pi) % (2 * np.pi) - np.pi
    RR = np.kron(np.eye(3), R)
    S = H @ P @ H.T + RR
    K = P @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(x2, x + K @ y, atol=1e-9)
    np.testing.assert_allclose(P2, (np.eye(x.size) - K @ H) @ P, atol=1e-9)
    Pinfo = np.linalg.inv(np.linalg.inv(P) + H.T @ np.linalg.inv(RR) @ H)
    np.testing.assert_allclose(P2, Pinfo, atol=1e-8)
    np.testing.assert_allclose(x2, x + Pinfo @ H.T @ np.linalg.inv(RR) @ y, atol=1e-8)
    np.testing.assert_array_equal(P2, P2.T)


def test_linear_gaussian_sequence_equals_closed_form_kalman_filter(rng):
    """Heading known exactly (zero heading variance and odometry heading noise): prediction
    is linear, and with the observation model's Jacobian frozen the filter is a linear KF.
    Predict/update sequence of the AEKF = the textbook KF run on the same linear system."""
    x, P = _random_state(rng, n=2)
    x[2] = 0.4
    P[2, :] = 0.0
    P[:, 2] = 0.0
    Q = np.diag([0.02, 0.01, 0.0])
    R = np.diag([0.01, 1e-4])
    xk, Pk = x.copy(), P.copy()
    xa, Pa = x.copy(), P.copy()
    for step in range(5):
        u = np.array([0.5, 0.1 * step, 0.0])
        xa, Pa = predict(xa, Pa, u, Q)
        c, s = math.cos(0.4), math.sin(0.4)
        G = np.zeros((x.size, 3))
        G[:2, :2] = [[c, -s], [s, c]]
        xk = xk + G @ u
        Pk = Pk + G @ Q @ G.T  # F = I on the x, y block; heading has no variance
        z = np.array([_h(xa, 1)]) + np.array([0.05, 0.01])
        H = _dense_H(xa, [1])
        xa, Pa = update(xa, Pa, z, R, [1])
        zh = observe(xk, [1])[0]
        yk = (z - zh).reshape(-1)
        K = Pk @ H.T @ np.linalg.inv(H @ Pk @ H.T + R)
        xk = xk + K @ yk
        Pk = (np.eye(x.size) - K @ H) @ Pk
        np.testing.assert_allclose(xa, xk, atol=1e-9)
        np.testing.assert_allclose(Pa, Pk, atol=1e-9)


def test_sequential_and_batch_updates_agree_to_first_order(rng):
    """Sequential updates re-linearize between observations; for small corrections the
    two agree closely (exactly for a linear model)."""
    x, P = _random_state(rng)
    P *= 1e-3
    idx = np.array([0, 1])
    R = np.diag([0.01, 3e-4])
    z = np.array([_h(x, i) for i in idx]) + 0.001
    xb, Pb = update(x, P, z, R, idx, batch=True)
    xs, Ps = update(x, P, z, R, idx, batch=False)
    np.testing.assert_allclose(xs, xb, atol=1e-5)
    np.testing.assert_allclose(Ps, Pb, atol=1e-6)


def test_augment_matches_full_jacobian_form_and_fills_only_new_blocks(rng):
    """Eq. 5.47 (sparse) equals eq. 5.43 (∇f P_aug ∇fᵀ with the full Jacobian from finite
    differences); the old blocks are untouched; two landmarks at once = one by one."""
    x, P = _random_state(rng, n=2)
    z = np.array([[12.0, 0.4], [7.0, -1.1]])
    R = np.diag([0.01, 3e-4])
    xa, Pa = augment(x, P, z, R)
    np.testing.assert_array_equal(Pa[: x.size, : x.size], P)
    np.testing.assert_array_equal(xa[: x.size], x)
    # one by one with the full-Jacobian form
    xs, Ps = x.copy(), P.copy()
    for zi in z:
        N = xs.size

        def g(v, N=N):
            xv, zz = v[:N], v[N:]
            return np.concatenate(
                [
                    xv,
                    [
                        xv[0] + zz[0] * math.cos(zz[1] + xv[2]),
                        xv[1] + zz[0] * math.sin(zz[1] + xv[2]),
                    ],
                ]
            )

        v = np.concatenate([xs, zi])
        J = _num_jac(lambda vv, g=g: g(vv), v)
        Paug = np.zeros((N + 2, N + 2))
        Paug[:N, :N] = Ps
        Paug[N:, N:] = R
        xs, Ps = g(v), J @ Paug @ J.T
    np.testing.assert_allclose(xa, xs, atol=1e-12)
    np.testing.assert_allclose(Pa, Ps, atol=1e-7)


def test_remove_landmarks_is_marginalization(rng):
    x, P = _random_state(rng, n=4)
    x2, P2 = remove_landmarks(x, P, [1, 3])
    keep = [0, 1, 2, 3, 4, 7, 8]
    np.testing.assert_array_equal(x2, x[keep])
    np.testing.assert_array_equal(P2, P[np.ix_(keep, keep)])


def _bailey_loop(x, P, z, R, gate1, gate2):
    """Bailey's data_associate (looped), second implementation of the vectorized one."""
    n = (x.size - 3) // 2
    out = []
    for zi in z:
        jbest, nbest, outer = -1, np.inf, np.inf
        for j in range(n):
            zh, Hv, Hm = observe(x, [j])
            H = np.zeros((2, x.size))
            H[:, :3] = Hv[0]
            H[:, 3 + 2 * j : 5 + 2 * j] = Hm[0]
            v = zi - zh[0]
            v[1] = (v[1] + np.pi) % (2 * np.pi) - np.pi
            S = H @ P @ H.T + R
            nis = v @ np.linalg.solve(S, v)
            nd = nis + math.log(np.linalg.det(S))
            if nis < gate1 and nd < nbest:
                nbest, jbest = nd, j
            elif nis < outer:
                outer = nis
        out.append((jbest, jbest < 0 and outer > gate2))
    return out


def test_association_equals_baileys_loop(rng):
    x, P = _random_state(rng, n=12, spread=30.0)
    P *= 0.01
    R = np.diag([0.01, 3e-4])
    z = np.array([_h(x, i) for i in (0, 3, 7)] + [[5.0, 0.2], [40.0, 3.0]])
    z[:3] += rng.standard_normal((3, 2)) * [0.05, 0.005]
    idx, new, _ = associate(x, P, z, R, exclusive=False)
    ref = _bailey_loop(x, P, z, R, 4.0, 25.0)
    assert idx.tolist() == [r[0] for r in ref]
    assert new.tolist() == [bool(r[1]) for r in ref]
    assert idx[:3].tolist() == [0, 3, 7]


def test_exclusive_association_keeps_best_claim(rng):
    """Two observations of one landmark in one scan: only the closer one is associated."""
    x, P = _random_state(rng, n=3, spread=30.0)
    P *= 0.01
    R = np.diag([0.01, 3e-4])
    zt = _h(x, 1)
    z = np.array([zt + np.array([0.01, 0.0]), zt + np.array([0.15, 0.0])])
    nis, _ = association_scores(x, P, z, R)
    assert np.all(nis[:, 1] < 4.0)
    idx, _, _ = associate(x, P, z, R, exclusive=True)
    assert idx.tolist() == [1, -1]


def test_pure_functions_and_class_agree(rng):
    x0 = np.array([0.5, 0.2, 0.1])
    P0 = np.diag([0.01, 0.01, 0.001])
    f = AEKFSlam(preset="reference", x0=x0, P0=P0)
    x, P = x0.copy(), P0.copy()
    R = np.diag([0.01, 3e-4])
    lms = np.array([[10.0, 3.0], [8.0, -6.0], [15.0, 1.0]])
    Q = np.diag([1e-3, 1e-4, 1e-4])
    for step in range(6):
        u = np.array([0.8, 0.0, 0.03])
        f.predict(Odometry(u, Q))
        x, P = predict(x, P, u, Q)
        zs = np.array([_h(np.concatenate([x[:3], lm]), 0) for lm in lms]) + 0.002 * step
        f.update([RangeBearing(z, R) for z in zs])
        idx, new, _ = associate(x, P, zs, R)
        known = idx >= 0
        x, P = update(x, P, zs[known], R, idx[known])
        x, P = augment(x, P, zs[new], R)
    xf, Pf = f.state()
    np.testing.assert_allclose(xf, x, atol=1e-12)
    np.testing.assert_allclose(Pf, P, atol=1e-12)
    assert f.n_landmarks == 3


# ----------------------------------------------------------------- bad input, state unchanged


@pytest.mark.parametrize(
    ("u", "Q", "match"),
    [
        ([np.nan, 0, 0], np.eye(3) * 1e-3, "finite"),
        ([0.1, 0, 0], np.diag([-1e-3, 1e-3, 1e-3]), "negative variance"),
        (
            [0.1, 0, 0],
            np.array([[1.0, 2.0, 0], [2.0, 1.0, 0], [0, 0, 1.0]]),
            "positive semi-definite",
        ),
        ([0.1, 0, 0], np.array([[1.0, 0.5, 0], [0.0, 1.0, 0], [0, 0, 1.0]]), "symmetric"),
        ([0.1, 0], np.eye(3), "shape"),
    ],
)
def test_rejected_odometry_leaves_state_unchanged(u, Q, match):
    f = AEKFSlam(preset="reference")
    f.update_arrays([[5.0, 0.1]], np.diag([0.01, 3e-4]))
    before = f.state()
    with pytest.raises(ValueError, match=match):
        f.predict_arrays(u, Q)
    after = f.state()
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])


@pytest.mark.parametrize(
    ("z", "R", "match"),
    [
        ([[np.inf, 0.1]], np.diag([0.01, 3e-4]), "finite"),
        ([[0.0, 0.1]], np.diag([0.01, 3e-4]), "range must be > 0"),
        ([[5.0, 0.1]], np.diag([0.01, -3e-4]), "negative variance"),
        ([[5.0, 0.1]], np.array([[0.01, 0.1], [0.1, 0.01]]), "positive semi-definite"),
        ([[5.0, 0.1]], np.array([[0.01, np.nan], [0.0, 0.01]]), "finite"),
        ([[5.0, 0.1]], np.diag([0.01, 0.0]), "positive definite"),
    ],
)
def test_rejected_observations_leave_state_unchanged(z, R, match):
    f = AEKFSlam(preset="reference")
    f.update_arrays([[5.0, 0.1]], np.diag([0.01, 3e-4]))
    f.predict_arrays([0.3, 0.0, 0.01], np.diag([1e-3, 1e-4, 1e-4]))
    before = f.state()
    with pytest.raises(ValueError, match=match):
        f.update_arrays(z, R)
    after = f.state()
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])


def test_non_psd_initial_covariance_rejected():
    with pytest.raises(ValueError, match="positive semi-definite"):
        AEKFSlam(preset="reference", P0=np.array([[1.0, 2.0, 0], [2.0, 1.0, 0], [0, 0, 1.0]]))
    with pytest.raises(ValueError, match="reject_gate"):
        AEKFSlam(preset="reference", reject_gate=-1.0)


# ----------------------------------------------------------------- property: P stays PSD


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    steps=st.integers(1, 12),
    joseph=st.booleans(),
    fej=st.booleans(),
    batch=st.booleans(),
    iterations=st.sampled_from([1, 5]),
)
def test_covariance_stays_symmetric_psd_over_random_sequences(
    seed, steps, joseph, fej, batch, iterations
):
    rng = np.random.default_rng(seed)
    f = AEKFSlam(
        preset="reference",
        joseph=joseph,
        jacobians="fej" if fej else "standard",
        batch=batch,
        iterations=iterations,
        relinearize_gate=0.0,  # iterate every update
    )
    lms = rng.uniform(-25, 25, (8, 2))
    truth = np.zeros(3)
    for _ in range(steps):
        u = np.array([rng.uniform(0, 2), rng.normal(0, 0.1), rng.normal(0, 0.2)])
        sd = rng.uniform(1e-4, 0.3, 3)
        Q = np.diag(sd**2)
        f.predict_arrays(u + rng.normal(0, sd), Q)
        truth = _f(truth, u)
        d = lms - truth[:2]
        z = np.stack([np.hypot(*d.T), np.arctan2(d[:, 1], d[:, 0]) - truth[2]], axis=1)
        z = z[z[:, 0] < 30] + rng.normal(0, [0.1, 0.02], (np.count_nonzero(z[:, 0] < 30), 2))
        z = z[z[:, 0] > 0]
        f.update_arrays(z, np.diag([0.01, 4e-4]))
        P = f.P
        assert np.all(np.isfinite(P))
        np.testing.assert_allclose(P, P.T, atol=1e-12 * max(1.0, np.abs(P).max()))
        w = np.linalg.eigvalsh(P)
        assert w.min() > -1e-9 * max(1.0, w.max())


def test_merge_fuses_a_duplicated_landmark_exactly():
    """Two estimates of one point (augmented from two observations) are fused by the
    exact constraint x_i = x_j: the result equals the textbook KF with H = [I, -I], R = 0,
    and the newer duplicate is removed."""
    f = AEKFSlam(preset="reference", merge_gate=9.0, merge_every=1)
    R = np.diag([0.01, 3e-4])
    f.update_arrays([[10.0, 0.3]], R)
    x, P = f.state()
    # a second landmark from a slightly different observation of the same point, added
    # directly (association would have matched it)
    xa, Pa = augment(x, P, np.array([[10.05, 0.302]]), R)
    H = np.zeros((2, xa.size))
    H[:, 3:5] = np.eye(2)
    H[:, 5:7] = -np.eye(2)
    S = H @ Pa @ H.T
    K = Pa @ H.T @ np.linalg.inv(S)
    x_ref = xa + K @ (0 - H @ xa)
    P_ref = (np.eye(xa.size) - K @ H) @ Pa
    f.x, f.P = xa, Pa
    f._lm_first = xa[3:].reshape(2, 2).copy()
    f.labels = np.array([-1, -1])
    f.ids = np.array([0, 1])
    f.misses = np.zeros(2, np.int64)
    f.hits = np.ones(2, np.int64)
    f.update_arrays(np.zeros((0, 2)), R)
    assert f.n_landmarks == 1 and f.n_merged == 1
    np.testing.assert_allclose(f.x, x_ref[:5], atol=1e-9)
    np.testing.assert_allclose(f.P, P_ref[:5, :5], atol=1e-9)


def _map_of_one_update(x0, P, z, R, idx):
    """MAP of one update by scipy's least squares on ``|z - h(x)|²_R + |x - x0|²_P`` (an
    optimizer that shares no code with the filter)."""
    from scipy.optimize import least_squares

    Lp = np.linalg.cholesky(np.linalg.inv(P)).T
    Rs = np.diag(1.0 / np.sqrt(np.diag(R)))

    def res(xx):
        v = np.array([_h(xx, i) for i in idx]) - z
        v[:, 1] = (v[:, 1] + np.pi) % (2 * np.pi) - np.pi
        return np.concatenate([(v @ Rs).ravel(), Lp @ (xx - x0)])

    return least_squares(res, x0, xtol=1e-14, ftol=1e-14, gtol=1e-14).x


def test_iterated_update_converges_to_the_map_of_the_update(rng):
    """Iterated EKF (``iterations`` > 1) on a large correction — the prior pose metres off,
    as at a loop closure — equals the maximum a posteriori estimate of that update found
    by scipy's least squares; the one-shot EKF update does not."""
    x, P = _random_state(rng, n=2, spread=15.0)
    P[:3, :3] += np.diag([4.0, 4.0, 0.01])  # loop-closure-size pose uncertainty
    truth = x.copy()
    truth[:2] += [2.5, -2.0]  # the prior is 3.2 m off
    idx = np.array([0, 1])
    R = np.diag([0.01, 3e-4])
    z = np.array([_h(truth, i) for i in idx])
    x_map = _map_of_one_update(x, P, z, R, idx)
    x_iekf, P_iekf = update(x, P, z, R, idx, iterations=20)
    x_ekf, _ = update(x, P, z, R, idx)
    np.testing.assert_allclose(x_iekf, x_map, atol=1e-6)
    assert np.max(np.abs(x_ekf - x_map)) > 1e-2  # the linearization mattered here
    # covariance: the EKF covariance of the linearization at the converged estimate
    H = _dense_H(x_iekf, idx)
    S = H @ P @ H.T + np.kron(np.eye(2), R)
    K = P @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(P_iekf, (np.eye(x.size) - K @ H) @ P, atol=1e-9)


def test_iterated_update_is_the_ekf_update_when_the_step_is_linear(rng):
    """A tiny correction has no linearization error above the gate: the iterated filter
    returns exactly the EKF update (iteration is only for loop-closure-size steps)."""
    x, P = _random_state(rng)
    P *= 1e-4
    idx = np.array([0, 2])
    R = np.diag([0.01, 3e-4])
    z = np.array([_h(x, i) for i in idx]) + np.array([0.01, 0.001])
    x1, P1 = update(x, P, z, R, idx)
    x2, P2 = update(x, P, z, R, idx, iterations=10)
    np.testing.assert_array_equal(x1, x2)
    np.testing.assert_array_equal(P1, P2)


@pytest.mark.parametrize("gate", [-1.0, float("nan"), float("inf")])
def test_bad_relinearize_gate_rejected(gate):
    with pytest.raises(ValueError, match="relinearize_gate"):
        AEKFSlam(preset="reference", iterations=5, relinearize_gate=gate)


@pytest.mark.parametrize("bad", [0, -1, 1.5])
def test_bad_iterations_rejected(bad):
    with pytest.raises(ValueError, match="iterations"):
        AEKFSlam(preset="reference", iterations=bad)
    x, P = _random_state(np.random.default_rng(0))
    with pytest.raises(ValueError, match="iterations"):
        update(x, P, [[10.0, 0.1]], np.diag([0.01, 3e-4]), [0], iterations=bad)


def test_iterated_update_with_first_estimates_keeps_the_fej_covariance(rng):
    """With first-estimates Jacobians the iterated mean is still the MAP of the update, but
    the covariance is the FEJ one: the Kalman covariance of H evaluated at ``x_lin``."""
    x, P = _random_state(rng, n=2, spread=15.0)
    P[:3, :3] += np.diag([4.0, 4.0, 0.01])
    truth = x.copy()
    truth[:2] += [2.5, -2.0]
    idx = np.array([0, 1])
    R = np.diag([0.01, 3e-4])
    z = np.array([_h(truth, i) for i in idx])
    x_lin = x.copy()
    x_lin[3:] += rng.normal(0, 0.3, x.size - 3)  # landmarks' first estimates
    x_it, P_it = update(x, P, z, R, idx, iterations=20, x_lin=x_lin)
    np.testing.assert_allclose(x_it, _map_of_one_update(x, P, z, R, idx), atol=1e-6)
    H = _dense_H(x_lin, idx)
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + np.kron(np.eye(2), R))
    np.testing.assert_allclose(P_it, (np.eye(x.size) - K @ H) @ P, atol=1e-9)
