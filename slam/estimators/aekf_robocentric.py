"""Robocentric AEKF-SLAM (Castellanos, Martinez-Cantin, Tardós and Neira, "Robocentric map
joining: improving the consistency of EKF-SLAM", Robotics and Autonomous Systems 55(1),
2007) — one of the consistency options the issue names, beside FEJ in ``aekf.py``.

The state lives in the *current vehicle frame*: ``x = [w_x, w_y, w_phi, m_1, ..., m_n]``
where ``w`` is the pose of the world origin seen from the vehicle and ``m_i`` the landmarks
in the vehicle frame (m). Motion moves every state by ``⊖u`` (O(n²): all blocks rotate);
an observation depends only on its landmark (``h = [|m|, atan2(m_y, m_x)]``), so its
Jacobian never involves the large, drifting global heading — the source of the
standard EKF's inconsistency. World-frame outputs compose with ``⊖w``.

Hand-written (no library implements it); same gates and association as ``aekf.py``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from slam.estimators.aekf import (
    AEKFConfig,
    as_observations,
    as_odometry,
    check_state,
    select_associations,
    subtract_outer,
    trsolve,
    wrap_scalar,
)
from slam.estimators.base import UpdateResult
from slam.estimators.rb_model import wrap as _wrap
from slam.types import Odometry, RangeBearing

__all__ = ["RobocentricAEKFSlam", "robo_augment", "robo_predict", "robo_scores", "robo_update"]


def _pairs(N: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs rotated by a frame change: (w_x, w_y) and every (m_x, m_y)."""
    a = np.concatenate([[0], np.arange(3, N, 2)])
    return a, a + 1


def robo_predict(x, P, u, Q):
    """Move the vehicle frame by ``u`` (body-frame increment, covariance ``Q``): every
    point p becomes ``Rot(-dphi)(p - t)``, ``w_phi`` becomes ``w_phi - dphi``. Returns new
    ``(x, P)``; O(n²)."""
    x = np.array(x, dtype=float)
    P = np.array(P, dtype=float)
    N = x.size
    c, s = math.cos(u[2]), math.sin(u[2])
    a, b = _pairs(N)
    px, py = x[a] - u[0], x[b] - u[1]
    # noise Jacobian G = ∂x'/∂u (N, 3)
    G = np.zeros((N, 3))
    G[a, 0], G[a, 1] = -c, -s
    G[b, 0], G[b, 1] = s, -c
    G[a, 2] = -s * px + c * py
    G[b, 2] = -c * px - s * py
    G[2, 2] = -1.0
    x[a], x[b] = c * px + s * py, -s * px + c * py
    x[2] = wrap_scalar(float(x[2]) - float(u[2]))
    # F = blockdiag(Rot(-dphi), 1, Rot(-dphi), ...): rotate rows then columns, O(n²)
    Pa, Pb = P[a].copy(), P[b].copy()
    P[a], P[b] = c * Pa + s * Pb, -s * Pa + c * Pb
    Pa, Pb = P[:, a].copy(), P[:, b].copy()
    P[:, a], P[:, b] = c * Pa + s * Pb, -s * Pa + c * Pb
    P += G @ Q @ G.T
    return x, 0.5 * (P + P.T)


def _h_and_H(m):
    q = m[:, 0] ** 2 + m[:, 1] ** 2
    r = np.sqrt(q)
    zhat = np.stack([r, np.arctan2(m[:, 1], m[:, 0])], axis=1)
    H = np.empty((m.shape[0], 2, 2))
    H[:, 0, 0], H[:, 0, 1] = m[:, 0] / r, m[:, 1] / r
    H[:, 1, 0], H[:, 1, 1] = -m[:, 1] / q, m[:, 0] / q
    return zhat, H


def robo_scores(x, P, z, R):
    """NIS and ML distance ``(k, n)`` of every observation to every landmark (vectorized);
    ``S_i = H_i P_ii H_iᵀ + R`` involves only the landmark's own 2×2 block."""
    n = (x.size - 3) // 2
    k = z.shape[0]
    if n == 0 or k == 0:
        return np.empty((k, n)), np.empty((k, n))
    ar = np.arange(n)
    zhat, H = _h_and_H(x[3:].reshape(n, 2))
    Pii = P[3:, 3:].reshape(n, 2, n, 2)[ar, :, ar, :]
    S = (H @ Pii @ np.swapaxes(H, 1, 2))[None] + R[:, None]
    y = z[:, None, :] - zhat[None]
    y[..., 1] = _wrap(y[..., 1])
    A, B, D = S[..., 0, 0], 0.5 * (S[..., 0, 1] + S[..., 1, 0]), S[..., 1, 1]
    det = A * D - B * B
    nis = (D * y[..., 0] ** 2 - 2 * B * y[..., 0] * y[..., 1] + A * y[..., 1] ** 2) / det
    return nis, nis + np.log(det)


