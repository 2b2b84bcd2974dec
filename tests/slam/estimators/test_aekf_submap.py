"""Sub-mapping AEKF with map joining.

Independent expectations: a linear-Gaussian problem, where joining local maps and fusing
their shared landmarks must reproduce the single full-map Kalman filter exactly (a second
implementation, written here); one local map of unlimited size is the plain AEKF; the
joined covariance is ``G D Gᵀ`` with G a finite-difference Jacobian of the joined means;
on the dense loop the joined map has no duplicated landmark and stays close to the single
map AEKF."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slam.estimators import make_estimator
from slam.estimators.aekf import AEKFSlam, predict
from slam.estimators.aekf_submap import (
    LocalMap,
    SubmapAEKFSlam,
    compose_pose,
    join_local_maps,
)
from slam.experiments import get_experiment
from slam.experiments.runner import run_once
from slam.sim2d import simulate_run


@pytest.fixture(autouse=True, scope="module")
def _single_blas_thread():
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


@pytest.fixture(scope="module")
def run():
    spec = get_experiment("dense-loop", n_loops=1)
    return simulate_run(spec.map.landmarks, spec.map.waypoints, spec.sim, np.random.default_rng(5))


# --------------------------------------------------------------------------- linear case


def _rot(phi):
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


class _LinearKF:
    """Landmark SLAM with a known heading (zero heading variance): translation-only
    odometry noise and relative-position observations in the body frame
    ``z = Rot(phi)ᵀ (l - p) + v`` make the problem linear-Gaussian, so this Kalman filter
    is the exact posterior. Written independently of the AEKF code."""

    def __init__(self, pose=(0.0, 0.0, 0.0)):
        self.x = np.array(pose, dtype=float)
        self.P = np.zeros((3, 3))
        self.ids: list[int] = []

    def predict(self, u, Q2):
        Rm = _rot(self.x[2])
        self.x[:2] += Rm @ u[:2]
        self.x[2] += u[2]
        self.P[:2, :2] += Rm @ Q2 @ Rm.T

    def observe(self, ids, z, Rz):
        Rm = _rot(self.x[2])
        known = [(k, zk) for k, zk in zip(ids, z, strict=True) if k in self.ids]
        if known:
            N = self.x.size
            H = np.zeros((2 * len(known), N))
            y = np.empty(2 * len(known))
            for r, (k, zk) in enumerate(known):
                c = 3 + 2 * self.ids.index(k)
                H[2 * r : 2 * r + 2, :2] = -Rm.T
                H[2 * r : 2 * r + 2, c : c + 2] = Rm.T
                y[2 * r : 2 * r + 2] = zk - Rm.T @ (self.x[c : c + 2] - self.x[:2])
            S = H @ self.P @ H.T + np.kron(np.eye(len(known)), Rz)
            K = np.linalg.solve(S, H @ self.P).T
            self.x = self.x + K @ y
            self.P = self.P - K @ S @ K.T
            self.P = 0.5 * (self.P + self.P.T)
        for k, zk in zip(ids, z, strict=True):
            if k in self.ids:
                continue
            N = self.x.size
            P = np.zeros((N + 2, N + 2))
            P[:N, :N] = self.P
            P[N:, :N] = self.P[:2, :]
            P[:N, N:] = self.P[:, :2]
            P[N:, N:] = self.P[:2, :2] + Rm @ Rz @ Rm.T
            self.x = np.concatenate([self.x, self.x[:2] + Rm @ zk])
            self.P = P
            self.ids.append(k)


def _linear_problem(seed, n_steps=24, n_lm=14):
    rng = np.random.default_rng(seed)
    lm = rng.uniform(-30.0, 30.0, (n_lm, 2))
    Q2 = np.diag([0.05, 0.02]) ** 2
    Rz = np.array([[0.04, 0.01], [0.01, 0.03]])
    pose = np.zeros(3)
    steps = []
    for _ in range(n_steps):
        u_true = np.array([2.0, 0.0, rng.uniform(-0.4, 0.4)])
        pose = np.array(
            [*(pose[:2] + _rot(pose[2]) @ u_true[:2]), pose[2] + u_true[2]], dtype=float
        )
        u = u_true.copy()
        u[:2] += rng.multivariate_normal(np.zeros(2), Q2)
        d = np.hypot(*(lm - pose[:2]).T)
        ids = np.flatnonzero(d < 25.0)
        z = (lm[ids] - pose[:2]) @ _rot(pose[2]) + rng.multivariate_normal(
            np.zeros(2), Rz, ids.size
        )
        steps.append((u, ids.tolist(), z))
    return steps, Q2, Rz


def _split_and_join(seed, cuts, fusion):
    steps, Q2, Rz = _linear_problem(seed)
    full = _LinearKF()
    locs = [_LinearKF()]
    for t, (u, ids, z) in enumerate(steps):
        if t in cuts:
            locs.append(_LinearKF())  # new local map: base = current pose, zero covariance
        for f in (full, locs[-1]):
            f.predict(u, Q2)
            f.observe(ids, z, Rz)
    maps = [LocalMap(f.x, f.P, np.array(f.ids, dtype=np.int64)) for f in locs]
    return maps, full, join_local_maps(maps, fusion=fusion)


def _assert_equals_full_filter(maps, full, gm):
    assert gm.n_fused == sum(m.n_landmarks for m in maps) - len(full.ids)
    np.testing.assert_array_equal(gm.labels, full.ids)
    d = gm.x - full.x
    d[2] = (d[2] + np.pi) % (
        2 * np.pi
    ) - np.pi  # the joined heading is wrapped, the linear filter's not
    np.testing.assert_allclose(d, 0.0, atol=1e-9)
    np.testing.assert_allclose(gm.P, full.P, atol=1e-10 * np.abs(full.P).max())


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("cuts", [(12,), (8, 16)])
def test_linear_gaussian_join_equals_single_full_kalman_filter(seed, cuts):
    """Linear-Gaussian case: local maps (split at ``cuts``) joined and fused by the
    Mahalanobis test equal the one full-map Kalman filter over all the data — means and
    the FULL covariance (exact: conditioning independent local maps on ``x_i = x_j`` is
    the full posterior)."""
    maps, full, gm = _split_and_join(seed, cuts, "mahalanobis")
    assert sum(m.n_landmarks for m in maps) > len(full.ids)  # there are duplicates to fuse
    _assert_equals_full_filter(maps, full, gm)


@settings(max_examples=15, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    cuts=st.lists(st.integers(1, 23), min_size=1, max_size=4, unique=True),
)
def test_linear_gaussian_join_with_labels_equals_full_filter_for_any_split(seed, cuts):
    """The same with label association, for random problems and any split into 2–5 local
    maps (a local map may hold a single step)."""
    maps, full, gm = _split_and_join(seed, tuple(cuts), "known")
    _assert_equals_full_filter(maps, full, gm)


def test_linear_gaussian_join_without_fusion_keeps_every_duplicate():
    """Control: without fusion the joined map differs from the full filter (duplicates
    kept, the later map's copies less certain), so the test above can fail."""
    steps, Q2, Rz = _linear_problem(0)
    locs = [_LinearKF()]
    for t, (u, ids, z) in enumerate(steps):
        if t == 12:
            locs.append(_LinearKF())
        locs[-1].predict(u, Q2)
        locs[-1].observe(ids, z, Rz)
    gm = join_local_maps([LocalMap(f.x, f.P, np.array(f.ids)) for f in locs], fusion="none")
    assert gm.n_fused == 0
    assert gm.n_landmarks == sum(len(f.ids) for f in locs)


# --------------------------------------------------------------------------- joining


def _random_local_maps(rng, sizes):
    maps = []
    for m in sizes:
        n = 3 + 2 * m
        A = rng.normal(size=(n, n)) * 0.1
        P = A @ A.T + 1e-3 * np.eye(n)
        x = np.concatenate(
            [rng.normal(size=2) * 10, [rng.uniform(-3, 3)], rng.normal(size=2 * m) * 20]
        )
        maps.append(LocalMap(x, P, np.arange(m) + 100 * len(maps)))
    return maps


def test_joined_covariance_is_first_order_propagation_with_numerical_jacobian():
    """Second implementation of the full joint covariance: ``G D Gᵀ`` with ``D`` the
    block-diagonal covariance of the independent local maps and ``G`` the central
    finite-difference Jacobian of the joined means (cross-map correlations through the
    chain of bases included)."""
    rng = np.random.default_rng(3)
    maps = _random_local_maps(rng, [3, 2, 4])
    gm = join_local_maps(maps, fusion="none")
    s0 = np.concatenate([m.x for m in maps])
    sizes = np.cumsum([0] + [m.x.size for m in maps])

    def f(s):
        ms = [LocalMap(s[a:b], m.P, m.labels) for a, b, m in zip(sizes[:-1], sizes[1:], maps)]
        return join_local_maps(ms, fusion="none").x

    h = 1e-6
    G = np.empty((gm.x.size, s0.size))
    for c in range(s0.size):  # finite differences, column by column (test only)
        e = np.zeros(s0.size)
        e[c] = h
        G[:, c] = (f(s0 + e) - f(s0 - e)) / (2 * h)
    D = np.zeros((s0.size, s0.size))
    for a, b, m in zip(sizes[:-1], sizes[1:], maps):
        D[a:b, a:b] = m.P
    np.testing.assert_allclose(gm.P, G @ D @ G.T, atol=1e-6)
    # the cross-map blocks are not zero: the correlations the chain view ignores
    assert np.abs(gm.P[3:9, 9:13]).max() > 1e-3


def test_compose_pose_equals_ekf_prediction():
    """Origin ⊕ local pose with independent covariances = an EKF prediction of the origin
    by the local pose used as an odometry increment (second implementation)."""
    o, Po = np.array([3.0, -1.0, 0.7]), np.diag([0.1, 0.2, 0.01])
    v, Pv = np.array([5.0, 2.0, -0.3]), np.diag([0.3, 0.1, 0.02])
    x1, P1 = compose_pose(o, Po, v, Pv)
    x2, P2 = predict(o, Po, v, Pv)
    np.testing.assert_allclose(x1, x2)
    np.testing.assert_allclose(P1, P2)


def test_one_large_submap_equals_plain_aekf_full_covariance(run):
    """One local map of unlimited size: the joined map is the plain AEKF's full state
    (both with Bailey's reference settings; the plain AEKF's default is the consistent
    preset)."""
    a = AEKFSlam(preset="reference")
    b = make_estimator("aekf-submap", max_landmarks=10_000, preset="reference")
    for i in range(300):
        for f in (a, b):
            f.predict(run.odometry(i))
            f.update(run.observations(i))
    assert b.n_submaps == 1
    np.testing.assert_allclose(b.pose()[0], a.pose()[0])
    np.testing.assert_allclose(b.pose()[1], a.pose()[1], atol=1e-15)
    np.testing.assert_allclose(b.landmarks()[0], a.landmarks()[0])
    gm = b.join()
    np.testing.assert_allclose(gm.x, a.x)
    np.testing.assert_allclose(gm.P, a.P, atol=1e-12)
    np.testing.assert_array_equal(b.labels, a.labels)


def test_small_submaps_bound_the_local_state_and_joined_marginals_match_chain(run):
    """With small local maps: the local state stays bounded; the join without fusion has
    the chain view's means and marginal covariances (second implementation: origin ⊕ point
    per local map); the fused map has fewer landmarks, all labels distinct, and lies
    within 3σ of the truth."""
    f = SubmapAEKFSlam(max_landmarks=8, jacobians="fej")
    for i in range(run.n_scans):
        f.predict(run.odometry(i))
        f.update(run.observations(i))
        assert f.local.n_landmarks <= 8
    assert f.n_submaps >= 3
    chain, chain_cov = f.chain_landmarks()
    plain = f.join(fusion="none")
    np.testing.assert_allclose(plain.landmarks()[0], chain, atol=1e-9)
    np.testing.assert_allclose(plain.landmarks()[1], chain_cov, atol=1e-9)
    np.testing.assert_array_equal(plain.labels, f.chain_labels)
    lm, cov = f.landmarks()
    assert lm.shape[0] == f.labels.size < chain.shape[0]
    assert np.unique(f.labels).size == f.labels.size  # no duplicate left
    e = run.landmarks[f.labels] - lm
    d2 = np.einsum("ni,nij,nj->n", e, np.linalg.inv(cov), e)
    assert np.mean(d2 <= 9.0) >= 0.9


def test_incremental_join_of_the_filter_equals_joining_from_scratch(run):
    """The filter joins frozen maps incrementally (MapJoiner, cached) and adds the live map
    to a copy; the same local maps joined from scratch give the same global map. With
    ``join_at_switch`` the landmarks are the same and the running pose is the fused base
    (the joined vehicle at the last switch) ⊕ the live local pose."""
    f = SubmapAEKFSlam(max_landmarks=8, jacobians="fej")
    g = SubmapAEKFSlam(max_landmarks=8, jacobians="fej", join_at_switch=True)
    for i in range(run.n_scans):
        for e in (f, g):
            e.predict(run.odometry(i))
            e.update(run.observations(i))
        if i == run.n_scans // 2:
            f.join()  # a join half way: the cache must follow the later maps
    a = f.join()
    b = join_local_maps(f.local_maps())
    np.testing.assert_allclose(a.x, b.x, atol=1e-9)
    np.testing.assert_allclose(a.P, b.P, atol=1e-9)
    np.testing.assert_array_equal(a.labels, b.labels)
    np.testing.assert_allclose(g.landmarks()[0], f.landmarks()[0], atol=1e-9)
    base = join_local_maps(g.frozen)
    xp, Pp = compose_pose(base.x[:3], base.P[:3, :3], *g.local.pose())
    np.testing.assert_allclose(g.pose()[0], xp, atol=1e-9)
    np.testing.assert_allclose(g.pose()[1], Pp, atol=1e-12)
    assert not np.allclose(f.pose()[0], g.pose()[0], atol=1e-3)  # fusion moved the base


@pytest.fixture(scope="module")
def dense_loop_result():
    """``run_once`` on the dense loop (Bailey's dt 0.025 s), made once per module and
    parameters: the chain of local maps of seed 0 is checked by two tests."""
    spec = get_experiment("dense-loop")
    done = {}

    def get(filter_name: str, seed: int, params: dict):
        key = (filter_name, seed, tuple(sorted(params.items())))
        if key not in done:
            done[key] = run_once(spec, filter_name, seed, params)
        return done[key]

    return get


def test_join_at_switch_corrects_the_running_pose_on_the_dense_loop(dense_loop_result):
    """Chain pose vs fused base on the dense loop (seed 0, local maps of 8): the running
    pose with ``join_at_switch`` gets the loop closures, so its trajectory error is
    smaller (measured seeds 0–9: ATE median 3.8 m against 6.4 m for the chain; single map
    3.4 m); the landmark map is the same."""
    p = {"preset": "consistent", "max_landmarks": 8}
    chain = dense_loop_result("aekf-submap", 0, p)
    fused = dense_loop_result("aekf-submap", 0, {**p, "join_at_switch": True})
    assert fused.ate < 0.5 * chain.ate
    np.testing.assert_allclose(fused.lm_est, chain.lm_est, atol=1e-9)


# --------------------------------------------------------------------------- dense loop


def _dense_loop(result, seeds, params):
    rows = []
    for seed in seeds:
        single = result("aekf", seed, params)
        joined = result("aekf-submap", seed, {**params, "max_landmarks": 8})
        rows.append((single, joined))
    return rows


@pytest.mark.parametrize("seed", [0, 1])
def test_dense_loop_joined_map_has_no_duplicates_and_single_map_accuracy(seed, dense_loop_result):
    """Dense loop (2 loops, 30 landmarks seen), "consistent" preset, local maps of 8
    landmarks (10 local maps, 73 landmarks in the chain): the joined map has exactly one
    landmark per true landmark and >= 90 % of them inside 3σ. RMSE bound per run: 2.5×
    the single-map AEKF on the same data — measured over seeds 0–19 the ratio has median
    1.09 and worst 2.39 (seed 1, tested here, where the single map is unusually good,
    0.38 m against 0.90 m joined); the sub-maps see the same data, but linearize the
    composition of local maps at different points than the single map, so they agree
    statistically, not exactly. The median is checked by the slow test."""
    ((single, joined),) = _dense_loop(dense_loop_result, [seed], {"preset": "consistent"})
    assert joined.n_duplicates == 0 and joined.n_missed == 0
    assert joined.n_landmarks == joined.n_true_seen
    assert joined.landmark_rmse <= 2.5 * single.landmark_rmse
    assert joined.frac_in_3sigma >= 0.9


@pytest.mark.slow
def test_dense_loop_joined_map_over_20_runs(dense_loop_result):
    """20 runs: no duplicates in any, median RMSE ratio joined / single map <= 1.3 (measured
    1.09), mean fraction of landmarks inside 3σ >= 0.9 (measured 0.937; single map 0.968)."""
    rows = _dense_loop(dense_loop_result, range(20), {"preset": "consistent"})
    ratio = np.array([j.landmark_rmse / s.landmark_rmse for s, j in rows])
    assert all(j.n_duplicates == 0 for _, j in rows)
    assert np.median(ratio) <= 1.3
    assert np.mean([j.frac_in_3sigma for _, j in rows]) >= 0.9


# --------------------------------------------------------------------------- bad input


def test_bad_input_is_rejected_with_the_field_named():
    rng = np.random.default_rng(0)
    good = _random_local_maps(rng, [2])[0]
    with pytest.raises(ValueError, match="non-empty sequence"):
        join_local_maps([])
    with pytest.raises(ValueError, match="non-empty sequence"):
        join_local_maps(good)
    with pytest.raises(ValueError, match=r"maps\[1\] must be a LocalMap"):
        join_local_maps([good, (good.x, good.P)])
    with pytest.raises(ValueError, match="fusion must be one of"):
        join_local_maps([good], fusion="icp")
    with pytest.raises(ValueError, match="gate"):
        join_local_maps([good], gate=-1.0)
    with pytest.raises(ValueError, match="gate"):
        join_local_maps([good], gate=float("nan"))
    with pytest.raises(ValueError, match="iterations"):
        join_local_maps([good], iterations=0)
    with pytest.raises(ValueError, match=r"LocalMap.x must have shape"):
        LocalMap(np.zeros(4), np.zeros((4, 4)))
    with pytest.raises(ValueError, match=r"LocalMap.P must have shape"):
        LocalMap(np.zeros(5), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="finite"):
        LocalMap(np.full(5, np.nan), np.eye(5))
    with pytest.raises(ValueError, match="symmetric"):
        LocalMap(np.zeros(5), np.triu(np.ones((5, 5))))
    with pytest.raises(ValueError, match="negative variance"):
        LocalMap(np.zeros(5), -np.eye(5))
    with pytest.raises(ValueError, match="labels"):
        LocalMap(np.zeros(5), np.eye(5), np.array([1, 2]))
    with pytest.raises(ValueError, match="max_landmarks"):
        SubmapAEKFSlam(max_landmarks=0)
    with pytest.raises(ValueError, match="fusion"):
        SubmapAEKFSlam(fusion="nearest")
    with pytest.raises(ValueError, match="output"):
        SubmapAEKFSlam(output="global")
    with pytest.raises(ValueError, match="fusion_gate"):
        SubmapAEKFSlam(fusion_gate=0.0)
    with pytest.raises(ValueError, match="preset"):
        SubmapAEKFSlam(preset="fast")
    with pytest.raises(ValueError, match="join_at_switch"):
        SubmapAEKFSlam(join_at_switch="yes")
