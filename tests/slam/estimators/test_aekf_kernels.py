"""The compiled AEKF bookkeeping and the JCBB joint covariance against straightforward
references: the state reduction's miss counting against the NumPy formulation it replaced
(footprint from ``hypot``/``arctan2``, excuses, removal rules) on random states, and the
pair covariance against ``H P Hᵀ + R`` with the full (2c × N) Jacobian."""

from __future__ import annotations

import math

import numpy as np
import pytest

from slam.estimators.aekf_kernels import count_misses
from slam.estimators.jcbb import _pair_covariance
from slam.estimators.rb_model import observe, wrap


def _reference_misses(x, seen, compatible, hits, misses, r_max, b_max, max_m, prov_m):
    n = misses.size
    lm = x[3:].reshape(n, 2)
    d = lm - x[:2]
    r = np.hypot(d[:, 0], d[:, 1])
    b = np.abs(wrap(np.arctan2(d[:, 1], d[:, 0]) - x[2]))
    inside = (r < r_max) & (b < b_max)
    misses = misses.copy()
    misses[seen] = 0
    miss = inside & ~seen
    provisional = hits < 2
    if compatible is not None:
        excuse = compatible.copy()
        if prov_m is not None:
            excuse &= ~provisional[: compatible.size]
        miss[: compatible.size] &= ~excuse
    misses[miss] += 1
    drop = np.zeros(n, dtype=bool)
    if max_m is not None:
        drop |= misses >= max_m
    if prov_m is not None:
        drop |= provisional & (misses >= prov_m)
    return misses, drop


@pytest.mark.parametrize(("max_m", "prov_m"), [(None, 3), (4, None), (2, 1)])
def test_count_misses_equals_numpy_reference(rng, max_m, prov_m):
    for _ in range(200):
        n = int(rng.integers(1, 40))
        x = np.concatenate([rng.normal(0, 5, 2), [rng.uniform(-4, 4)], rng.normal(0, 25, 2 * n)])
        assoc = rng.integers(-1, n, int(rng.integers(0, 5)))  # the scan's associations
        seen = np.zeros(n, dtype=bool)
        seen[assoc[assoc >= 0]] = True
        m_c = int(rng.integers(0, n + 1))
        compatible = rng.random(m_c) < 0.3 if rng.random() < 0.8 else None
        hits = rng.integers(1, 4, n)
        misses = rng.integers(0, 4, n)
        args = (27.0, math.radians(80.0))
        ref_misses, ref_drop = _reference_misses(
            x, seen, compatible, hits, misses, *args, max_m, prov_m
        )
        got = misses.copy()
        drop, n_drop = count_misses(
            x,
            assoc,
            np.zeros(0, bool) if compatible is None else compatible,
            hits,
            got,
            *args,
            -1 if max_m is None else max_m,
            -1 if prov_m is None else prov_m,
        )
        assert np.array_equal(got, ref_misses)
        assert np.array_equal(drop, ref_drop)
        assert n_drop == ref_drop.sum()


def test_pair_covariance_equals_full_jacobian_product(rng):
    n = 6
    N = 3 + 2 * n
    x = np.concatenate([[1.0, -2.0, 0.3], rng.normal(0, 15, 2 * n)])
    A = rng.normal(size=(N, N))
    P = A @ A.T * 0.01
    z = np.column_stack([rng.uniform(5, 20, 3), rng.uniform(-1, 1, 3)])
    R = np.array([np.diag([0.1, 0.01]), np.diag([0.2, 0.02]), np.diag([0.3, 0.03])])
    obs = np.array([0, 0, 1, 2])
    lms = np.array([1, 4, 4, 5])
    nu, S = _pair_covariance(x, P, z, R, obs, lms)
    zhat, Hv, Hm = observe(x, lms)
    H = np.zeros((2 * obs.size, N))
    for a, lm in enumerate(lms):
        H[2 * a : 2 * a + 2, :3] = Hv[a]
        H[2 * a : 2 * a + 2, 3 + 2 * lm : 5 + 2 * lm] = Hm[a]
    Rb = np.zeros_like(S)
    for a in range(obs.size):
        for b in range(obs.size):
            if obs[a] == obs[b]:
                Rb[2 * a : 2 * a + 2, 2 * b : 2 * b + 2] = R[obs[a]]
    expected = H @ P @ H.T + Rb
    np.testing.assert_allclose(S, expected, rtol=1e-12, atol=1e-12)
    assert np.array_equal(S, S.T)
    y = z[obs] - zhat
    y[:, 1] = wrap(y[:, 1])
    np.testing.assert_allclose(nu, y.reshape(-1), rtol=0, atol=1e-12)
