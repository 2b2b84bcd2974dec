"""The AEKF's per-scan steps in their NumPy formulation (the code the compiled kernels of
``slam.estimators.aekf_kernels`` and ``rb_kernels`` replaced), as a second
implementation for the tests: same signatures as the kernels, so a test can compare them
call by call or swap them into the filter (``monkeypatch``) for a whole run."""

from __future__ import annotations

import math

import numpy as np

from slam.estimators.rb_model import observe, wrap


def predict_inplace(x, P, u, Q, ref):
    phi = float(x[2])
    c, s = math.cos(phi), math.sin(phi)
    xn = float(x[0]) + (c * u[0] - s * u[1])
    yn = float(x[1]) + (s * u[0] + c * u[1])
    F = np.array([[1.0, 0.0, -(yn - ref[1])], [0.0, 1.0, xn - ref[0]], [0.0, 0.0, 1.0]])
    G = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    Pvv = F @ P[:3, :3] @ F.T + G @ Q @ G.T
    P[:3, :3] = 0.5 * (Pvv + Pvv.T)
    if P.shape[0] > 3:
        Pvm = F @ P[:3, 3:]
        P[:3, 3:] = Pvm
        P[3:, :3] = Pvm.T
    x[0], x[1], x[2] = xn, yn, (phi + float(u[2]) + math.pi) % (2 * math.pi) - math.pi


def ekf_gain(x, P, z, R, idx, xl):
    k = idx.size
    cols = 3 + 2 * idx
    pair_cols = np.stack([cols, cols + 1], axis=1).reshape(-1)
    zhat, Hv, Hm = observe(x, idx, x_lin=xl)
    y = z - zhat
    y[:, 1] = wrap(y[:, 1])
    Pm = P[:, pair_cols].reshape(-1, k, 2)
    PHt = (np.einsum("na,kba->nkb", P[:, :3], Hv) + np.einsum("nka,kba->nkb", Pm, Hm)).reshape(
        -1, 2 * k
    )
    B = PHt[pair_cols, :].reshape(k, 2, -1)
    HPHt = (np.einsum("kba,am->kbm", Hv, PHt[:3, :]) + np.einsum("kba,kam->kbm", Hm, B)).reshape(
        2 * k, -1
    )
    Rb = np.zeros((2 * k, 2 * k))
    for j in range(k):
        Rb[2 * j : 2 * j + 2, 2 * j : 2 * j + 2] = R[j]
    S = HPHt + Rb
    S = 0.5 * (S + S.T)
    try:
        L = np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        return False, PHt, S, np.zeros_like(S), np.zeros_like(PHt), np.zeros(x.size)
    W1 = np.linalg.solve(L, PHt.T).T
    step = W1 @ np.linalg.solve(L, y.reshape(-1))
    return True, PHt, S, L, W1, step


def add_step(x, step):
    x += step
    x[2] = (x[2] + math.pi) % (2 * math.pi) - math.pi


def downdate(P, W1):
    P -= W1 @ W1.T


def surely_linear(x0, step, idx, R, gate):
    total = 0.0
    for j, i in enumerate(idx.tolist()):
        c = 3 + 2 * i
        r = math.hypot(float(x0[c] - x0[0]), float(x0[c + 1] - x0[1]))
        ex, ey = float(step[c] - step[0]), float(step[c + 1] - step[1])
        s2 = ex * ex + ey * ey
        r_min = r - math.sqrt(s2)
        a, b, d = float(R[j, 0, 0]), float(R[j, 0, 1]), float(R[j, 1, 1])
        lam = 0.5 * (a + d) - math.hypot(0.5 * (a - d), b)
        if r_min <= 0.0 or lam <= 0.0:
            return False
        e_r = 0.5 * s2 / r_min
        e_b = e_r / r_min
        total += (e_r * e_r + e_b * e_b) / lam
    return total <= gate


