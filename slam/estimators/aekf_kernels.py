"""Compiled per-scan steps of the AEKF (:mod:`slam.estimators.aekf`).

At the dense loop's sizes (a state of 3 + 2n with n ≈ 30 landmarks, k ≤ 4 observations a
scan) every NumPy call costs more than its arithmetic, so the predict, the batch update's
gain, the covariance downdate, the input checks and the state reduction's bookkeeping are
loops compiled by numba (``cache=True``: compiled on first use, then loaded from disk).
They compute what the NumPy formulation computes, in another order of summation (equal to
~1e-15 relative; the tests compare them on random cases and on the dense loop).

Array arguments are float64 (``idx`` intp, masks bool) and C-contiguous: the wrappers in
:mod:`slam.estimators.aekf` make them so, which keeps one compiled signature per kernel.
Angles in rad, frames as in the filter: pose ``x[:3] = [x m, y m, phi rad]`` in the 2-D
world frame, landmark ``i`` at ``x[3 + 2i : 5 + 2i]``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from slam.estimators.rb_kernels import landmark_jacobian, wrap_angle

__all__ = [
    "OK",
    "add_step",
    "count_misses",
    "cov_status",
    "downdate",
    "ekf_gain",
    "jcbb_outcome",
    "obs_status",
    "odo_status",
    "predict_inplace",
    "surely_linear",
]

_TWO_PI = 2.0 * math.pi

#: status codes of :func:`cov_status` / :func:`obs_status` (0: valid)
OK = 0
NON_FINITE, NEGATIVE_VARIANCE, ASYMMETRIC, NOT_PSD, NOT_PD, BAD_Z = 1, 2, 3, 4, 5, 6


@numba.njit(cache=True)
def _cholesky_lower(A, L) -> bool:
    """``A = L Lᵀ`` into ``L`` (lower, zero above); False when A is not positive definite."""
    m = A.shape[0]
    for i in range(m):
        for j in range(i + 1):
            s = A[i, j]
            for c in range(j):
                s -= L[i, c] * L[j, c]
            if i == j:
                if not s > 0.0:
                    return False
                L[i, i] = math.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
        for j in range(i + 1, m):
            L[i, j] = 0.0
    return True


@numba.njit(cache=True)
def cov_status(C, tol):
    """Checks of a stack of covariances ``C`` (m, d, d), in the order and with the
    tolerances of ``aekf._check_cov``: finite, no negative variance, symmetric to ``tol``
    × scale (scale = max(1, max |C|)), positive semi-definite (d = 2: determinant ≥ −tol ×
    scale²; else every eigenvalue ≥ −tol × scale, tested as a Cholesky factorization of
    ``sym(C) + tol × scale / 2 × I``). Returns :data:`OK` or the first failing check's code;
    a failing PSD test for d > 2 may be a false alarm within the halved tolerance, which
    the caller settles with the eigenvalues."""
    m, d = C.shape[0], C.shape[1]
    big = 0.0
    for s in range(m):
        for i in range(d):
            for j in range(d):
                v = C[s, i, j]
                if not math.isfinite(v):
                    return NON_FINITE
                big = max(big, abs(v))
    for s in range(m):
        for i in range(d):
            if C[s, i, i] < 0.0:
                return NEGATIVE_VARIANCE
    scale = max(1.0, big)
    for s in range(m):
        for i in range(d):
            for j in range(d):
                if abs(C[s, i, j] - C[s, j, i]) > tol * scale:
                    return ASYMMETRIC
    if d == 2:
        for s in range(m):
            det = C[s, 0, 0] * C[s, 1, 1] - C[s, 0, 1] * C[s, 1, 0]
            if det < -tol * scale * scale:
                return NOT_PSD
    elif d > 0:
        A = np.empty((d, d))
        L = np.empty((d, d))
        for s in range(m):
            for i in range(d):
                for j in range(d):
                    A[i, j] = 0.5 * (C[s, i, j] + C[s, j, i])
                A[i, i] += 0.5 * tol * scale
            if not _cholesky_lower(A, L):
                return NOT_PSD
    return OK


@numba.njit(cache=True)
def obs_status(z, R, tol):
    """Checks of a scan's observations ``z`` (k, 2) [range m, bearing rad] and covariances
    ``R`` (k, 2, 2) in the order of ``aekf.as_observations``: z finite, ranges > 0, then R
    as :func:`cov_status`, then R positive definite (variances and determinant > 0)."""
    k = z.shape[0]
    for j in range(k):
        if not (math.isfinite(z[j, 0]) and math.isfinite(z[j, 1])):
            return BAD_Z
    for j in range(k):
        if z[j, 0] <= 0.0:
            return BAD_Z
    st = cov_status(R, tol)
    if st != OK:
        return st
    for j in range(k):
        det = R[j, 0, 0] * R[j, 1, 1] - R[j, 0, 1] * R[j, 1, 0]
        if R[j, 0, 0] <= 0.0 or R[j, 1, 1] <= 0.0 or det <= 0.0:
            return NOT_PD
    return OK


@numba.njit(cache=True)
def odo_status(u, Q, tol):
    """Checks of an odometry increment ``u`` (3,) and its covariance ``Q`` (3, 3): u finite
    (else :data:`BAD_Z`), then Q as :func:`cov_status`."""
    for i in range(u.size):
        if not math.isfinite(u[i]):
            return BAD_Z
    return cov_status(Q.reshape((1, *Q.shape)), tol)


@numba.njit(cache=True)
def predict_inplace(x, P, u, Q, ref):
    """Prediction (thesis eqs. 5.21–5.27) of ``x``, ``P`` in place from the body-frame
    increment ``u`` (3,) [m, m, rad] with covariance ``Q`` (3, 3); ``F = I + E(x_v' −
    ref)`` with the linearization pose ``ref`` (3,). Only ``P_v`` and ``P_vm`` change."""
    N = x.size
    phi = x[2]
    c, s = math.cos(phi), math.sin(phi)
    xn = x[0] + (c * u[0] - s * u[1])
    yn = x[1] + (s * u[0] + c * u[1])
    F = np.eye(3)
    F[0, 2] = -(yn - ref[1])
    F[1, 2] = xn - ref[0]
    G = np.zeros((3, 3))
    G[0, 0], G[0, 1], G[1, 0], G[1, 1], G[2, 2] = c, -s, s, c, 1.0
    FP = np.zeros((3, 3))
    GQ = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            a = 0.0
            b = 0.0
            for m in range(3):
                a += F[i, m] * P[m, j]
                b += G[i, m] * Q[m, j]
            FP[i, j] = a
            GQ[i, j] = b
    V = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            a = 0.0
            for m in range(3):
                a += FP[i, m] * F[j, m] + GQ[i, m] * G[j, m]
            V[i, j] = a
    for i in range(3):
        for j in range(3):
            P[i, j] = 0.5 * (V[i, j] + V[j, i])
    for col in range(3, N):
        p0, p1, p2 = P[0, col], P[1, col], P[2, col]
        for i in range(3):
            v = F[i, 0] * p0 + F[i, 1] * p1 + F[i, 2] * p2
            P[i, col] = v
            P[col, i] = v
    x[0], x[1], x[2] = xn, yn, wrap_angle(phi + u[2])


@numba.njit(cache=True)
def _rows_H(x, xl, idx, Hv, Hm, y, z):
    """Innovations ``y`` (2k,) at ``x`` (bearing wrapped) and the non-zero Jacobian blocks
    ``Hv`` (k, 2, 3), ``Hm`` (k, 2, 2) at the linearization state ``xl``."""
    for j in range(idx.size):
        c = 3 + 2 * idx[j]
        dx, dy = x[c] - x[0], x[c + 1] - x[1]
        y[2 * j] = z[j, 0] - math.hypot(dx, dy)
        y[2 * j + 1] = wrap_angle(z[j, 1] - wrap_angle(math.atan2(dy, dx) - x[2]))
        Hm[j, 0, 0], Hm[j, 0, 1], Hm[j, 1, 0], Hm[j, 1, 1] = landmark_jacobian(xl, idx[j])
        Hv[j, 0, 0], Hv[j, 0, 1], Hv[j, 0, 2] = -Hm[j, 0, 0], -Hm[j, 0, 1], 0.0
        Hv[j, 1, 0], Hv[j, 1, 1], Hv[j, 1, 2] = -Hm[j, 1, 0], -Hm[j, 1, 1], -1.0


@numba.njit(cache=True)
def ekf_gain(x, P, z, R, idx, xl):
    """The batch update's factors (eqs. 5.28–5.39) for observations ``z`` (k, 2) of
    landmarks ``idx`` (k,) with covariances ``R`` (k, 2, 2), Jacobians at ``xl`` (state
    sized; ``x`` itself for the standard EKF), only the non-zero columns of H: O(N k).

    Returns ``(ok, PHt (N, 2k), S (2k, 2k), L, W1 (N, 2k), step (N,))`` with ``S = H P Hᵀ
    + R`` (symmetrized) ``= L Lᵀ``, ``W1 = P Hᵀ L⁻ᵀ`` and the mean step ``W1 L⁻¹ y``; ``ok``
    is False when S is not positive definite (the rest is then undefined)."""
    N, k = x.size, idx.size
    m = 2 * k
    Hv = np.empty((k, 2, 3))
    Hm = np.empty((k, 2, 2))
    y = np.empty(m)
    _rows_H(x, xl, idx, Hv, Hm, y, z)
    PHt = np.empty((N, m))
    for n in range(N):
        for j in range(k):
            c = 3 + 2 * idx[j]
            pv0, pv1, pv2 = P[n, 0], P[n, 1], P[n, 2]
            pm0, pm1 = P[n, c], P[n, c + 1]
            for b in range(2):
                PHt[n, 2 * j + b] = (pv0 * Hv[j, b, 0] + pv1 * Hv[j, b, 1] + pv2 * Hv[j, b, 2]) + (
                    pm0 * Hm[j, b, 0] + pm1 * Hm[j, b, 1]
                )
    S0 = np.empty((m, m))
    for j in range(k):
        c = 3 + 2 * idx[j]
        for b in range(2):
            for col in range(m):
                S0[2 * j + b, col] = (
                    Hv[j, b, 0] * PHt[0, col]
                    + Hv[j, b, 1] * PHt[1, col]
                    + Hv[j, b, 2] * PHt[2, col]
                ) + (Hm[j, b, 0] * PHt[c, col] + Hm[j, b, 1] * PHt[c + 1, col])
    for j in range(k):
        for a in range(2):
            for b in range(2):
                S0[2 * j + a, 2 * j + b] += R[j, a, b]
    S = np.empty((m, m))
    for a in range(m):
        for b in range(m):
            S[a, b] = 0.5 * (S0[a, b] + S0[b, a])
    L = np.empty((m, m))
    W1 = np.empty((N, m))
    step = np.empty(N)
    if not _cholesky_lower(S, L):
        return False, PHt, S, L, W1, step
    for n in range(N):  # W1 = PHt L⁻ᵀ: forward substitution on each row
        for c in range(m):
            s = PHt[n, c]
            for a in range(c):
                s -= L[c, a] * W1[n, a]
            W1[n, c] = s / L[c, c]
    v = np.empty(m)  # L⁻¹ y
    for c in range(m):
        s = y[c]
        for a in range(c):
            s -= L[c, a] * v[a]
        v[c] = s / L[c, c]
    for n in range(N):
        s = 0.0
        for c in range(m):
            s += W1[n, c] * v[c]
        step[n] = s
    return True, PHt, S, L, W1, step


@numba.njit(cache=True)
def add_step(x, step):
    """``x += step`` in place, heading ``x[2]`` wrapped to [-pi, pi)."""
    for n in range(x.size):
        x[n] += step[n]
    x[2] = wrap_angle(x[2])


@numba.njit(cache=True)
def downdate(P, W1):
    """``P -= W1 W1ᵀ`` in place, one column of W1 at a time (contiguous inner loop). Entry
    (i, j) and (j, i) subtract the same products in the same order, so a symmetric P
    stays exactly symmetric."""
    N, m = W1.shape
    WT = np.ascontiguousarray(W1.T)
    for i in range(N):
        row = P[i]
        for c in range(m):
            w = WT[c, i]
            col = WT[c]
            for j in range(N):
                row[j] -= w * col[j]


@numba.njit(cache=True)
def surely_linear(x0, step, idx, R, gate):
    """True when a Taylor bound on the EKF step's linearization error (in units of R) is
    already <= ``gate``; see ``aekf._surely_linear`` for the bound."""
    total = 0.0
    for j in range(idx.size):
        c = 3 + 2 * idx[j]
        r = math.hypot(x0[c] - x0[0], x0[c + 1] - x0[1])
        ex, ey = step[c] - step[0], step[c + 1] - step[1]
        s2 = ex * ex + ey * ey
        r_min = r - math.sqrt(s2)
        a, b, d = R[j, 0, 0], R[j, 0, 1], R[j, 1, 1]
        lam = 0.5 * (a + d) - math.hypot(0.5 * (a - d), b)
        if r_min <= 0.0 or lam <= 0.0:
            return False
        e_r = 0.5 * s2 / r_min
        e_b = e_r / r_min
        total += (e_r * e_r + e_b * e_b) / lam
    return total <= gate


@numba.njit(cache=True)
def jcbb_outcome(scores, pairs, ambiguous, augment_gate):
    """From a JCBB result — ``scores`` (k, n) individual NIS, ``pairs`` (k,) landmark or
    -1, ``ambiguous`` (k,) — the filter's ``new`` (k,) (unpaired, not ambiguous, NIS above
    ``augment_gate`` for every landmark), ``nis`` (k,) of each pair (NaN unpaired) and
    ``compatible`` (n,) (some observation's NIS below ``augment_gate``)."""
    k, n = scores.shape
    new = np.zeros(k, np.bool_)
    nis = np.full(k, np.nan)
    compatible = np.zeros(n, np.bool_)
    for j in range(k):
        far = True
        for i in range(n):
            v = scores[j, i]
            if not v > augment_gate:
                far = False
            if v < augment_gate:
                compatible[i] = True
        if pairs[j] >= 0:
            nis[j] = scores[j, pairs[j]]
        else:
            new[j] = far and not ambiguous[j]
    return new, nis, compatible


@numba.njit(cache=True)
def count_misses(x, assoc, compatible, hits, misses, r_max, b_max, max_misses, provisional_misses):
    """Update the miss counters of the landmarks of state ``x`` in place; returns the
    (n,) bool mask of landmarks to remove and how many it flags.

    ``assoc`` (k,) is the landmark index each observation of the scan went to (-1: none).
    A landmark seen (associated this scan) gets 0 misses; one inside the footprint
    (range ``< r_max`` m and ``|bearing| < b_max`` rad from the pose ``x[:3]``) that is not
    seen and not excused gets one more. ``compatible`` (m <= n,) excuses the first m
    landmarks (some observation was within the augment gate) unless, with
    ``provisional_misses >= 0``, the landmark is provisional (``hits < 2``). Removed:
    ``misses >= max_misses`` (when ``>= 0``) or provisional with ``misses >=
    provisional_misses`` (when ``>= 0``)."""
    n = misses.size
    seen = np.zeros(n, np.bool_)
    for j in range(assoc.size):
        if assoc[j] >= 0:
            seen[assoc[j]] = True
    drop = np.zeros(n, np.bool_)
    n_drop = 0
    px, py, phi = x[0], x[1], x[2]
    for i in range(n):
        provisional = hits[i] < 2
        if seen[i]:
            misses[i] = 0
        else:
            dx = x[3 + 2 * i] - px
            dy = x[4 + 2 * i] - py
            if math.hypot(dx, dy) < r_max:
                b = abs((math.atan2(dy, dx) - phi + math.pi) % _TWO_PI - math.pi)
                excused = False
                if i < compatible.size:
                    excused = compatible[i] and not (provisional_misses >= 0 and provisional)
                if b < b_max and not excused:
                    misses[i] += 1
        if (max_misses >= 0 and misses[i] >= max_misses) or (
            provisional_misses >= 0 and provisional and misses[i] >= provisional_misses
        ):
            drop[i] = True
            n_drop += 1
    return drop, n_drop
