"""The one joint-compatibility search (slam.estimators.jcbb.jcbb_search) against a
brute-force enumeration of every hypothesis, and both of its users (a scan's association
and the fleet's map-to-map association) against the same enumeration."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.stats import chi2

from slam.estimators.jcbb import jcbb_search
from slam.fleet.association import pair_maps


def _enumerate(obs, lms, nu, S, k, limits):
    """Every injective assignment of items to targets through the candidate pairs whose
    every prefix (in item order) passes the joint test; returns the best size, the
    smallest joint NIS of that size, the hypothesis that has it and every hypothesis of
    that size (as pair-id sets)."""
    by_item = [[a for a in range(obs.size) if obs[a] == i] + [None] for i in range(k)]
    best_n, best_d2, best, ties = 0, 0.0, frozenset(), []
    for choice in itertools.product(*by_item):
        sel, ok, d2 = [], True, 0.0
        for a in choice:
            if a is None:
                continue
            if any(lms[b] == lms[a] for b in sel):
                ok = False
                break
            sel.append(a)
            rows = np.concatenate([[2 * b, 2 * b + 1] for b in sel])
            d2 = float(nu[rows] @ np.linalg.solve(S[np.ix_(rows, rows)], nu[rows]))
            if d2 >= limits[len(sel) - 1]:
                ok = False
                break
        if not ok or not sel:
            continue
        if len(sel) > best_n:
            best_n, best_d2, best, ties = len(sel), d2, frozenset(sel), []
        if len(sel) == best_n:
            ties.append(frozenset(sel))
            if d2 < best_d2:
                best_d2, best = d2, frozenset(sel)
    return best_n, best_d2, best, ties


def _problem(rng):
    k, n = int(rng.integers(1, 5)), int(rng.integers(1, 5))
    pairs = [(i, j) for i in range(k) for j in range(n) if rng.random() < 0.6]
    if not pairs:
        pairs = [(0, 0)]
    obs = np.array([p[0] for p in pairs])
    lms = np.array([p[1] for p in pairs])
    c = obs.size
    A = rng.normal(size=(2 * c, 2 * c)) * 0.4
    S = A @ A.T + np.eye(2 * c)
    nu = rng.normal(size=2 * c) * rng.uniform(0.5, 2.0)
    score = rng.random(c)
    return obs, lms, score, nu, S, k


@pytest.mark.parametrize("seed", range(40))
def test_search_equals_brute_force_enumeration(seed):
    rng = np.random.default_rng(seed)
    obs, lms, score, nu, S, k = _problem(rng)
    limits = chi2.ppf(0.99, 2 * np.arange(1, k + 1))
    n, d2, best, ties = _enumerate(obs, lms, nu, S, k, limits)
    pairs, amb, nis, _, complete = jcbb_search(obs, lms, score, nu, S, k, limits, 10**6, False)
    assert complete
    assert int((pairs >= 0).sum()) == n
    assert nis == pytest.approx(d2, rel=1e-9, abs=1e-12)
    assert not amb.any()
    # with ambiguity rejection: exactly the pairings every best-size hypothesis shares
    pairs, amb, _, _, _ = jcbb_search(obs, lms, score, nu, S, k, limits, 10**6, True)
    common = frozenset.intersection(*ties) if ties else frozenset()
    expect = np.full(k, -1)
    for a in common:
        expect[obs[a]] = lms[a]
    np.testing.assert_array_equal(pairs, expect)
    expect_amb = {int(obs[a]) for a in best - common} if len(ties) > 1 else set()
    assert set(np.nonzero(amb)[0].tolist()) == expect_amb


@pytest.mark.parametrize("seed", range(15))
def test_map_pairing_equals_enumeration_of_map_differences(seed):
    """pair_maps builds the candidate differences of two maps (G_i − g_j, covariance
    Σ_G + C_g blocks) and searches them; the enumeration here builds them anew."""
    rng = np.random.default_rng(100 + seed)
    n, m = int(rng.integers(1, 5)), int(rng.integers(1, 5))
    G = rng.uniform(-4, 4, (n, 2))
    g = G[rng.integers(0, n, m)] + rng.normal(0, 0.8, (m, 2))
    A = rng.normal(size=(2 * n, 2 * n)) * 0.3
    B = rng.normal(size=(2 * m, 2 * m)) * 0.3
    SG, Cg = A @ A.T + 0.2 * np.eye(2 * n), B @ B.T + 0.2 * np.eye(2 * m)
    res = pair_maps(G, SG, g, Cg, reject_ambiguous=False)
    limits = chi2.ppf(0.99, 2 * np.arange(1, m + 1))
    best_n, best_d2 = 0, 0.0
    for choice in itertools.product(*[[-1, *range(n)]] * m):
        used = [c for c in choice if c >= 0]
        if not used or len(set(used)) != len(used):
            continue
        sel = [(j, i) for j, i in enumerate(choice) if i >= 0]
        ok, d2 = True, 0.0
        for p in range(1, len(sel) + 1):  # every prefix passes (individual gate first)
            rj = np.concatenate([[2 * j, 2 * j + 1] for j, _ in sel[:p]])
            ri = np.concatenate([[2 * i, 2 * i + 1] for _, i in sel[:p]])
            d = np.concatenate([G[i] - g[j] for j, i in sel[:p]])
            Sp = SG[np.ix_(ri, ri)] + Cg[np.ix_(rj, rj)]
            d2 = float(d @ np.linalg.solve(Sp, d))
            j, i = sel[p - 1]
            d1 = G[i] - g[j]
            S1 = SG[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] + Cg[2 * j : 2 * j + 2, 2 * j : 2 * j + 2]
            if d2 >= limits[p - 1] or d1 @ np.linalg.solve(S1, d1) >= limits[0]:
                ok = False
                break
        if ok and (len(sel) > best_n or (len(sel) == best_n and d2 < best_d2)):
            best_n, best_d2 = len(sel), d2
    assert int((res.pairs >= 0).sum()) == best_n
    assert res.joint_nis == pytest.approx(best_d2, rel=1e-9, abs=1e-12)