def nis_scores(x, P, z, R, xl, ml):
    n = (x.size - 3) // 2
    ar = np.arange(n)
    zhat, Hv, Hm = observe(x, ar, x_lin=xl)
    Pvv = P[:3, :3]
    Pvi = P[:3, 3:].reshape(3, n, 2).transpose(1, 0, 2)
    Pii = P[3:, 3:].reshape(n, 2, n, 2)[ar, :, ar, :]
    HmT = np.swapaxes(Hm, 1, 2)
    C = Hv @ Pvi @ HmT
    S0 = Hv @ Pvv @ np.swapaxes(Hv, 1, 2) + C + np.swapaxes(C, 1, 2) + Hm @ Pii @ HmT
    S = S0[None, :, :, :] + R[:, None, :, :]
    y = z[:, None, :] - zhat[None, :, :]
    y[..., 1] = wrap(y[..., 1])
    a, b, d = S[..., 0, 0], 0.5 * (S[..., 0, 1] + S[..., 1, 0]), S[..., 1, 1]
    det = a * d - b * b
    nis = (d * y[..., 0] ** 2 - 2.0 * b * y[..., 0] * y[..., 1] + a * y[..., 1] ** 2) / det
    return nis, nis + np.log(det)


def pair_covariance(x, P, z, R, obs, lms):
    c = obs.size
    zhat, Hv, Hm = observe(x, lms)
    nu = z[obs] - zhat
    nu[:, 1] = wrap(nu[:, 1])
    H = np.concatenate([Hv, Hm], axis=2)
    cols = np.empty((c, 5), dtype=np.intp)
    cols[:, :3] = np.arange(3)
    cols[:, 3] = 3 + 2 * lms
    cols[:, 4] = 4 + 2 * lms
    flat = cols.reshape(-1)
    Psub = P[flat[:, None], flat[None, :]].reshape(c, 5, c, 5)
    HP = np.einsum("aij,ajbk->aibk", H, Psub)
    S = np.einsum("aibk,blk->aibl", HP, H).reshape(2 * c, 2 * c)
    for a in range(c):
        for b in range(c):
            if obs[a] == obs[b]:
                S[2 * a : 2 * a + 2, 2 * b : 2 * b + 2] += R[obs[a]]
    return nu.reshape(-1), 0.5 * (S + S.T)


def joint_nis(S, nu, rows):
    try:
        L = np.linalg.cholesky(S[np.ix_(rows, rows)])
    except np.linalg.LinAlgError:
        return -1.0
    w = np.linalg.solve(L, nu[rows])
    return float(w @ w)


def jcbb_outcome(scores, pairs, ambiguous, augment_gate):
    k, n = scores.shape
    new = (pairs < 0) & ~ambiguous & ((scores > augment_gate).all(axis=1) if n else True)
    nis = np.full(k, np.nan)
    m = pairs >= 0
    nis[m] = scores[np.flatnonzero(m), pairs[m]]
    return new, nis, (scores < augment_gate).any(axis=0)


def jcbb_easy(x, P, z, R, gate, limits):
    """The steps ``slam.estimators.jcbb.jcbb`` took before its branch and bound (the
    Python code ``rb_kernels.jcbb_easy`` replaced)."""
    k, n = z.shape[0], (x.size - 3) // 2
    pairs = np.full(k, -1, dtype=np.intp)
    if n == 0 or k == 0:
        return 1, pairs, np.empty((k, n)), 0.0, 0
    nis, _ = nis_scores(x, P, z, R, x, False)
    obs, lms = np.nonzero(nis < gate)
    if obs.size == 0:
        return 1, pairs, nis, 0.0, 0
    if obs.size == 1 and gate <= limits[0]:
        pairs[obs] = lms
        return 1, pairs, nis, float(nis[obs[0], lms[0]]), 1
    if len(set(obs.tolist())) == obs.size and len(set(lms.tolist())) == lms.size:
        nu, S = pair_covariance(x, P, z, R, obs, lms)
        d2 = joint_nis(S, nu, np.arange(nu.size))
        if d2 < 0:
            return -1, pairs, nis, 0.0, 1
        if d2 < limits[obs.size - 1]:
            pairs[obs] = lms
            return 1, pairs, nis, d2, 1
    return 0, pairs, nis, 0.0, 1
