"""Fleet map fusion (slam.fleet) against the truth of generated maps and against a second
implementation: the same MAP written here as a plain least-squares problem for scipy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import cholesky, solve_triangular
from scipy.optimize import least_squares
from scipy.stats import chi2

from slam.fleet import FleetFusionConfig, GpsFix, VehicleMap, fuse_maps, pair_maps, solve_fused


def _local(T, pts):
    """World points (n, 2) into the frame whose world pose is T."""
    c, s = math.cos(T[2]), math.sin(T[2])
    return (np.asarray(pts) - T[:2]) @ np.array([[c, -s], [s, c]])


def _landmarks(rng, n, box=(100.0, 80.0), min_sep=10.0):
    pts = []
    while len(pts) < n:
        p = rng.uniform([-box[0] / 2, -box[1] / 2], [box[0] / 2, box[1] / 2])
        if all(np.hypot(*(p - q)) >= min_sep for q in pts):
            pts.append(p)
    return np.array(pts)


def _map_cov(pts_local, sigma_l=0.3, common=(0.25, 0.25, 0.007)):
    """A map covariance with the correlations of a filter's map: independent noise plus a
    shared rigid error (navigation) of std ``common`` (m, m, rad) about the map origin. ``pts_local``
    (1 + m, 2): the vehicle, then the landmarks."""
    m = len(pts_local) - 1
    J = np.zeros((3 + 2 * m, 3))
    rows_x = np.r_[0, 3 + 2 * np.arange(m)]
    J[rows_x, 0] = 1.0
    J[rows_x + 1, 1] = 1.0
    J[rows_x, 2] = -pts_local[:, 1]
    J[rows_x + 1, 2] = pts_local[:, 0]
    J[2, 2] = 1.0
    P = J @ np.diag(np.square(common)) @ J.T
    P += np.diag(np.r_[0.1, 0.1, math.radians(0.2) ** 2, np.full(2 * m, sigma_l**2)])
    return 0.5 * (P + P.T)


def _make_map(rng, T, pose_w, lms_w, name, frame=None, frame_cov=None):
    """A vehicle map in frame T: truth expressed in T plus a draw of its own covariance."""
    loc = _local(T, np.vstack([pose_w[:2], lms_w]))
    x_true = np.r_[loc[0], (pose_w[2] - T[2] + math.pi) % (2 * math.pi) - math.pi, loc[1:].ravel()]
    P = _map_cov(loc)
    x = x_true + np.linalg.cholesky(P) @ rng.standard_normal(x_true.size)
    return VehicleMap(x, P, name, frame=frame, frame_cov=frame_cov)


def _two_maps(seed=3):
    rng = np.random.default_rng(seed)
    L = _landmarks(rng, 15)
    T_B = np.array([12.0, -7.0, math.radians(25.0)])
    a = _make_map(rng, np.zeros(3), np.array([-40.0, 30.0, 0.3]), L[:12], "A")
    extra = np.array([[70.0, 10.0], [75.0, -30.0], [62.0, 45.0]])  # only B maps these
    prior = T_B + np.array([1.0, -0.8, math.radians(2.0)])
    pcov = np.diag([3.0**2, 3.0**2, math.radians(5.0) ** 2])
    b = _make_map(
        rng, T_B, np.array([20.0, -20.0, -1.0]), np.vstack([L[3:15], extra]), "B", prior, pcov
    )
    return a, b, T_B


def test_two_maps_recover_the_true_transform_and_pair_the_shared_landmarks():
    a, b, T_B = _two_maps()
    fused = fuse_maps([a, b])
    # B's landmarks 0..8 are A's 3..11; 9..11 (L[12:15]) and the 3 extras are new
    np.testing.assert_array_equal(fused.assignment[1][:9], np.arange(3, 12))
    assert fused.n_paired == 9
    assert fused.n_landmarks == 12 + 3 + 3
    e = fused.frames[1] - T_B
    e[2] = (e[2] + math.pi) % (2 * math.pi) - math.pi
    assert e @ np.linalg.solve(fused.frame_cov[1], e) < chi2.ppf(0.999, 3)
    # far better than the prior it started from (1.28 m and 2° off)
    assert np.hypot(e[0], e[1]) < 0.64 and abs(math.degrees(e[2])) < 1.0
    # consistent maps: the weighted residual is a χ² draw with dof degrees of freedom
    assert chi2.ppf(0.001, fused.dof) < fused.chi2 < chi2.ppf(0.999, fused.dof)


def _scipy_fused(a: VehicleMap, b: VehicleMap, assign_b, M):
    """Second implementation: unknowns [T_B, V_A, V_B, G (M, 2)], residuals whitened by
    scipy's Cholesky factors, solved by scipy's trust-region least squares."""
    La = cholesky(
        a.P + np.eye(a.P.shape[0]) * 1e-10 * max(1, np.trace(a.P) / a.P.shape[0]), lower=True
    )
    Lb = cholesky(
        b.P + np.eye(b.P.shape[0]) * 1e-10 * max(1, np.trace(b.P) / b.P.shape[0]), lower=True
    )
    Lp = cholesky(b.frame_cov, lower=True)

    def wrap(t):
        return math.atan2(math.sin(t), math.cos(t))

    def fun(p):
        T, VA, VB, G = p[:3], p[3:6], p[6:9], p[9:].reshape(M, 2)
        ha = np.r_[VA, G[: a.n_landmarks].ravel()]
        ea = ha - a.x
        ea[2] = wrap(ea[2])
        loc = _local(T, np.vstack([VB[:2], G[assign_b]]))
        hb = np.r_[loc[0], VB[2] - T[2], loc[1:].ravel()]
        eb = hb - b.x
        eb[2] = wrap(eb[2])
        ep = T - b.frame
        ep[2] = wrap(ep[2])
        return np.r_[
            solve_triangular(La, ea, lower=True),
            solve_triangular(Lb, eb, lower=True),
            solve_triangular(Lp, ep, lower=True),
        ]

    G0 = np.zeros((M, 2))
    G0[: a.n_landmarks] = a.x[3:].reshape(-1, 2)
    c, s = math.cos(b.frame[2]), math.sin(b.frame[2])
    gb = b.x[3:].reshape(-1, 2) @ np.array([[c, s], [-s, c]]) + b.frame[:2]
    new = assign_b >= a.n_landmarks
    G0[assign_b[new]] = gb[new]
    p0 = np.r_[
        b.frame,
        a.x[:3],
        b.frame[:2] + np.array([[c, -s], [s, c]]) @ b.x[:2],
        b.frame[2] + b.x[2],
        G0.ravel(),
    ]
    res = least_squares(fun, p0, method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=2000)
    cov = np.linalg.inv(res.jac.T @ res.jac)
    return res.x, cov


def test_fusion_equals_the_batch_least_squares_solution_of_scipy():
    a, b, _ = _two_maps(seed=7)
    fused = fuse_maps([a, b])
    M = fused.n_landmarks
    p, cov = _scipy_fused(a, b, fused.assignment[1], M)
    np.testing.assert_allclose(fused.frames[1], p[:3], atol=1e-7)
    np.testing.assert_allclose(fused.poses, [p[3:6], p[6:9]], atol=1e-7)
    np.testing.assert_allclose(fused.landmarks, p[9:].reshape(M, 2), atol=1e-7)
    np.testing.assert_allclose(fused.cov, cov, rtol=1e-4, atol=1e-8)


def test_a_gps_fix_of_a_surfaced_vehicle_anchors_the_fused_map():
    """Two vehicles that both started from poor fixes (frames off by metres); B surfaces
    and gets a 0.5 m GPS fix at hand-over: the fused map's error against the truth drops."""
    err_no, err_gps, inside = [], [], []
    for seed in range(8):
        rng = np.random.default_rng(100 + seed)
        L = _landmarks(rng, 12)
        pcov = np.diag([5.0**2, 5.0**2, math.radians(1.0) ** 2])
        Ta = np.linalg.cholesky(pcov) @ rng.standard_normal(3)
        Tb = np.linalg.cholesky(pcov) @ rng.standard_normal(3)
        pose_b = np.array([30.0, -10.0, 0.5])
        a = _make_map(rng, Ta, np.array([-30.0, 20.0, 0.1]), L[:9], "A", np.zeros(3), pcov)
        b = _make_map(rng, Tb, pose_b, L[4:], "B", np.zeros(3), pcov)
        fix = GpsFix(1, pose_b[:2] + 0.5 * rng.standard_normal(2), np.eye(2) * 0.25)
        for gps, out in (((), err_no), ((fix,), err_gps)):
            f = fuse_maps([a, b], gps)
            assert f.n_landmarks == len(L)  # 5 shared landmarks paired, none duplicated
            order = np.empty(len(L), int)
            order[f.assignment[0]] = np.arange(9)
            order[f.assignment[1]] = np.arange(4, 12)
            truth = L[order]
            out.append(np.sqrt(np.mean(np.sum((f.landmarks - truth) ** 2, axis=1))))
            if gps:
                d = f.landmarks - truth
                nees = np.einsum("ni,nij,nj->n", d, np.linalg.inv(f.landmark_cov), d)
                inside.append(np.mean(nees < chi2.ppf(0.99, 2)))
    assert np.mean(err_gps) < 0.5 * np.mean(err_no)
    assert np.mean(inside) > 0.9


