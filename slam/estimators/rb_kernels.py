"""Compiled association scores of the range-bearing model (:mod:`slam.estimators.rb_model`)
for the AEKF's gated association and JCBB: per landmark a 2 × 2 innovation covariance
from the 5 × 5 pose-and-landmark blocks of P, per observation–landmark pair its NIS.
Loops compiled by numba (``cache=True``); float64 / intp C-contiguous arrays (the
wrappers make them so). Units: ranges m, bearings rad; state as in ``rb_model``."""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = [
    "jcbb_easy",
    "joint_nis",
    "landmark_jacobian",
    "nis_scores",
    "pair_covariance",
    "wrap_angle",
]

_TWO_PI = 2.0 * math.pi


@numba.njit(cache=True, inline="always")
def wrap_angle(a):
    """Angle wrapped to [-pi, pi) (rad), as ``rb_model.wrap``."""
    return (a + math.pi) % _TWO_PI - math.pi


@numba.njit(cache=True, inline="always")
def landmark_jacobian(xl, i):
    """Non-zero Jacobian block ``Hm`` (2, 2) of landmark i at state ``xl`` as its entries
    ``(m00, m01, m10, m11)``; the vehicle block is ``Hv = [-Hm | (0, -1)ᵀ]``."""
    c = 3 + 2 * i
    dx, dy = xl[c] - xl[0], xl[c + 1] - xl[1]
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    return dx / r, dy / r, -dy / q, dx / q


@numba.njit(cache=True)
def _landmark_S0(P, i, m00, m01, m10, m11):
    """``H P Hᵀ`` (2, 2) of landmark i with ``H = [Hv | Hm]`` over the 5 columns (pose,
    landmark): returns (s00, s01, s10, s11)."""
    c = 3 + 2 * i
    cols = (0, 1, 2, c, c + 1)
    h0 = (-m00, -m01, 0.0, m00, m01)
    h1 = (-m10, -m11, -1.0, m10, m11)
    t0 = np.zeros(5)  # h0 P_sub, h1 P_sub
    t1 = np.zeros(5)
    for b in range(5):
        cb = cols[b]
        a0 = 0.0
        a1 = 0.0
        for a in range(5):
            p = P[cols[a], cb]
            a0 += h0[a] * p
            a1 += h1[a] * p
        t0[b] = a0
        t1[b] = a1
    s00 = s01 = s10 = s11 = 0.0
    for b in range(5):
        s00 += t0[b] * h0[b]
        s01 += t0[b] * h1[b]
        s10 += t1[b] * h0[b]
        s11 += t1[b] * h1[b]
    return s00, s01, s10, s11