def robo_update(x, P, z, R, idx):
    """Batch update of landmarks ``idx`` with ``z (k, 2)``; returns new ``(x, P)``."""
    x = np.array(x, dtype=float)
    P = np.array(P, dtype=float)
    idx = np.asarray(idx, dtype=np.intp)
    k = idx.size
    if k == 0:
        return x, P
    cols = (3 + 2 * idx[:, None] + np.arange(2)).reshape(-1)
    zhat, H = _h_and_H(x[cols].reshape(k, 2))
    y = z - zhat
    y[:, 1] = _wrap(y[:, 1])
    Pc = P[:, cols].reshape(-1, k, 2)
    PHt = np.einsum("nka,kba->nkb", Pc, H).reshape(-1, 2 * k)
    B = PHt[cols].reshape(k, 2, 2 * k)
    S = np.einsum("kba,kam->kbm", H, B).reshape(2 * k, 2 * k)
    for j in range(k):  # block-diagonal R of the k observations
        S[2 * j : 2 * j + 2, 2 * j : 2 * j + 2] += R[j]
    S = 0.5 * (S + S.T)
    L = np.linalg.cholesky(S)
    W1 = trsolve(L, PHt.T).T
    x += W1 @ trsolve(L, y.reshape(-1))
    x[2] = wrap_scalar(float(x[2]))
    subtract_outer(P, W1)
    return x, P


def robo_augment(x, P, z, R):
    """New landmarks ``[r cos b, r sin b]`` in the vehicle frame: uncorrelated with the
    rest (the vehicle is the frame's origin), covariance ``G_z R G_zᵀ``."""
    k = z.shape[0]
    N = x.size
    c, s, r = np.cos(z[:, 1]), np.sin(z[:, 1]), z[:, 0]
    m = np.stack([r * c, r * s], axis=1)
    Gz = np.empty((k, 2, 2))
    Gz[:, 0, 0], Gz[:, 0, 1], Gz[:, 1, 0], Gz[:, 1, 1] = c, -r * s, s, r * c
    Pa = np.zeros((N + 2 * k, N + 2 * k))
    Pa[:N, :N] = P
    blocks = Gz @ R @ np.swapaxes(Gz, 1, 2)
    for j in range(k):  # k new observations of one scan
        Pa[N + 2 * j : N + 2 * j + 2, N + 2 * j : N + 2 * j + 2] = blocks[j]
    return np.concatenate([x, m.reshape(-1)]), Pa