def test_known_frames_fuse_by_information_like_a_linear_kalman_update():
    """Frames known and identity: the model is linear, so the fused shared landmark is the
    information-weighted mean of the two maps' marginals (independent maps)."""
    rng = np.random.default_rng(5)
    L = _landmarks(rng, 3)
    a = _make_map(rng, np.zeros(3), np.array([0.0, -50.0, 0.0]), L, "A")
    b = _make_map(rng, np.zeros(3), np.array([0.0, 50.0, 0.0]), L[:1], "B")
    f = fuse_maps([a, b])
    # joint linear update: stack [x_a, x_b], condition on l0_a = l0_b
    x = np.r_[a.x, b.x]
    P = np.zeros((x.size, x.size))
    P[: a.x.size, : a.x.size] = a.P
    P[a.x.size :, a.x.size :] = b.P
    H = np.zeros((2, x.size))
    H[:, 3:5] = np.eye(2)
    H[:, a.x.size + 3 : a.x.size + 5] = -np.eye(2)
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T)
    xs = x - K @ (H @ x)
    Ps = P - K @ H @ P
    np.testing.assert_allclose(f.landmarks, xs[3 : a.x.size].reshape(-1, 2), atol=1e-6)
    np.testing.assert_allclose(f.landmark_cov[0], Ps[3:5, 3:5], rtol=1e-5, atol=1e-9)


