"""Joint compatibility branch and bound against a brute-force enumeration (a second
implementation with dense H matrices) and against hand-made clustered cases."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2
from slam_reference_models import observe_state_landmark as _h

from slam.estimators.aekf import AEKFSlam, association_scores
from slam.estimators.jcbb import jcbb

R = np.diag([0.1**2, math.radians(1.0) ** 2])


def _dense_H(x, j):
    """Dense 2 × N Jacobian of the observation of landmark j (written out anew)."""
    d = x[3 + 2 * j : 5 + 2 * j] - x[:2]
    q = d @ d
    r = math.sqrt(q)
    H = np.zeros((2, x.size))
    H[:, :3] = [[-d[0] / r, -d[1] / r, 0.0], [d[1] / q, -d[0] / q, -1.0]]
    H[:, 3 + 2 * j : 5 + 2 * j] = [[d[0] / r, d[1] / r], [-d[1] / q, d[0] / q]]
    return H


def _brute_force(x, P, z, confidence):
    """Every injective partial assignment of observations to landmarks whose pairs are
    individually and jointly compatible; the most pairs, then the smallest joint NIS."""
    k, n = z.shape[0], (x.size - 3) // 2
    gate1 = chi2.ppf(confidence, 2)
    best = (0, 0.0, {})
    for choice in itertools.product(range(-1, n), repeat=k):
        used = [c for c in choice if c >= 0]
        if len(used) != len(set(used)) or not used:
            continue
        pairs = [(i, c) for i, c in enumerate(choice) if c >= 0]
        H = np.vstack([_dense_H(x, c) for _, c in pairs])
        nu = np.concatenate([z[i] - _h(x, c) for i, c in pairs])
        nu[1::2] = (nu[1::2] + np.pi) % (2 * np.pi) - np.pi
        S = H @ P @ H.T + np.kron(np.eye(len(pairs)), R)
        ok = all(
            (
                nu[2 * a : 2 * a + 2]
                @ np.linalg.solve(S[2 * a : 2 * a + 2, 2 * a : 2 * a + 2], nu[2 * a : 2 * a + 2])
            )
            < gate1
            for a in range(len(pairs))
        )
        d2 = float(nu @ np.linalg.solve(S, nu))
        if not ok or d2 >= chi2.ppf(confidence, 2 * len(pairs)):
            continue
        if len(pairs) > best[0] or (len(pairs) == best[0] and d2 < best[1]):
            best = (len(pairs), d2, dict(pairs))
    out = np.full(k, -1)
    for i, c in best[2].items():
        out[i] = c
    return out, best[1]


def _clustered_problem(rng, n_lm=4, k=3, pose_sd=1.5):
    """Landmarks 3-6 m apart ahead of a vehicle whose pose uncertainty spans them."""
    lm = np.array([10.0, -4.0]) + rng.uniform(0, 1, (n_lm, 2)) * [8.0, 8.0]
    x_true = np.concatenate([[0.0, 0.0, 0.0], lm.reshape(-1)])
    P = np.zeros((x_true.size, x_true.size))
    P[:3, :3] = np.diag([pose_sd**2, pose_sd**2, 0.03**2])
    P[3:, 3:] = 0.05**2 * np.eye(2 * n_lm)
    err = rng.multivariate_normal(np.zeros(x_true.size), P)
    x_est = x_true + err
    seen = rng.choice(n_lm, size=min(k, n_lm), replace=False)
    z = np.array([_h(x_true, j) for j in seen]) + rng.normal(0, np.sqrt(np.diag(R)), (seen.size, 2))
    return x_est, P, z, seen


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n_lm=st.integers(2, 4), k=st.integers(1, 3))
def test_branch_and_bound_equals_brute_force_enumeration(seed, n_lm, k):
    """Branch and bound prunes; it must still return the hypothesis the exhaustive search
    finds (most pairings, then smallest joint NIS)."""
    x, P, z, _ = _clustered_problem(np.random.default_rng(seed), n_lm, k)
    res = jcbb(x, P, z, R, confidence=0.99, reject_ambiguous=False)
    expect, d2 = _brute_force(x, P, z, 0.99)
    assert res.complete
    assert np.sum(res.pairs >= 0) == np.sum(expect >= 0)
    assert res.joint_nis == pytest.approx(d2, rel=1e-6, abs=1e-9)
    np.testing.assert_array_equal(res.pairs, expect)


def test_shared_pose_error_is_resolved_jointly_where_individual_gating_fails():
    """Two landmarks 3 m apart, the vehicle's position estimate 2.9 m off (inside its
    σ = 2 m uncertainty): the observation of L1 falls on L2's predicted position, so
    nearest-neighbour gating pairs it with L2 and cannot place L2's own observation. The
    joint test sees one pose offset explaining both: L1 → L1, L2 → L2."""
    lm = np.array([[15.0, 0.0], [15.0, 3.0]])
    x_true = np.concatenate([[0.0, 0.0, 0.0], lm.reshape(-1)])
    x_est = x_true.copy()
    x_est[1] += 2.9  # estimate 2.9 m north: everything appears 2.9 m further south
    P = np.zeros((7, 7))
    P[:3, :3] = np.diag([4.0, 4.0, 1e-4])
    P[3:, 3:] = 0.01 * np.eye(4)
    z = np.array([_h(x_true, 0), _h(x_true, 1)])
    nis, _ = association_scores(x_est, P, z, R)
    assert np.argmin(nis[0]) == 1  # individually, L1's observation looks like L2
    res = jcbb(x_est, P, z, R)
    np.testing.assert_array_equal(res.pairs, [0, 1])
    assert not res.ambiguous.any()


def test_single_observation_between_two_landmarks_is_ambiguous_not_forced():
    """One observation, two landmarks 4 m apart, pose uncertainty σ = 3 m (a loop closure
    seen once): both pairings pass the joint test, so neither is taken and the observation
    is not a new landmark either; with ambiguity rejection off the better one is taken."""
    lm = np.array([[20.0, 0.0], [20.0, 4.0]])
    x = np.concatenate([[0.0, 1.0, 0.0], lm.reshape(-1)])
    P = np.zeros((7, 7))
    P[:3, :3] = np.diag([9.0, 9.0, 1e-4])
    P[3:, 3:] = 0.01 * np.eye(4)
    z = np.array([_h(np.concatenate([[0.0, 0.0, 0.0], lm.reshape(-1)]), 0)])
    res = jcbb(x, P, z, R)
    assert res.pairs.tolist() == [-1] and res.ambiguous.tolist() == [True]
    forced = jcbb(x, P, z, R, reject_ambiguous=False)
    assert forced.pairs.tolist() in ([0], [1])


def test_aekf_with_jcbb_neither_pairs_nor_augments_an_ambiguous_observation():
    lm = np.array([[20.0, 0.0], [20.0, 4.0]])
    f = AEKFSlam(association="jcbb")
    f.x = np.concatenate([[0.0, 1.0, 0.0], lm.reshape(-1)])
    f.P = np.zeros((7, 7))
    f.P[:3, :3] = np.diag([9.0, 9.0, 1e-4])
    f.P[3:, 3:] = 0.01 * np.eye(4)
    f._lm_first = lm.copy()
    f.labels = np.array([-1, -1])
    f.ids = np.array([0, 1])
    f._next_id = 2
    f.misses = np.zeros(2, np.int64)
    f.hits = np.ones(2, np.int64)
    x_before = f.x.copy()
    res = f.update_arrays([_h(np.concatenate([[0.0, 0.0, 0.0], lm.reshape(-1)]), 0)], R)
    assert res.associations.tolist() == [-1] and not res.new.any()
    np.testing.assert_array_equal(f.x, x_before)


def test_no_landmarks_or_no_candidates_pair_nothing():
    x = np.array([0.0, 0.0, 0.0])
    res = jcbb(x, np.zeros((3, 3)), [[10.0, 0.1]], R)
    assert res.pairs.tolist() == [-1]
    x2 = np.array([0.0, 0.0, 0.0, 50.0, 50.0])
    res = jcbb(x2, 0.01 * np.eye(5), [[10.0, 0.1]], R)
    assert res.pairs.tolist() == [-1] and not res.ambiguous.any()


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"confidence": 1.0}, "confidence"),
        ({"confidence": 0.0}, "confidence"),
        ({"max_nodes": 0}, "max_nodes"),
    ],
)
def test_bad_parameters_rejected(kw, match):
    with pytest.raises(ValueError, match=match):
        jcbb(np.zeros(3), np.zeros((3, 3)), [[10.0, 0.0]], R, **kw)
    if "confidence" in kw:
        with pytest.raises(ValueError, match="jcbb_confidence"):
            AEKFSlam(association="jcbb", jcbb_confidence=kw["confidence"])