class RobocentricAEKFSlam:
    """Robocentric AEKF-SLAM behind :class:`slam.estimators.base.SlamEstimator`, with the
    same gates and options for association as :class:`AEKFConfig` (``association``,
    ``reject_gate``, ``augment_gate``, ``exclusive``, ``unambiguous_gate``; the Jacobian
    and reduction options do not apply)."""

    name = "aekf-robocentric"

    def __init__(
        self, config: AEKFConfig | None = None, *, x0=None, P0=None, rng=None, seed=None, **params
    ):
        del rng, seed  # deterministic
        self.config = AEKFConfig(**params) if config is None else config
        x0 = np.zeros(3) if x0 is None else np.asarray(x0, dtype=float).reshape(-1)
        P0 = np.zeros((3, 3)) if P0 is None else np.asarray(P0, dtype=float)
        check_state(x0, P0, psd=True)
        # world origin seen from the vehicle: w = ⊖x0; first order cov J P0 Jᵀ
        c, s = math.cos(x0[2]), math.sin(x0[2])
        w = np.array([-c * x0[0] - s * x0[1], s * x0[0] - c * x0[1], -x0[2]])
        J = np.array(
            [[-c, -s, -(-s * x0[0] + c * x0[1])], [s, -c, c * x0[0] + s * x0[1]], [0, 0, -1.0]]
        )
        self.x = w
        self.P = J @ P0 @ J.T
        self.labels = np.empty(0, dtype=np.int64)

    @property
    def n_landmarks(self) -> int:
        return (self.x.size - 3) // 2

    def predict(self, odometry: Odometry) -> None:
        self.predict_arrays(odometry.delta, odometry.cov)

    def predict_arrays(self, u, Q) -> None:
        u, Q = as_odometry(u, Q)
        self.x, self.P = robo_predict(self.x, self.P, u, Q)

    def update(self, observations: Sequence[RangeBearing]) -> UpdateResult:
        k = len(observations)
        z = np.array([o.z for o in observations]).reshape(k, 2)
        R = np.array([o.R for o in observations]).reshape(k, 2, 2)
        labels = [o.label for o in observations]
        lab = np.array(labels, dtype=np.int64) if k and all(v is not None for v in labels) else None
        return self.update_arrays(z, R, lab)

    def update_arrays(self, z, R, labels=None) -> UpdateResult:
        z, R = as_observations(z, R)
        cfg = self.config
        k = z.shape[0]
        if k == 0:
            return UpdateResult(np.zeros(0, np.intp), np.zeros(0, bool), np.zeros(0))
        if cfg.association == "known" and labels is None:
            raise ValueError("association='known' needs a label on every observation")
        n = self.n_landmarks
        nis_m, nd_m = robo_scores(self.x, self.P, z, R)
        if cfg.association == "known":
            labels = np.asarray(labels, dtype=np.int64)
            pos = {int(v): i for i, v in enumerate(self.labels)}  # label -> index lookup
            idx = np.array([pos.get(int(v), -1) for v in labels], dtype=np.intp)
            new = idx < 0
            nis = np.full(k, np.nan)
            m = idx >= 0
            nis[m] = nis_m[np.flatnonzero(m), idx[m]]
        else:
            idx, new, nis = select_associations(
                nis_m,
                nd_m,
                reject_gate=cfg.reject_gate,
                augment_gate=cfg.augment_gate,
                method=cfg.association,
                exclusive=cfg.exclusive,
                unambiguous_gate=cfg.unambiguous_gate,
            )
        known = idx >= 0
        if np.any(known):
            self.x, self.P = robo_update(self.x, self.P, z[known], R[known], idx[known])
        assoc = idx.copy()
        if np.any(new):
            mcount = int(new.sum())
            self.x, self.P = robo_augment(self.x, self.P, z[new], R[new])
            lab = labels[new] if labels is not None else np.full(mcount, -1, np.int64)
            self.labels = np.concatenate([self.labels, np.asarray(lab, dtype=np.int64)])
            assoc[new] = n + np.arange(mcount)
        return UpdateResult(assoc, new, nis)

    def _to_world(self, pts: np.ndarray, idx_cols: np.ndarray | None):
        """World coordinates and covariances of vehicle-frame points ``pts (m, 2)`` that are
        state blocks at columns ``idx_cols (m, 2)`` (None: the vehicle origin itself)."""
        w = self.x[:3]
        c, s = math.cos(w[2]), math.sin(w[2])
        Rm = np.array([[c, s], [-s, c]])  # Rot(-w_phi)
        d = pts - w[:2]
        g = d @ Rm.T
        m = pts.shape[0]
        J = np.zeros((m, 2, 5))
        J[:, :, :2] = -Rm
        J[:, 0, 2] = -s * d[:, 0] + c * d[:, 1]
        J[:, 1, 2] = -c * d[:, 0] - s * d[:, 1]
        J[:, :, 3:] = Rm
        Sig = np.zeros((m, 5, 5))
        Sig[:, :3, :3] = self.P[:3, :3]
        if idx_cols is not None:
            Sig[:, :3, 3:] = self.P[:3][:, idx_cols].transpose(1, 0, 2)
            Sig[:, 3:, :3] = np.swapaxes(Sig[:, :3, 3:], 1, 2)
            ar = np.arange(m)
            Sig[:, 3:, 3:] = self.P[idx_cols[:, :, None], idx_cols[:, None, :]][ar]
        return g, J @ Sig @ np.swapaxes(J, 1, 2), J, Sig

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        g, _C, J, Sig = self._to_world(np.zeros((1, 2)), None)
        Jp = np.zeros((3, 5))
        Jp[:2] = J[0]
        Jp[2, 2] = -1.0
        return np.array([g[0, 0], g[0, 1], wrap_scalar(-float(self.x[2]))]), Jp @ Sig[0] @ Jp.T

    def landmarks(self) -> tuple[np.ndarray, np.ndarray]:
        n = self.n_landmarks
        if n == 0:
            return np.empty((0, 2)), np.empty((0, 2, 2))
        cols = 3 + 2 * np.arange(n)[:, None] + np.arange(2)
        g, C, _, _ = self._to_world(self.x[3:].reshape(n, 2), cols)
        return g, C
