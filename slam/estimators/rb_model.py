"""The range-bearing observation model of the landmark state ``[x, y, phi, x1, y1, …]``
(thesis eqs. 5.30, 5.36-5.39), shared by the AEKF (slam.estimators.aekf) and JCBB
(slam.estimators.jcbb) so neither imports the other's internals, and the small 2 x 2
helpers FastSLAM 2.0 and iSAM2 share (``inv2``, ``symmetrize``, ``wrap``)."""

from __future__ import annotations

import math

import numpy as np

from slam.estimators.rb_kernels import nis_scores

_TWO_PI = 2.0 * math.pi


def wrap(a):
    """Wrap angles to [-pi, pi) fast (array or float); the sign at exactly ±pi is irrelevant
    for innovations."""
    return np.mod(np.asarray(a) + math.pi, _TWO_PI) - math.pi


def observe(x, idx, *, x_lin=None):
    """Predicted observations and Jacobians of landmarks ``idx`` (eqs. 5.30, 5.36–5.39).

    Returns ``zhat (k, 2)`` at ``x`` and ``Hv (k, 2, 3)``, ``Hm (k, 2, 2)`` — the non-zero
    blocks of each row pair of ``H`` (vehicle columns, landmark columns) — at ``x_lin``
    (default ``x``).
    """
    x = np.asarray(x, dtype=float)
    idx = np.asarray(idx, dtype=np.intp)
    lm = x[3:].reshape(-1, 2)[idx]
    d = lm - x[:2]
    zhat = np.empty((idx.size, 2))
    zhat[:, 0] = np.hypot(d[:, 0], d[:, 1])
    zhat[:, 1] = wrap(np.arctan2(d[:, 1], d[:, 0]) - x[2])
    if x_lin is not None:
        x_lin = np.asarray(x_lin, dtype=float)
        d = x_lin[3:].reshape(-1, 2)[idx] - x_lin[:2]
    Hv, Hm = jacobians(d)
    return zhat, Hv, Hm


def jacobians(d: np.ndarray):
    q = d[:, 0] ** 2 + d[:, 1] ** 2
    r = np.sqrt(q)
    Hm = np.empty((d.shape[0], 2, 2))
    Hm[:, 0, 0] = d[:, 0] / r
    Hm[:, 0, 1] = d[:, 1] / r
    Hm[:, 1, 0] = -d[:, 1] / q
    Hm[:, 1, 1] = d[:, 0] / q
    Hv = np.zeros((d.shape[0], 2, 3))
    Hv[:, :, :2] = -Hm
    Hv[:, 1, 2] = -1.0
    return Hv, Hm


def association_scores(x, P, z, R, *, x_lin=None, ml: bool = True):
    """Normalized innovation squared and ML distance of every observation to every landmark.

    Returns ``nis (k, n)`` = ``yᵀ S⁻¹ y`` and ``nd (k, n)`` = ``nis + ln det S`` (Bailey's
    "normalised distance", the negative log-likelihood up to constants; None with
    ``ml=False``): S of each landmark from the 5×5 vehicle-landmark block of P, compiled
    (:func:`slam.estimators.rb_kernels.nis_scores`), Jacobians at ``x_lin`` (default x).
    """
    x = np.ascontiguousarray(x, dtype=float)
    P = np.ascontiguousarray(P, dtype=float)
    z = np.ascontiguousarray(z, dtype=float).reshape(-1, 2)
    k = z.shape[0]
    n = (x.size - 3) // 2
    R = np.asarray(R, dtype=float)
    if R.shape == (2, 2):
        R = np.broadcast_to(R, (k, 2, 2))
    if n == 0 or k == 0:
        return np.empty((k, n)), np.empty((k, n))
    xl = x if x_lin is None else np.ascontiguousarray(x_lin, dtype=float)
    nis, nd = nis_scores(x, P, z, np.ascontiguousarray(R), xl, ml)
    return nis, (nd if ml else None)


def inv2(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form inverse and determinant of symmetric 2x2 matrices (..., 2, 2)."""
    det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
    det = np.maximum(det, 1e-300)
    inv = np.empty_like(S)
    inv[..., 0, 0] = S[..., 1, 1] / det
    inv[..., 1, 1] = S[..., 0, 0] / det
    inv[..., 0, 1] = -S[..., 0, 1] / det
    inv[..., 1, 0] = -S[..., 1, 0] / det
    return inv, det


def symmetrize(P: np.ndarray) -> np.ndarray:
    """(P + Pᵀ) / 2 over the last two axes."""
    return 0.5 * (P + np.swapaxes(P, -1, -2))
