"""Compiled covariance steps of :class:`sim.navigation.dead_reckoning.DeadReckoner`.

Each dead-reckoner step propagates its 21-state error covariance with a transition
``A`` that differs from the identity in a few rows only (the propagation ``F`` in the
position, heading and compass-drift rows; a sample correction in one or two rows; the
compass update ``I − K hᵀ`` in the five updated states). ``A P Aᵀ`` with ``A = I + E``
is then ``P`` with those rows replaced by ``A[rows] P`` and afterwards the same columns
replaced by ``(A P)[:, rows] ← (A P) A[rows]ᵀ``: ``2 k n²`` flops for ``k`` rows instead
of the ``4 n³`` of two dense products, in one compiled pass (numba, cached on disk)
without the 21 × 21 temporaries. The result equals the dense ``A @ P @ A.T`` of numpy
to rounding (the order of summation differs from BLAS's; relative 1e-15, checked over
long runs in tests/sim/navigation/test_dr_covariance.py); run to run it is
bit-identical. All functions update ``P`` (float64, C-contiguous, (n, n)) in place.
"""

from __future__ import annotations

import numba
import numpy as np

# the error-state layout of sim.navigation.dead_reckoning (first index of each block;
# tests/sim/navigation/test_dr_covariance.py checks they agree)
I_P, I_PHI, I_E0, I_NV, I_NW, I_B, I_S, I_M, I_BV, I_G = 0, 2, 3, 4, 7, 9, 11, 12, 13, 20


@numba.njit(cache=True)
def sandwich_rows(P, rows, A_rows):
    """``P ← A P Aᵀ`` for ``A`` = the identity except rows ``rows`` (k,) int, which are
    ``A_rows`` (k, n). Rows must be distinct."""
    n = P.shape[0]
    k = rows.shape[0]
    M = np.empty((k, n))
    for a in range(k):  # (A P)[rows] = A[rows] P
        for j in range(n):
            s = 0.0
            for m in range(n):
                s += A_rows[a, m] * P[m, j]
            M[a, j] = s
    for a in range(k):
        P[rows[a], :] = M[a]
    # (A P) Aᵀ: columns outside rows are unchanged; column rows[a] is (A P) A[rows[a]]ᵀ
    C = np.empty((n, k))
    for i in range(n):
        for a in range(k):
            s = 0.0
            for m in range(n):
                s += P[i, m] * A_rows[a, m]
            C[i, a] = s
    for a in range(k):
        P[:, rows[a]] = C[:, a]


@numba.njit(cache=True)
def propagate(P, Jdp, RT, cz, Rv, Rm, h, a, q_g, q_b, q_v):
    """``DeadReckoner._propagate``'s covariance over ``h`` s: ``P ← F P Fᵀ`` plus the
    process noise. ``F`` (module docstring of sim.navigation.dead_reckoning) is the
    identity except the position rows (``Jdp`` (2,) d(dp)/d(phi_mid), ``RT`` (2, 3) the
    levelled rotation R T, ``cz`` (2,) yaw-rate coefficients, ``Rv``/``Rm`` (2,) the
    rotated velocity and its misalignment derivative), the heading row and the compass
    drift's decay ``a``. Noise added: ``q_g`` rad² on the drift, ``q_b`` (rad/s)² on each
    gyro-bias state, ``q_v`` (m/s)² on each held-velocity state."""
    n = P.shape[0]
    rows = np.array([I_P, I_P + 1, I_PHI, I_G])
    A = np.zeros((4, n))
    for i in range(2):
        A[i, I_P + i] = 1.0
        A[i, I_PHI] = Jdp[i]
        A[i, I_E0] = -Jdp[i]
        for j in range(3):
            A[i, I_NV + j] = RT[i, j] * h
            A[i, I_BV + j] = RT[i, j] * h
        for j in range(2):
            A[i, I_NW + j] = Jdp[i] * cz[j] * 0.5 * h
            A[i, I_B + j] = Jdp[i] * cz[j] * 0.5 * h
        A[i, I_S] = Rv[i] * h
        A[i, I_M] = Rm[i] * h
    A[2, I_PHI] = 1.0
    for j in range(2):
        A[2, I_NW + j] = cz[j] * h
        A[2, I_B + j] = cz[j] * h
    A[3, I_G] = a
    sandwich_rows(P, rows, A)
    P[I_G, I_G] += q_g
    for i in range(I_B, I_B + 2):
        P[i, i] += q_b
    for i in range(I_NV, I_NV + 3):
        P[i, i] += q_v


