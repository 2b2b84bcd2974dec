"""The compiled covariance steps of the dead reckoner (sim.navigation.dr_covariance)
against the dense numpy formulation they replace: each kernel against ``A @ P @ A.T``
with ``A`` assembled as a full 21 × 21 matrix, and a long consumer-IMU run (compass
aiding, DVL dropouts, turns, cuts every tick) of the nav suite with the kernels swapped
for those dense products: every odometry covariance and the final 21 × 21 covariances
agree to 1e-12 relative (to sqrt(P_ii P_jj)), and the estimate is bit-identical."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest

from sim.navigation import DVLConfig, NavSuite, NavSuiteConfig
from sim.navigation import dead_reckoning as dr
from sim.navigation import dr_covariance as cov
from sim.navigation import suite as suite_mod
from tests.sim.navigation.test_nav_dead_reckoning import arc_states

N = 21


def _dense_propagate(P, Jdp, RT, cz, Rv, Rm, h, a, q_g, q_b, q_v):
    F = np.eye(N)
    F[dr._P, dr._PHI] = Jdp
    F[dr._P, dr._E0] = -Jdp
    F[dr._P, dr._NV] = RT * h
    F[dr._P, dr._NW] = np.outer(Jdp, cz) * 0.5 * h
    F[dr._P, dr._B] = np.outer(Jdp, cz) * 0.5 * h
    F[dr._PHI, dr._NW] = cz * h
    F[dr._PHI, dr._B] = cz * h
    F[dr._P, dr._S] = Rv * h
    F[dr._P, dr._M] = Rm * h
    F[dr._P, dr._BV] = RT * h
    F[dr._G, dr._G] = a
    P[:] = F @ P @ F.T
    P[dr._G, dr._G] += q_g
    P[dr._B, dr._B] += np.eye(2) * q_b
    P[dr._NV, dr._NV] += np.eye(3) * q_v


def _dense_fresh(P, i0, k, var):
    P[i0 : i0 + k, :] = 0.0
    P[:, i0 : i0 + k] = 0.0
    P[i0 : i0 + k, i0 : i0 + k] = np.eye(k) * var


def _dense_correct(P, r0, c0, G, var):
    k, m = G.shape
    F = np.eye(N)
    F[r0 : r0 + k, c0 : c0 + m] = -G
    P[:] = F @ P @ F.T
    _dense_fresh(P, c0, m, var)
    F[r0 : r0 + k, c0 : c0 + m] = G
    P[:] = F @ P @ F.T


def _dense_schmidt(P, K, h, var):
    A = np.eye(N) - np.outer(K, h)
    P[:] = A @ P @ A.T + np.outer(K, K) * var


def _dense_cut_covariance(P):
    M = np.zeros((3, N))
    M[0, 0] = M[1, 1] = M[2, dr._PHI] = 1.0
    M[2, dr._E0] = -1.0
    C = M @ P @ M.T
    return 0.5 * (C + C.T)


def _rot3(a):
    B = np.eye(3)
    B[:2, :2] = [[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]
    return B


def _dense_matched(cov_whole, cov_cut, yaw0, yaw_prev, dx, dy):
    B = _rot3(yaw0)
    cov_now = B @ cov_whole @ B.T
    c, s = math.cos(yaw_prev), math.sin(yaw_prev)
    F = np.array([[1.0, 0.0, -s * dx - c * dy], [0.0, 1.0, c * dx - s * dy], [0.0, 0.0, 1.0]])
    G = _rot3(yaw_prev)
    D = G.T @ (cov_now - F @ cov_cut @ F.T) @ G
    w, V = np.linalg.eigh(0.5 * (D + D.T))
    Q = (V * np.maximum(w, 0.0)) @ V.T
    cov_cut[:] = F @ cov_cut @ F.T + G @ Q @ G.T
    return 0.5 * (Q + Q.T)


DENSE = types.SimpleNamespace(
    propagate=_dense_propagate,
    fresh_noise=_dense_fresh,
    correct=_dense_correct,
    schmidt_update=_dense_schmidt,
    cut_covariance=_dense_cut_covariance,
    matched_odometry_cov=_dense_matched,
)


def _close(P_fast, P_ref, tol=1e-12, scale=None):
    """|ΔP_ij| <= tol sqrt(S_ii S_jj), S = ``scale`` (default the reference P itself)."""
    S = P_ref if scale is None else scale
    d = np.sqrt(np.clip(np.diag(S), 1e-300, None))
    return float(np.max(np.abs(P_fast - P_ref) / np.outer(d, d))) <= tol


def test_state_layout_matches_the_dead_reckoner():
    """The kernel's block offsets are the dead reckoner's error-state layout."""
    assert (cov.I_P, cov.I_PHI, cov.I_E0, cov.I_S, cov.I_M, cov.I_G) == (
        dr._P.start,
        dr._PHI,
        dr._E0,
        dr._S,
        dr._M,
        dr._G,
    )
    assert (cov.I_NV, cov.I_NW, cov.I_B, cov.I_BV) == (
        dr._NV.start,
        dr._NW.start,
        dr._B.start,
        dr._BV.start,
    )
    assert dr._N == N


def _spd(rng):
    X = rng.standard_normal((N, 2 * N))
    return X @ X.T / N


def test_sandwich_rows_equals_dense_product():
    """A = identity with three rows replaced: A P Aᵀ of numpy, to rounding."""
    rng = np.random.default_rng(3)
    P = _spd(rng)
    rows = np.array([0, 5, 20])
    A = np.eye(N)
    A[rows] = rng.standard_normal((3, N))
    ref = A @ P @ A.T
    got = P.copy()
    cov.sandwich_rows(got, rows, A[rows].copy())
    assert _close(got, ref, 1e-13)


@pytest.mark.parametrize(
    "name", ["propagate", "correct", "schmidt_update", "cut_covariance", "matched_odometry_cov"]
)
def test_each_kernel_equals_its_dense_formula(name):
    rng = np.random.default_rng(7)
    P = _spd(rng)
    if name == "propagate":
        args = (
            rng.standard_normal(2),
            rng.standard_normal((2, 3)),
            rng.standard_normal(2),
            rng.standard_normal(2),
            rng.standard_normal(2),
            0.05,
            0.99,
            1e-6,
            2e-7,
            3e-4,
        )
    elif name == "correct":
        args = (0, 4, rng.standard_normal((2, 3)), 1e-4)
    elif name == "schmidt_update":
        K = np.where(dr._UPDATED, rng.standard_normal(N), 0.0)
        args = (K, rng.standard_normal(N), 1e-3)
    elif name == "cut_covariance":
        assert _close(cov.cut_covariance(P), DENSE.cut_covariance(P), 1e-13)
        return
    else:  # Σ grown from the recursion's Σ̃ (3 × 3 blocks of two SPD matrices)
        S3 = np.ascontiguousarray(P[:3, :3])
        cut = S3 * 0.5
        ref_cut, got_cut = cut.copy(), cut.copy()
        q_ref = DENSE.matched_odometry_cov(S3, ref_cut, 0.3, -1.2, 0.5, 0.1)
        q_got = cov.matched_odometry_cov(S3, got_cut, 0.3, -1.2, 0.5, 0.1)
        assert _close(q_got, q_ref, 1e-13, scale=S3)
        assert _close(got_cut, ref_cut, 1e-13)
        return
    ref, got = P.copy(), P.copy()
    getattr(DENSE, name)(ref, *args)
    getattr(cov, name)(got, *args)
    assert _close(got, ref, 1e-13)
    assert not np.array_equal(ref, P)  # the step did something


def _long_run(monkeypatch, kernels, duration=240.0):
    monkeypatch.setattr(dr, "_cov", kernels)
    monkeypatch.setattr(suite_mod, "_cov", kernels)
    dvl = DVLConfig.preset("rdi600", dropout_prob=0.1)
    cfg = NavSuiteConfig(dvl=dvl)  # consumer IMU: compass-aided, gyro bias estimated
    assert cfg.aided
    states = arc_states(duration)  # a constant turn: 1.5 turns of a 37.5 m circle
    suite = NavSuite(
        cfg, np.random.default_rng(11), t0=0.0, initial_velocity_body=states[0].velocity_body
    )
    incs = []
    for s in states[1:]:
        suite.poll(s)
        incs.append((suite.odometry(s.t), suite._cov_cut.copy()))
    return suite, incs


def test_long_run_matches_the_dense_numpy_formulation(monkeypatch):
    """240 s of aided consumer-IMU dead reckoning with DVL dropouts, a cut every tick
    (4,800 increments): both reckoners' covariances stay within 1e-12 of the dense
    products. The matched odometry covariance Q is a difference of two such
    covariances (NavSuite.odometry), so its rounding is that of the whole-run covariance
    Σ̃ it is differenced from: within 1e-12 of Σ̃'s scale. The estimates depend on the
    covariance through the compass gain: each increment within 1e-12 of its length."""
    fast, inc_f = _long_run(monkeypatch, cov)
    ref, inc_r = _long_run(monkeypatch, DENSE)
    assert len(inc_f) == len(inc_r) == 4800
    for (a, cut_a), (b, cut_b) in zip(inc_f, inc_r):
        assert np.max(np.abs(a.delta - b.delta)) <= 1e-12 * np.linalg.norm(b.delta)
        assert _close(a.cov, b.cov, scale=cut_b)
        assert _close(cut_a, cut_b)
    for f, r in ((fast.dead_reckoner, ref.dead_reckoner), (fast._whole, ref._whole)):
        assert _close(f.P, r.P)
        assert f.n_dvl_dropped > 0 and f.psi0 is not None  # dropouts and aiding happened
    assert np.max(np.abs(fast.pose() - ref.pose())) < 1e-9  # m, rad after 240 s