def test_pair_maps_leaves_an_ambiguous_landmark_unpaired():
    """One incoming landmark halfway between two fused ones 1 m apart with 2 m σ: both
    pairings pass, neither is evidence for the other, so it is left unpaired."""
    G = np.array([[0.0, 0.0], [1.0, 0.0], [40.0, 0.0]])
    SG = np.eye(6) * 4.0
    g = np.array([[0.5, 0.0], [40.2, 0.1]])
    pm = pair_maps(G, SG, g, np.eye(4) * 0.01)
    assert pm.pairs.tolist() == [-1, 2]
    assert pm.ambiguous.tolist() == [True, False]


def test_bad_input_names_the_field():
    with pytest.raises(ValueError, match=r"VehicleMap 'A'.x must have shape"):
        VehicleMap(np.zeros(4), np.eye(4), "A")
    with pytest.raises(ValueError, match=r"P must be symmetric"):
        VehicleMap(np.zeros(3), np.array([[1.0, 0.5, 0], [0, 1, 0], [0, 0, 1]]), "A")
    with pytest.raises(ValueError, match=r"frame_cov must be positive definite"):
        VehicleMap(np.zeros(3), np.eye(3), "A", frame_cov=np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"GpsFix.vehicle 2 out of range"):
        fuse_maps([VehicleMap(np.zeros(3), np.eye(3))], [GpsFix(2, [0.0, 0.0], np.eye(2))])
    with pytest.raises(ValueError, match=r"confidence must be in"):
        FleetFusionConfig(confidence=1.5)
    with pytest.raises(ValueError, match=r"assignment\[0\] must hold 1 indices"):
        solve_fused([VehicleMap(np.zeros(5), np.eye(5))], [np.array([0, 1])])