@numba.njit(cache=True)
def sandwich_block(P, r0, c0, G, sign):
    """``P ← A P Aᵀ`` with ``A = I + sign · E``, ``E`` zero except the block ``G`` (k, m)
    at rows ``r0 … r0+k−1`` and columns ``c0 … c0+m−1``; the two index ranges must not
    overlap (a correction of the estimate rows by a noise state)."""
    n = P.shape[0]
    k, m = G.shape
    rows = np.arange(r0, r0 + k)
    A_rows = np.zeros((k, n))
    for a in range(k):
        A_rows[a, r0 + a] = 1.0
        for b in range(m):
            A_rows[a, c0 + b] = sign * G[a, b]
    sandwich_rows(P, rows, A_rows)


@numba.njit(cache=True)
def fresh_noise(P, i0, k, var):
    """States ``i0 … i0+k−1`` replaced by a fresh independent draw of variance ``var``:
    their rows and columns zeroed, ``var`` on their diagonal."""
    for i in range(i0, i0 + k):
        P[i, :] = 0.0
        P[:, i] = 0.0
    for i in range(i0, i0 + k):
        P[i, i] = var


@numba.njit(cache=True)
def correct(P, r0, c0, G, var):
    """``DeadReckoner._correct``'s covariance: remove ``G n_old`` from rows ``r0…``,
    draw fresh noise states ``c0 … c0+m−1`` of variance ``var``, add ``G n_new``."""
    sandwich_block(P, r0, c0, G, -1.0)
    fresh_noise(P, c0, G.shape[1], var)
    sandwich_block(P, r0, c0, G, 1.0)


@numba.njit(cache=True)
def schmidt_update(P, K, h, var):
    """``P ← (I − K hᵀ) P (I − K hᵀ)ᵀ + var K Kᵀ`` (Joseph form; ``K`` (n,) zero outside
    the updated states, which are the rows that change)."""
    n = P.shape[0]
    k = 0
    for i in range(n):
        if K[i] != 0.0:
            k += 1
    rows = np.empty(k, np.int64)
    A_rows = np.zeros((k, n))
    a = 0
    for i in range(n):
        if K[i] != 0.0:
            rows[a] = i
            for j in range(n):
                A_rows[a, j] = -K[i] * h[j]
            A_rows[a, i] += 1.0
            a += 1
    sandwich_rows(P, rows, A_rows)
    for a in range(k):
        for b in range(k):
            P[rows[a], rows[b]] += K[rows[a]] * K[rows[b]] * var


@numba.njit(cache=True)
def cut_covariance(P):
    """(3, 3) covariance of ``[dx, dy, dphi]`` since the cut: position rows of ``P``
    and the heading-change error ``e_psi − e0``, symmetrized."""
    C = np.empty((3, 3))
    e = (I_P, I_P + 1, I_PHI)
    for a in range(3):
        for b in range(3):
            C[a, b] = P[e[a], e[b]]
    for a in range(3):  # row and column 2: e_psi − e0
        C[a, 2] -= P[e[a], I_E0]
    for b in range(2):
        C[2, b] -= P[I_E0, e[b]]
    C[2, 2] += P[I_E0, I_E0] - P[I_E0, I_PHI]
    return 0.5 * (C + C.T)


@numba.njit(cache=True)
def _rot3(yaw):
    """Identity with the 2-D rotation by ``yaw`` rad in its top-left block."""
    B = np.eye(3)
    c, s = np.cos(yaw), np.sin(yaw)
    B[0, 0], B[0, 1], B[1, 0], B[1, 1] = c, -s, s, c
    return B


@numba.njit(cache=True)
def matched_odometry_cov(cov_whole, cov_cut, yaw0, yaw_prev, dx, dy):
    """``NavSuite.odometry``'s matched increment covariance ``Q`` (3, 3) (see there):
    ``cov_whole`` the never-cut reckoner's covariance in its start frame, ``cov_cut`` the
    recursion's covariance at the previous cut (updated in place), ``yaw0`` the start
    heading, ``yaw_prev`` the heading at the previous cut (rad), ``dx, dy`` the
    increment (m, frame of the previous cut)."""
    B = _rot3(yaw0)
    cov_now = B @ cov_whole @ B.T.copy()
    c, s = np.cos(yaw_prev), np.sin(yaw_prev)
    F = np.eye(3)
    F[0, 2] = -s * dx - c * dy
    F[1, 2] = c * dx - s * dy
    Ft = F.T.copy()
    G = _rot3(yaw_prev)
    Gt = G.T.copy()
    D = Gt @ (cov_now - F @ cov_cut @ Ft) @ G
    w, V = np.linalg.eigh(0.5 * (D + D.T))
    Q = (V * np.maximum(w, 0.0)) @ V.T.copy()
    cov_cut[:] = F @ cov_cut @ Ft + G @ Q @ Gt
    return 0.5 * (Q + Q.T)