@numba.njit(cache=True)
def nis_scores(x, P, z, R, xl, ml):
    """``nis (k, n)`` = yᵀ S⁻¹ y of every observation ``z`` (k, 2) with covariance ``R``
    (k, 2, 2) against every landmark of ``x`` (Jacobians at ``xl``, innovations at ``x``),
    and ``nd (k, n)`` = nis + ln det S (filled only with ``ml``)."""
    k = z.shape[0]
    n = (x.size - 3) // 2
    nis = np.empty((k, n))
    nd = np.empty((k, n))
    for i in range(n):
        c = 3 + 2 * i
        dx, dy = x[c] - x[0], x[c + 1] - x[1]
        zr = math.hypot(dx, dy)
        zb = wrap_angle(math.atan2(dy, dx) - x[2])
        m00, m01, m10, m11 = landmark_jacobian(xl, i)
        s00, s01, s10, s11 = _landmark_S0(P, i, m00, m01, m10, m11)
        for j in range(k):
            a = s00 + R[j, 0, 0]
            b = 0.5 * ((s01 + R[j, 0, 1]) + (s10 + R[j, 1, 0]))
            d = s11 + R[j, 1, 1]
            det = a * d - b * b
            y0 = z[j, 0] - zr
            y1 = wrap_angle(z[j, 1] - zb)
            v = (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det
            nis[j, i] = v
            if ml:
                nd[j, i] = v + math.log(det)
    return nis, nd


@numba.njit(cache=True)
def pair_covariance(x, P, z, R, obs, lms):
    """Innovations ``nu`` (2c,) and joint covariance ``S`` (2c, 2c) of candidate pairs
    ``(obs[a], lms[a])``: ``S_ab = H_a P H_bᵀ + [obs_a = obs_b] R_obs``, symmetrized."""
    c = obs.size
    H = np.zeros((c, 2, 5))
    cols = np.empty((c, 5), np.intp)
    nu = np.empty(2 * c)
    for a in range(c):
        i = lms[a]
        ci = 3 + 2 * i
        dx, dy = x[ci] - x[0], x[ci + 1] - x[1]
        nu[2 * a] = z[obs[a], 0] - math.hypot(dx, dy)
        nu[2 * a + 1] = wrap_angle(z[obs[a], 1] - wrap_angle(math.atan2(dy, dx) - x[2]))
        m00, m01, m10, m11 = landmark_jacobian(x, i)
        H[a, 0, 0], H[a, 0, 1], H[a, 0, 3], H[a, 0, 4] = -m00, -m01, m00, m01
        H[a, 1, 0], H[a, 1, 1], H[a, 1, 2], H[a, 1, 3], H[a, 1, 4] = -m10, -m11, -1.0, m10, m11
        cols[a, 0], cols[a, 1], cols[a, 2], cols[a, 3], cols[a, 4] = 0, 1, 2, ci, ci + 1
    S0 = np.empty((2 * c, 2 * c))
    HP = np.empty((2, 5))
    for a in range(c):
        for b in range(c):
            for r in range(2):  # H_a P_ab (2, 5)
                for q in range(5):
                    s = 0.0
                    for p in range(5):
                        s += H[a, r, p] * P[cols[a, p], cols[b, q]]
                    HP[r, q] = s
            for r in range(2):
                for t in range(2):
                    s = 0.0
                    for q in range(5):
                        s += HP[r, q] * H[b, t, q]
                    if obs[a] == obs[b]:
                        s += R[obs[a], r, t]
                    S0[2 * a + r, 2 * b + t] = s
    S = np.empty((2 * c, 2 * c))
    for r in range(2 * c):
        for t in range(2 * c):
            S[r, t] = 0.5 * (S0[r, t] + S0[t, r])
    return nu, S


@numba.njit(cache=True)
def joint_nis(S, nu, rows):
    """``nuᵀ S⁻¹ nu`` over the index set ``rows`` of S and nu (Cholesky); -1.0 when that
    block of S is not positive definite."""
    m = rows.size
    L = np.zeros((m, m))
    w = np.empty(m)
    total = 0.0
    for i in range(m):
        for j in range(i + 1):
            s = S[rows[i], rows[j]]
            for c in range(j):
                s -= L[i, c] * L[j, c]
            if i == j:
                if not s > 0.0:
                    return -1.0
                L[i, i] = math.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
        s = nu[rows[i]]
        for c in range(i):
            s -= L[i, c] * w[c]
        w[i] = s / L[i, i]
        total += w[i] * w[i]
    return total


@numba.njit(cache=True)
def jcbb_easy(x, P, z, R, gate, limits):
    """The scans JCBB decides without a search, in one compiled call: individual NIS of
    every observation ``z`` (k, 2) against every landmark (:func:`nis_scores`), candidate
    pairs below ``gate``, and then — no candidate; one candidate with ``gate <=
    limits[0]``; or one candidate per observation, each landmark once, jointly compatible
    (``nuᵀ S⁻¹ nu < limits[c - 1]`` for c pairs) — the decided hypothesis.

    Returns ``(status, pairs (k,), nis (k, n), joint NIS, nodes)`` (nodes 0 without a
    candidate, else 1, as the search counts them); ``status`` 1 decided, 0 the branch and
    bound is needed, -1 the joint covariance of the one-each hypothesis is not positive
    definite (``pairs`` all -1 unless decided)."""
    k = z.shape[0]
    n = (x.size - 3) // 2
    pairs = np.full(k, -1, np.intp)
    if n == 0 or k == 0:
        return 1, pairs, np.empty((k, n)), 0.0, 0
    nis, _ = nis_scores(x, P, z, R, x, False)
    c = 0
    for j in range(k):
        for i in range(n):
            if nis[j, i] < gate:
                c += 1
    if c == 0:
        return 1, pairs, nis, 0.0, 0
    obs = np.empty(c, np.intp)
    lms = np.empty(c, np.intp)
    a = 0
    for j in range(k):  # row-major, as np.nonzero orders them
        for i in range(n):
            if nis[j, i] < gate:
                obs[a] = j
                lms[a] = i
                a += 1
    if c == 1 and gate <= limits[0]:
        pairs[obs[0]] = lms[0]
        return 1, pairs, nis, nis[obs[0], lms[0]], 1
    for a in range(c):
        for b in range(a):
            if obs[a] == obs[b] or lms[a] == lms[b]:
                return 0, pairs, nis, 0.0, 1
    nu, S = pair_covariance(x, P, z, R, obs, lms)
    d2 = joint_nis(S, nu, np.arange(2 * c))
    if d2 < 0.0:
        return -1, pairs, nis, 0.0, 1
    if not d2 < limits[c - 1]:
        return 0, pairs, nis, 0.0, 1
    for a in range(c):
        pairs[obs[a]] = lms[a]
    return 1, pairs, nis, d2, 1