def test_fusion_does_not_make_a_vehicles_pose_worse_than_its_own_map():
    """Known frames (the scenario's case), 40 generated pairs of maps sharing 6 of their
    landmarks, each map a draw of its own covariance (shared navigation error): the fused
    pose of each vehicle is closer to the truth on average than the vehicle's own (the
    other map adds information through the shared landmarks), and its NEES averages 3
    (inside the 99 % interval of the mean of 40 χ²(3) draws)."""
    own, fused_err, nees = np.zeros((2, 40)), np.zeros((2, 40)), []
    for s in range(40):
        rng = np.random.default_rng(300 + s)
        L = _landmarks(rng, 14)
        poses = [np.array([-30.0, 20.0, 0.1]), np.array([30.0, -10.0, 0.5])]
        a = _make_map(rng, np.zeros(3), poses[0], L[:10], "A")
        b = _make_map(rng, np.zeros(3), poses[1], L[4:], "B")
        f = fuse_maps([a, b])
        paired = np.nonzero(f.assignment[1] < 10)[0]  # B's landmarks paired with A's
        np.testing.assert_array_equal(f.assignment[1][paired], paired + 4)  # never wrongly
        assert f.n_paired >= 4
        for k, (mp, p) in enumerate(zip((a, b), poses, strict=True)):
            own[k, s] = np.sum((mp.x[:2] - p[:2]) ** 2)
            fused_err[k, s] = np.sum((f.poses[k, :2] - p[:2]) ** 2)
            d = f.poses[k] - p
            d[2] = (d[2] + math.pi) % (2 * math.pi) - math.pi
            nees.append(d @ np.linalg.solve(f.pose_cov[k], d))
    assert np.all(fused_err.mean(axis=1) < own.mean(axis=1))
    lo, hi = chi2.ppf([0.005, 0.995], 3 * 80) / 80
    assert lo < np.mean(nees) < hi


def test_covariance_intersection_stays_consistent_when_the_maps_share_errors():
    """Two maps of the same 8 landmarks whose errors share a common part (each map alone is
    consistent: its covariance holds the common and its own part). Fusing them as
    independent counts the common part twice: the fused landmark NEES averages well above 2;
    with ``cross_correlation="unknown"`` (covariance intersection) it stays at or below 2."""
    indep, ci = [], []
    for s in range(30):
        rng = np.random.default_rng(500 + s)
        L = _landmarks(rng, 8)
        n = 3 + 2 * len(L)
        Cc = np.diag(np.r_[0.05, 0.05, 1e-4, np.full(2 * len(L), 0.8**2)])  # shared
        Ci = _map_cov(np.vstack([[0.0, 0.0], L]), sigma_l=0.3, common=(0.1, 0.1, 0.002))
        common = np.linalg.cholesky(Cc) @ rng.standard_normal(n)
        maps = []
        for k, pose in enumerate(([-30.0, 20.0, 0.1], [30.0, -10.0, 0.5])):
            x_true = np.r_[pose, L.ravel()]
            x = x_true + common + np.linalg.cholesky(Ci) @ rng.standard_normal(n)
            maps.append(VehicleMap(x, Cc + Ci, f"v{k}"))
        for cfg, out in (
            (FleetFusionConfig(), indep),
            (FleetFusionConfig(cross_correlation="unknown"), ci),
        ):
            f = fuse_maps(maps, config=cfg)
            assert f.n_landmarks == len(L)  # all paired
            d = f.landmarks[f.assignment[0]] - L
            out.append(
                np.mean(
                    np.einsum("ni,nij,nj->n", d, np.linalg.inv(f.landmark_cov[f.assignment[0]]), d)
                )
            )
    hi = chi2.ppf(0.99, 2 * 30) / 30  # the mean of 30 independent NEES draws
    assert np.mean(indep) > hi
    assert np.mean(ci) < hi


def test_covariance_intersection_leaves_a_map_that_shares_nothing_as_it_is():
    rng = np.random.default_rng(9)
    a, b, _ = _two_maps(seed=9)
    lone = _make_map(
        rng, np.zeros(3), np.array([300.0, 300.0, 0.0]), np.array([[320.0, 310.0]]), "C"
    )
    f = fuse_maps([a, b, lone], config=FleetFusionConfig(cross_correlation="unknown"))
    np.testing.assert_allclose(f.pose_cov[2], lone.P[:3, :3], rtol=1e-4, atol=1e-12)
    np.testing.assert_allclose(
        f.landmark_cov[f.assignment[2][0]], lone.P[3:, 3:], rtol=1e-4, atol=1e-12
    )
    # the two linked maps are intersected: weights below 1 widen their shared landmarks
    g = fuse_maps([a, b, lone])
    shared = f.assignment[1][:9]
    assert np.all(
        np.trace(f.landmark_cov[shared], axis1=1, axis2=2)
        > np.trace(g.landmark_cov[shared], axis1=1, axis2=2)
    )
