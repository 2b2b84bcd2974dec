"""AEKF-SLAM: the augmented extended Kalman filter of the reference thesis, chapter 5.

State ``x = [x_v, y_v, phi_v, x_1, y_1, ..., x_n, y_n]`` (m, m, rad, m ...) in the 2-D
world frame (x east, y north, phi counter-clockwise from x), covariance ``P``. Three
steps, each a pure ``(x, P) -> (x, P)`` function beside the thin class :class:`AEKFSlam`:

* :func:`predict` — eqs. 5.21–5.27: odometry increment ``u = [dx, dy, dphi]`` in the body
  frame at the start of the interval with covariance ``Q``; only ``P_v`` and ``P_vm`` change
  (O(n)).
* :func:`update` — eqs. 5.28–5.39: range-bearing observations of known landmarks, batch
  (all of a scan in one stacked update) or sequential; Kalman gain through a Cholesky
  factor of ``S`` and the symmetric form ``P - W1 W1ᵀ`` (or the Joseph form, option),
  O(n² k) for k observations, no O(n³) step.
* :func:`augment` — eqs. 5.40–5.47: new landmarks fill only the new row/column blocks
  (O(n) per landmark).

plus :func:`associate` (maximum-likelihood or nearest-neighbour gated association,
vectorized over all landmarks × observations, the reject/augment gates of Tim Bailey's
toolbox which the reference used: 4.0 and 25.0) and :func:`remove_landmarks` (state
reduction). Names follow filterpy: ``x, P, F, Q, R, H, K, y, S``. The thesis's ``J_v`` is
``F`` here and its noise Jacobian ``Q_v`` is ``G`` (``Q`` stays the odometry covariance).

Hand-written: the equations are the reference's own; no library in the project's
dependencies implements landmark EKF-SLAM (filterpy, which is not a dependency, has a
generic EKF only).

Consistency options beyond the reference (see ``AEKFConfig.jacobians``): ``"fej"``
evaluates the prediction Jacobian at the previous *predicted* pose and the landmark
Jacobians at each landmark's first estimate (Huang, Mourikis and Roumeliotis, "Analysis
and improvement of the consistency of extended Kalman filter based SLAM", ICRA 2008), which
keeps the filter's unobservable subspace three-dimensional as in the true system;
``iterations`` makes loop-closure-size updates iterated (Gauss–Newton) updates;
``association="jcbb"`` uses joint compatibility (:mod:`slam.estimators.jcbb`); the preset
``"consistent"`` combines the three and is the default (measured in
``slam/experiments/README.md``); ``"reference"`` is Bailey's filter.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import blas as _blas
from scipy.linalg import lapack as _lapack

from slam.estimators.aekf_kernels import (
    OK,
    add_step,
    count_misses,
    cov_status,
    downdate,
    ekf_gain,
    jcbb_outcome,
    obs_status,
    odo_status,
    predict_inplace,
    surely_linear,
)
from slam.estimators.base import UpdateResult
from slam.estimators.jcbb import jcbb
from slam.estimators.rb_model import association_scores, observe
from slam.estimators.rb_model import wrap as _wrap
from slam.types import Odometry, RangeBearing

__all__ = [
    "AEKF_PRESETS",
    "DEFAULT_PRESET",
    "AEKFConfig",
    "AEKFSlam",
    "associate",
    "augment",
    "compose_odometry",
    "landmark_marginals",
    "observe",
    "predict",
    "remove_landmarks",
    "select_associations",
    "update",
]

_TWO_PI = 2.0 * math.pi
#: states larger than this go through BLAS (dgemm) for ``P -= W1 W1ᵀ``, under the BLAS
#: thread limit; smaller ones through the compiled loop (no BLAS call, no thread limit)
_BLAS_MIN_STATE = 200
_NO_COMPATIBLE = np.zeros(0, dtype=bool)


def wrap_scalar(a: float) -> float:
    return (a + math.pi) % _TWO_PI - math.pi


# --------------------------------------------------------------------------- validation


def check_state(x: np.ndarray, P: np.ndarray, *, psd: bool = False) -> None:
    if x.ndim != 1 or x.size < 3 or (x.size - 3) % 2:
        raise ValueError(f"x must have shape (3 + 2n,), got {x.shape}")
    if P.shape != (x.size, x.size):
        raise ValueError(f"P must have shape {(x.size, x.size)} to match x, got {P.shape}")
    if psd:
        _check_cov("P", P)
        if not np.all(np.isfinite(x)):
            raise ValueError(f"x must be finite, got {x}")


def _check_cov(name: str, C: np.ndarray, tol: float = 1e-9) -> None:
    """Symmetric positive semi-definite, finite, non-negative variances: the compiled
    check (:func:`~slam.estimators.aekf_kernels.cov_status`) passes valid input; anything
    it flags goes through the NumPy checks below, which raise with the details."""
    C = np.asarray(C, dtype=float)
    if C.ndim >= 2 and C.shape[-1] == C.shape[-2]:
        C3 = np.ascontiguousarray(C).reshape(-1, C.shape[-2], C.shape[-1])
        if cov_status(C3, tol) == OK:
            return
    _check_cov_numpy(name, C, tol)


def _check_cov_numpy(name: str, C: np.ndarray, tol: float) -> None:
    if not np.all(np.isfinite(C)):
        raise ValueError(f"{name} must be finite, got {np.asarray(C).tolist()}")
    d = np.diagonal(C, axis1=-2, axis2=-1)
    if np.any(d < 0.0):
        raise ValueError(f"{name} has a negative variance {d.min()}; variances must be >= 0")
    scale = max(1.0, float(np.abs(C).max()) if C.size else 1.0)
    if C.size and np.abs(C - np.swapaxes(C, -1, -2)).max() > tol * scale:
        raise ValueError(f"{name} must be symmetric, got {np.asarray(C).tolist()}")
    if C.shape[-1] == 2:
        det = C[..., 0, 0] * C[..., 1, 1] - C[..., 0, 1] * C[..., 1, 0]
        if np.any(det < -tol * scale * scale):
            raise ValueError(f"{name} must be positive semi-definite, got determinant {det.min()}")
    elif C.size:
        w = np.linalg.eigvalsh(0.5 * (C + np.swapaxes(C, -1, -2)))
        if np.any(w < -tol * scale):
            raise ValueError(f"{name} must be positive semi-definite, got eigenvalue {w.min()}")


def as_odometry(u, Q) -> tuple[np.ndarray, np.ndarray]:
    u = np.asarray(u, dtype=float).reshape(-1)
    Q = np.asarray(Q, dtype=float)
    if u.shape != (3,):
        raise ValueError(f"u (odometry increment) must have shape (3,), got {u.shape}")
    if Q.shape != (3, 3):
        raise ValueError(f"Q (odometry covariance) must have shape (3, 3), got {Q.shape}")
    u = np.ascontiguousarray(u)
    Q = np.ascontiguousarray(Q)
    if odo_status(u, Q, 1e-9) == OK:
        return u, Q
    if not np.all(np.isfinite(u)):
        raise ValueError(f"u (odometry increment) must be finite, got {u}")
    _check_cov("Q (odometry covariance)", Q)
    return u, Q


def as_observations(z, R) -> tuple[np.ndarray, np.ndarray]:
    """z (k, 2) [range m, bearing rad]; R (2, 2) or (k, 2, 2). Returns R as (k, 2, 2)."""
    z = np.asarray(z, dtype=float)
    if z.ndim == 1 and z.size == 2:
        z = z.reshape(1, 2)
    if z.ndim != 2 or z.shape[1] != 2:
        raise ValueError(f"z (observations) must have shape (k, 2), got {z.shape}")
    R = np.asarray(R, dtype=float)
    if R.shape == (2, 2):
        R = np.broadcast_to(R, (z.shape[0], 2, 2))
    if R.shape != (z.shape[0], 2, 2):
        raise ValueError(f"R must have shape (2, 2) or ({z.shape[0]}, 2, 2), got {R.shape}")
    R = np.ascontiguousarray(R)
    if obs_status(np.ascontiguousarray(z), R, 1e-9) == OK:
        return z, R
    if not np.all(np.isfinite(z)):
        raise ValueError(f"z (observations) must be finite, got {z.tolist()}")
    if z.size and np.any(z[:, 0] <= 0.0):
        raise ValueError(
            f"z range must be > 0 m (a zero range has no bearing), got {z[:, 0].min()}"
        )
    _check_cov("R (observation covariance)", R)
    if R.shape[0]:
        det = R[:, 0, 0] * R[:, 1, 1] - R[:, 0, 1] * R[:, 1, 0]
        if np.any(np.diagonal(R, axis1=1, axis2=2) <= 0.0) or np.any(det <= 0.0):
            raise ValueError(
                "R (observation covariance) must be positive definite (a noise-free "
                f"range-bearing observation is not supported), got {R[np.argmin(det)].tolist()}"
            )
    return z, R


# --------------------------------------------------------------------------- pure steps


def predict(x, P, u, Q, *, x_lin=None, inplace: bool = False):
    """Prediction from one odometry increment (thesis eqs. 5.21–5.27).

    Parameters
    ----------
    x : (3 + 2n,) state; P : (3 + 2n, 3 + 2n) covariance.
    u : (3,) ``[dx m, dy m, dphi rad]`` in the body frame at the start of the interval.
    Q : (3, 3) covariance of ``u``.
    x_lin : (3,) optional linearization pose for ``F``: ``F = I + E(x_v' - x_lin)`` with
        ``E(d) = [[0, 0, -d_y], [0, 0, d_x], [0, 0, 0]]``. Default ``x[:3]`` (the standard
        EKF); the first-estimates-Jacobian filter passes the previous *predicted* pose.
    inplace : write into ``x`` and ``P`` (the class does, after validation) instead of copies.

    Returns ``(x, P)``. Only ``P_v`` (3×3) and ``P_vm`` / ``P_mv`` change: O(n).
    """
    xw, Pw = _work(x, inplace), _work(P, inplace)
    ref = xw[:3].copy() if x_lin is None else np.ascontiguousarray(x_lin, dtype=float)[:3]
    predict_inplace(
        xw, Pw, np.ascontiguousarray(u, dtype=float), np.ascontiguousarray(Q, dtype=float), ref
    )
    return _written_back(x, xw, inplace), _written_back(P, Pw, inplace)


def _work(a, inplace: bool) -> np.ndarray:
    """``a`` itself when ``inplace`` and already a float64 C-contiguous array (what the
    compiled steps take), else a float64 C-contiguous copy."""
    if (
        inplace
        and isinstance(a, np.ndarray)
        and a.dtype == np.float64
        and a.flags.c_contiguous
        and a.flags.writeable
    ):
        return a
    return np.array(a, dtype=float, order="C")


def _written_back(a, work: np.ndarray, inplace: bool) -> np.ndarray:
    """With ``inplace``, the caller's array holding ``work`` (copied back when ``work`` is
    a copy); else ``work``."""
    if inplace and work is not a:
        a[...] = work
        return a
    return work


def compose_odometry(u1, Q1, u2, Q2) -> tuple[np.ndarray, np.ndarray]:
    """Compose two body-frame increments ``u = u1 ⊕ u2`` with first-order covariance.

    A prediction with ``u`` gives the same mean as two predictions with ``u1`` then ``u2``
    (the composition is associative), and — because the Jacobians of the composite are
    exactly the chain-rule products evaluated at the same points — the same EKF covariance
    (``F = F2 F1``, proved in the tests to rounding error). So a filter may be predicted
    once per observation scan instead of once per control step without changing results.
    """
    u1 = np.asarray(u1, dtype=float)
    u2 = np.asarray(u2, dtype=float)
    c, s = math.cos(u1[2]), math.sin(u1[2])
    u = np.array(
        [u1[0] + c * u2[0] - s * u2[1], u1[1] + s * u2[0] + c * u2[1], wrap_scalar(u1[2] + u2[2])]
    )
    A = np.array(
        [[1.0, 0.0, -(s * u2[0] + c * u2[1])], [0.0, 1.0, c * u2[0] - s * u2[1]], [0, 0, 1]]
    )
    B = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    Q = A @ Q1 @ A.T + B @ Q2 @ B.T
    return u, 0.5 * (Q + Q.T)


def _innovation(z, zhat):
    y = z - zhat
    y[..., 1] = _wrap(y[..., 1])
    return y


def trsolve(L: np.ndarray, B: np.ndarray, trans: int = 0) -> np.ndarray:
    """Solve ``L X = B`` (``trans=1``: ``Lᵀ X = B``) for lower-triangular L (LAPACK dtrtrs;
    scipy's ``solve_triangular`` wrapper costs more than the solve at these sizes)."""
    X, info = _lapack.dtrtrs(L, np.ascontiguousarray(B), lower=1, trans=trans)
    if info != 0:
        raise np.linalg.LinAlgError(f"triangular solve failed (info={info})")
    return X


def subtract_outer(P: np.ndarray, W1: np.ndarray) -> None:
    """``P -= W1 W1ᵀ`` in place, one pass over P: BLAS dgemm on the transposed view for a
    large P, the compiled loop (:func:`slam.estimators.aekf_kernels.downdate`) for a small
    one."""
    if not (P.flags.c_contiguous and P.dtype == np.float64):
        P -= W1 @ W1.T
    elif P.shape[0] > _BLAS_MIN_STATE:
        # P is symmetric, so updating Pᵀ (its Fortran-ordered view) updates P.
        _blas.dgemm(-1.0, W1, W1, beta=1.0, c=P.T, trans_b=1, overwrite_c=1)
    else:
        downdate(P, np.ascontiguousarray(W1, dtype=float))


def update(
    x,
    P,
    z,
    R,
    idx,
    *,
    x_lin=None,
    batch: bool = True,
    joseph: bool = False,
    iterations: int = 1,
    relinearize_gate: float = 1.0,
    inplace: bool = False,
):
    """Update with range-bearing observations of known landmarks (eqs. 5.28–5.39).

    Parameters
    ----------
    x, P : state and covariance.
    z : (k, 2) observations ``[range m, bearing rad]`` in the body frame.
    R : (2, 2) or (k, 2, 2) observation covariance(s).
    idx : (k,) int, landmark index (0-based, landmark i is ``x[3+2i:5+2i]``) of each z.
    x_lin : optional state-sized linearization point for ``H`` (innovations always use x).
    batch : one stacked update for all k (``S`` is 2k × 2k) or k sequential updates
        (identical for a linear model; differ by re-linearization in the EKF).
    joseph : Joseph form ``(I - K H) P (I - K H)ᵀ + K R Kᵀ`` expanded in O(n² k); otherwise
        ``P - W1 W1ᵀ`` with ``W1 = P Hᵀ L⁻ᵀ``, ``S = L Lᵀ`` (symmetric by construction).
    iterations : 1 is the EKF update. More makes it the iterated EKF (Bell and Cathey
        1993): Gauss–Newton on the update's MAP cost, ``x_{i+1} = x0 + K_i (z - h(x_i) -
        H_i (x0 - x_i))`` with ``H_i`` at the iterate ``x_i``, at most ``iterations`` times
        or until the step is below 1e-9 — but only when the EKF step's linearization error
        (:func:`_linearization_error`, in units of R) exceeds ``relinearize_gate``. That
        happens at a loop closure, where one observation corrects metres of drift and the
        single linearization at the predicted pose falls short. The covariance then uses
        ``H`` at the converged estimate, or at ``x_lin`` when given (first-estimates
        Jacobians keep the filter's unobservable subspace). Routine updates stay EKF (or
        FEJ) updates.

    Returns ``(x, P)``.
    """
    if not (isinstance(iterations, int | np.integer) and iterations >= 1):
        raise ValueError(f"iterations must be an integer >= 1, got {iterations!r}")
    xw, Pw = _work(x, inplace), _work(P, inplace)
    z = np.ascontiguousarray(z, dtype=float).reshape(-1, 2)
    idx = np.ascontiguousarray(idx, dtype=np.intp).reshape(-1)
    R = np.asarray(R, dtype=float)
    if R.shape == (2, 2):
        R = np.broadcast_to(R, (idx.size, 2, 2))
    R = np.ascontiguousarray(R)
    xl = xw if x_lin is None else np.ascontiguousarray(x_lin, dtype=float)
    if idx.size and batch:
        _update_block(xw, Pw, z, R, idx, xl, joseph, iterations, relinearize_gate)
    elif idx.size:
        for j in range(idx.size):
            _update_block(
                xw,
                Pw,
                z[j : j + 1],
                R[j : j + 1],
                idx[j : j + 1],
                xl,
                joseph,
                iterations,
                relinearize_gate,
            )
    return _written_back(x, xw, inplace), _written_back(P, Pw, inplace)


def _gain_factors(x, P, z, R, idx, xl):
    """``(P Hᵀ, S, L, W1, step)`` of the batch update, Jacobians at ``xl`` (compiled:
    :func:`slam.estimators.aekf_kernels.ekf_gain`); LinAlgError when S is not positive
    definite."""
    ok, PHt, S, L, W1, step = ekf_gain(x, P, z, R, idx, xl)
    if not ok:
        raise np.linalg.LinAlgError("innovation covariance S is not positive definite")
    return PHt, S, L, W1, step


def _iterated_mean(x0, P, z, idx, R, iterations: int) -> np.ndarray:
    """Iterated-EKF mean (Gauss–Newton on ``|z - h(x)|²_R + |x - x0|²_P``), the
    Jacobians re-evaluated at each iterate. Only the pose and the observed landmarks enter
    ``h``, so each iteration costs O(N k)."""
    cols = (3 + 2 * idx[:, None] + np.arange(2)).reshape(-1)
    xi = x0.copy()
    for _ in range(iterations):
        zhat, Hv, Hm = observe(xi, idx)
        PHt, _, L, _, _ = _gain_factors(xi, P, z, R, idx, xi)
        dx_v = x0[:3] - xi[:3]
        dx_v[2] = wrap_scalar(float(dx_v[2]))
        dx_m = (x0[cols] - xi[cols]).reshape(-1, 2)
        r = (
            _innovation(z, zhat)
            - np.einsum("kba,a->kb", Hv, dx_v)
            - np.einsum("kba,ka->kb", Hm, dx_m)
        )
        xn = x0 + trsolve(L, trsolve(L, r.reshape(-1)), trans=1) @ PHt.T
        xn[2] = wrap_scalar(float(xn[2]))
        step = xn - xi
        step[2] = wrap_scalar(float(step[2]))
        xi = xn
        if float(np.max(np.abs(step))) < 1e-9:
            break
    return xi


def _linearization_error(x0, step, idx, Rb) -> float:
    """``eᵀ R⁻¹ e`` with ``e = h(x0 + step) - h(x0) - H(x0) step``: the part of the EKF
    step's predicted change of the observations that the linear model got wrong, in units
    of the observation noise."""
    z0, Hv, Hm = observe(x0, idx)
    cols = (3 + 2 * idx[:, None] + np.arange(2)).reshape(-1)
    z1, _, _ = observe(x0 + step, idx)
    lin = np.einsum("kba,a->kb", Hv, step[:3]) + np.einsum(
        "kba,ka->kb", Hm, step[cols].reshape(-1, 2)
    )
    e = (_innovation(z1, z0) - lin).reshape(-1)
    return float(e @ np.linalg.solve(Rb, e))


def _surely_linear(x0, step, idx, R, gate: float) -> bool:
    """True when a bound on :func:`_linearization_error` is already <= ``gate`` (then the
    exact value is too, and routine updates skip computing it).

    ``h`` depends on the pose and landmark only through ``d = m - p`` (the heading enters
    the bearing linearly), so ``e`` is the Taylor remainder of ``[|d|, atan2(d)]`` along
    ``delta`` (the step of ``m - p``): ``|e_r| <= |delta|² / (2 r_min)`` and ``|e_b| <=
    |delta|² / (2 r_min²)`` (Hessian norms ``1/r`` and ``1/r²``) with ``r_min = |d| -
    |delta|``, and ``eᵀ R⁻¹ e <= Σ |e_j|² / λ_min(R_j)``. Scalar arithmetic on the k
    observations of a scan (a handful), cheaper than the exact check's array calls (compiled:
    :func:`slam.estimators.aekf_kernels.surely_linear`)."""
    return surely_linear(x0, step, idx, R, gate)


def _update_block(
    x, P, z, R, idx, xl, joseph, iterations: int = 1, relinearize_gate: float = 1.0
) -> None:
    """One batch update of ``x``, ``P`` in place (float64 C-contiguous; ``xl`` the
    linearization state, ``x`` itself for the standard EKF)."""
    PHt, S, L, W1, step = _gain_factors(x, P, z, R, idx, xl)
    if (
        iterations > 1
        and not _surely_linear(x, step, idx, R, relinearize_gate)
        and _linearization_error(x, step, idx, _block_diag(R)) > relinearize_gate
    ):
        # the EKF step left the region where h is linear (a loop closure correcting
        # metres of drift): iterate the mean. The covariance takes H at the converged
        # estimate, or with FEJ still at the first estimates: re-linearizing it there
        # once per loop closure gave the filter spurious heading information (50 dense
        # loops: NEES 3.81 against 3.18, 51 % of scans inside the bounds against 87 %).
        x_new = _iterated_mean(x, P, z, idx, R, iterations)
        PHt, S, L, W1, _ = _gain_factors(x_new, P, z, R, idx, xl if xl is not x else x_new)
        x[...] = x_new
    else:
        add_step(x, step)
    if joseph:
        # (I-KH)P(I-KH)ᵀ + KRKᵀ = P - K(HP) - (PHᵀ)Kᵀ + K(HPHᵀ + R)Kᵀ, all O(n² k)
        K = trsolve(L, W1.T, trans=1).T
        KHP = K @ PHt.T
        P -= KHP
        P -= KHP.T
        P += K @ S @ K.T
        P[...] = 0.5 * (P + P.T)
    else:
        subtract_outer(P, W1)


def _block_diag(R: np.ndarray) -> np.ndarray:
    """(2k, 2k) block diagonal of the k (2, 2) covariances ``R``."""
    k = R.shape[0]
    Rb = np.zeros((2 * k, 2 * k))
    for j in range(k):  # k observations of one scan, not landmarks
        Rb[2 * j : 2 * j + 2, 2 * j : 2 * j + 2] = R[j]
    return Rb


def augment(x, P, z, R):
    """Add new landmarks from observations ``z`` (k, 2) (eqs. 5.40–5.47).

    ``g = [x_v + r cos(theta + phi), y_v + r sin(theta + phi)]``; ``P`` grows by 2k rows and
    columns, of which only the new blocks are computed (``G_x P_v*`` and
    ``G_x P_v G_xᵀ + G_z R G_zᵀ``): O(n k) arithmetic (plus the copy into the larger array).
    Several landmarks from one pose are correlated through ``P_v``, exactly as adding them
    one at a time would make them.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    R = np.asarray(R, dtype=float)
    k = z.shape[0]
    if R.shape == (2, 2):
        R = np.broadcast_to(R, (k, 2, 2))
    if k == 0:
        return x.copy(), P.copy()
    N = x.size
    a = x[2] + z[:, 1]
    c, s = np.cos(a), np.sin(a)
    r = z[:, 0]
    g = np.stack([x[0] + r * c, x[1] + r * s], axis=1)
    Gx = np.zeros((k, 2, 3))
    Gx[:, 0, 0] = 1.0
    Gx[:, 1, 1] = 1.0
    Gx[:, 0, 2] = -r * s
    Gx[:, 1, 2] = r * c
    Gz = np.empty((k, 2, 2))
    Gz[:, 0, 0] = c
    Gz[:, 0, 1] = -r * s
    Gz[:, 1, 0] = s
    Gz[:, 1, 1] = r * c
    Gx2 = Gx.reshape(2 * k, 3)
    xa = np.concatenate([x, g.reshape(-1)])
    Pa = np.empty((N + 2 * k, N + 2 * k))
    Pa[:N, :N] = P
    cross = Gx2 @ P[:3, :]  # (2k, N): new-to-old
    Pa[N:, :N] = cross
    Pa[:N, N:] = cross.T
    Pnn = cross[:, :3] @ Gx2.T
    blocks = Gz @ R @ np.swapaxes(Gz, 1, 2)
    for j in range(k):  # k new observations of one scan
        Pnn[2 * j : 2 * j + 2, 2 * j : 2 * j + 2] += blocks[j]
    Pa[N:, N:] = 0.5 * (Pnn + Pnn.T)
    return xa, Pa


def remove_landmarks(x, P, idx):
    """State reduction: delete landmarks ``idx`` (rows/columns of ``x`` and ``P``).

    Marginalizing a Gaussian is deleting its rows and columns, so the rest is unchanged.
    """
    x = np.asarray(x, dtype=float)
    P = np.asarray(P, dtype=float)
    idx = np.asarray(idx, dtype=np.intp).reshape(-1)
    keep = np.ones(x.size, dtype=bool)
    keep[3 + 2 * idx] = False
    keep[4 + 2 * idx] = False
    return x[keep], P[np.ix_(keep, keep)]


def landmark_marginals(x, P) -> tuple[np.ndarray, np.ndarray]:
    """Landmark means ``(n, 2)`` m and marginal covariances ``(n, 2, 2)`` m² of a
    ``[pose, landmarks]`` state (copies)."""
    n = (np.asarray(x).size - 3) // 2
    ar = np.arange(n)
    cov = np.asarray(P)[3:, 3:].reshape(n, 2, n, 2)[ar, :, ar, :].copy()
    return np.asarray(x)[3:].reshape(n, 2).copy(), cov


def associate(
    x,
    P,
    z,
    R,
    *,
    reject_gate: float = 4.0,
    augment_gate: float = 25.0,
    method: str = "ml",
    exclusive: bool = True,
    x_lin=None,
    return_scores: bool = False,
    unambiguous_gate: float | None = None,
):
    """Gated data association (Bailey's ``data_associate``, vectorized).

    For each observation: among landmarks with NIS < ``reject_gate`` pick the one with the
    smallest ML distance ``nis + ln det S`` (``method="ml"``) or smallest NIS (``"nn"``);
    if none is inside the reject gate and every NIS exceeds ``augment_gate`` the observation
    is a new landmark; otherwise (between the gates: ambiguous) it is rejected. With
    ``exclusive`` (beyond Bailey, who lets two observations of a scan update one landmark),
    a landmark claimed by several observations keeps only the best; the others are rejected.

    ``unambiguous_gate`` (beyond Bailey; None = off): an observation with no landmark inside
    the reject gate but exactly one landmark with NIS below this gate (and none other below
    it) is associated with that one instead of being discarded. Discarding every
    innovation above the reject gate truncates the innovation distribution, which makes a
    filter overconfident (13.5 % of correct observations at gate 4 with 2 dof).

    Returns ``(idx (k,) int landmark index or -1, new (k,) bool, nis (k,) float)``, and
    with ``return_scores`` also the full ``nis (k, n)`` matrix.
    """
    if method not in ("ml", "nn"):
        raise ValueError(f"method must be 'ml' or 'nn', got {method!r}")
    nis, nd = association_scores(x, P, z, R, x_lin=x_lin)
    return select_associations(
        nis,
        nd,
        reject_gate=reject_gate,
        augment_gate=augment_gate,
        method=method,
        exclusive=exclusive,
        return_scores=return_scores,
        unambiguous_gate=unambiguous_gate,
    )


def select_associations(
    nis,
    nd,
    *,
    reject_gate: float = 4.0,
    augment_gate: float = 25.0,
    method: str = "ml",
    exclusive: bool = True,
    return_scores: bool = False,
    unambiguous_gate: float | None = None,
):
    """The decision part of :func:`associate` from score matrices ``nis (k, n)`` and
    ``nd (k, n)`` (shared by the robocentric filter)."""
    if method not in ("ml", "nn"):
        raise ValueError(f"method must be 'ml' or 'nn', got {method!r}")
    k, n = nis.shape
    idx = np.full(k, -1, dtype=np.intp)
    best_nis = np.full(k, np.nan)
    if n == 0:
        out = idx, np.ones(k, dtype=bool), best_nis
        return (*out, nis) if return_scores else out
    inside = nis < reject_gate
    score = np.where(inside, nd if method == "ml" else nis, np.inf)
    j = np.argmin(score, axis=1)
    rows = np.arange(k)
    ok = inside[rows, j]
    idx[ok] = j[ok]
    best_nis[ok] = nis[rows[ok], j[ok]]
    new = ~ok & (nis.min(axis=1) > augment_gate)
    if unambiguous_gate is not None:
        cand = nis < unambiguous_gate
        single = ~ok & (cand.sum(axis=1) == 1)
        if np.any(single):
            jj = np.argmax(cand[single], axis=1)
            rs = rows[single]
            idx[rs] = jj
            best_nis[rs] = nis[rs, jj]
            ok = ok.copy()
            ok[rs] = True
            j = j.copy()
            j[rs] = jj
            score[rs, jj] = nis[rs, jj] if method == "nn" else nd[rs, jj]
            new[rs] = False
    if exclusive and np.count_nonzero(ok) > 1:
        sel = rows[ok]
        order = np.lexsort((score[sel, j[sel]], j[sel]))
        sel = sel[order]
        dup = np.zeros(sel.size, dtype=bool)
        dup[1:] = j[sel][1:] == j[sel][:-1]
        idx[sel[dup]] = -1
        best_nis[sel[dup]] = np.nan
    return (idx, new, best_nis, nis) if return_scores else (idx, new, best_nis)


# --------------------------------------------------------------------------- the class

_CONTROLLER = None


def _blas_limit(n_threads: int | None):
    """Context limiting BLAS threads (a cached threadpoolctl controller, ~30 µs)."""
    global _CONTROLLER
    if n_threads is None:
        return contextlib.nullcontext()
    if _CONTROLLER is None:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:  # pragma: no cover - threadpoolctl is a dependency
            return contextlib.nullcontext()
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=n_threads, user_api="blas")


@dataclass(frozen=True)
class AEKFConfig:
    """AEKF-SLAM options.

    reject_gate, augment_gate : Mahalanobis (NIS) gates of the association (Bailey's
        GATE_REJECT 4.0 and GATE_AUGMENT 25.0, which the reference used).
    association : "ml" (maximum likelihood, nis + ln det S), "nn" (nearest neighbour,
        NIS), "known" (observation labels give the landmark identity), or "jcbb" (joint
        compatibility branch and bound, :mod:`slam.estimators.jcbb`, at
        ``jcbb_confidence``; unpaired observations beyond ``augment_gate`` of every
        landmark start new ones, the rest are discarded).
    exclusive : at most one observation per landmark per scan.
    batch : batch update of all observations of a scan (Bailey's default) or sequential.
    joseph : Joseph-form covariance update instead of ``P - W1 W1ᵀ``.
    jacobians : "standard" EKF, or "fej" first-estimates Jacobians (consistency).
    unambiguous_gate : see :func:`associate`; None (Bailey's rule) by default.
    blas_threads : BLAS threads during an update (threadpoolctl; None leaves them alone).
        The default 1: the filter's triangular solves and rank-2k updates are small, and
        multi-threaded BLAS on a busy machine made them up to 40× slower (measured).
    merge_gate : landmark fusion (beyond Bailey; None = off): every ``merge_every`` scans,
        two landmarks closer than ``merge_radius_m`` whose difference is compatible with
        zero (``dᵀ C⁻¹ d < merge_gate``, C the covariance of the difference) are fused by
        the constraint ``x_i - x_j = 0`` (an exact observation) and the newer one removed:
        a landmark duplicated at a loop closure rejoins its original.
    iterations : Gauss–Newton iterations of each update (1 = EKF; more = iterated EKF,
        see :func:`update`), for the large corrections of a loop closure.
    fej_gating : with FEJ, gate the association with the FEJ Jacobians too; default False
        gates with the current-estimate Jacobians (first estimates can be far off after a
        loop closure, and a wrong S in the gate creates duplicate landmarks).
    max_range_m, fov_half_angle_rad : the sensor footprint used by state reduction.
    max_misses : state reduction: a landmark predicted well inside the footprint
        (``reduction_margin_m`` inside its range edge and 10° inside its angle edge) on
        this many consecutive scans without an association is removed. None disables.
    provisional_misses : delayed confirmation: a landmark seen only once (the scan that
        created it) is removed after this many scans well inside the footprint without an
        association, even when an observation of the scan was compatible with it (which
        went to another landmark): a single outlying observation beyond the augment gate
        of a known landmark then leaves no duplicate. None disables.
    """

    reject_gate: float = 4.0
    augment_gate: float = 25.0
    association: str = "ml"
    exclusive: bool = True
    batch: bool = True
    joseph: bool = False
    jacobians: str = "standard"
    max_range_m: float = 30.0
    fov_half_angle_rad: float = math.pi / 2
    max_misses: int | None = None
    provisional_misses: int | None = None
    reduction_margin_m: float = 3.0
    fej_gating: bool = False
    unambiguous_gate: float | None = None
    merge_gate: float | None = None
    merge_radius_m: float = 5.0
    merge_every: int = 10
    iterations: int = 1
    relinearize_gate: float = 1.0
    jcbb_confidence: float = 0.99
    blas_threads: int | None = 1

    def __post_init__(self) -> None:
        if not (self.reject_gate > 0 and math.isfinite(self.reject_gate)):
            raise ValueError(f"reject_gate must be > 0, got {self.reject_gate}")
        if not (self.augment_gate >= self.reject_gate and math.isfinite(self.augment_gate)):
            raise ValueError(
                f"augment_gate must be finite and >= reject_gate ({self.reject_gate}), "
                f"got {self.augment_gate}"
            )
        if self.association not in ("ml", "nn", "known", "jcbb"):
            raise ValueError(
                f"association must be 'ml', 'nn', 'known' or 'jcbb', got {self.association!r}"
            )
        if not 0.0 < self.jcbb_confidence < 1.0:
            raise ValueError(f"jcbb_confidence must be in (0, 1), got {self.jcbb_confidence!r}")
        if self.jacobians not in ("standard", "fej"):
            raise ValueError(f"jacobians must be 'standard' or 'fej', got {self.jacobians!r}")
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise ValueError(f"iterations must be an integer >= 1, got {self.iterations!r}")
        if not (math.isfinite(self.relinearize_gate) and self.relinearize_gate >= 0):
            raise ValueError(
                f"relinearize_gate must be finite and >= 0, got {self.relinearize_gate!r}"
            )
        if self.max_misses is not None and self.max_misses < 1:
            raise ValueError(f"max_misses must be >= 1 or None, got {self.max_misses}")
        if self.provisional_misses is not None and self.provisional_misses < 1:
            raise ValueError(
                f"provisional_misses must be >= 1 or None, got {self.provisional_misses}"
            )
        if not self.max_range_m > 0:
            raise ValueError(f"max_range_m must be > 0, got {self.max_range_m}")


AEKF_PRESETS: dict[str, dict] = {
    # Bailey's toolbox as the reference ran it (the AEKFConfig defaults)
    "reference": {},
    # the most consistent combination measured (slam/experiments/README.md): first-estimates
    # Jacobians, joint-compatibility association with ambiguity rejection and iterated
    # loop-closure updates
    "consistent": {"jacobians": "fej", "association": "jcbb", "iterations": 10},
}


#: preset of an AEKFSlam built without ``config`` or ``preset`` (``make_estimator("aekf")``,
#: scenarios, envs, ``undersea slam-experiment``); Bailey's filter is ``preset="reference"``
DEFAULT_PRESET = "consistent"


class AEKFSlam:
    """AEKF-SLAM behind :class:`slam.estimators.base.SlamEstimator` (thin wrapper of the
    pure functions; a test checks they agree).

    The filter starts at ``x0`` (default the origin) with covariance ``P0`` (default zero:
    the world frame is the initial pose, thesis §5.6.1). A rejected input raises
    ``ValueError`` before anything is changed. Without ``config`` the filter starts from
    the preset ``preset`` of :data:`AEKF_PRESETS` (default :data:`DEFAULT_PRESET`,
    ``"consistent"``; ``"reference"`` is Bailey's filter as the thesis ran it); keyword
    parameters override it.
    """

    name = "aekf"

    def __init__(
        self,
        config: AEKFConfig | None = None,
        *,
        x0=None,
        P0=None,
        rng: np.random.Generator | None = None,
        seed: int | None = None,
        **params,
    ):
        # rng / seed are accepted and ignored (the filter is deterministic) so that the
        # factory can pass the same keywords to every estimator.
        del rng, seed
        preset = params.pop("preset", None)
        if preset is None and config is None:
            preset = DEFAULT_PRESET
        if preset is not None:
            if config is not None:
                raise ValueError("pass either config or preset, got both")
            if preset not in AEKF_PRESETS:
                raise ValueError(f"preset must be one of {', '.join(AEKF_PRESETS)}, got {preset!r}")
            params = {**AEKF_PRESETS[preset], **params}
        if config is None:
            config = AEKFConfig(**params)
        elif params:
            raise ValueError(
                f"pass either config or keyword parameters, got both: {sorted(params)}"
            )
        self.config = config
        x0 = np.zeros(3) if x0 is None else np.asarray(x0, dtype=float).reshape(-1)
        P0 = np.zeros((3, 3)) if P0 is None else np.asarray(P0, dtype=float)
        if x0.shape != (3,):
            raise ValueError(f"x0 must have shape (3,), got {x0.shape}")
        if P0.shape != (3, 3):
            raise ValueError(f"P0 must have shape (3, 3), got {P0.shape}")
        check_state(x0, P0, psd=True)
        self.x = x0.copy()
        self.x[2] = wrap_scalar(float(self.x[2]))
        self.P = 0.5 * (P0 + P0.T)
        self._pose_prior = self.x[:3].copy()  # previous predicted pose (FEJ)
        self._lm_first = np.empty((0, 2))  # first estimates (FEJ)
        self._xl_cache = self._xl_source = None  # FEJ linearization state (_x_lin)
        self.labels = np.empty(0, dtype=np.int64)  # label of the creating observation, -1 none
        self.ids = np.empty(0, dtype=np.int64)  # persistent landmark ids (0, 1, ... created)
        self.misses = np.empty(0, dtype=np.int64)
        self.hits = np.empty(0, dtype=np.int64)
        self._next_id = 0
        self.n_removed = 0
        self.n_merged = 0
        self._scans = 0

    # ---- SlamEstimator
    def predict(self, odometry: Odometry) -> None:
        self.predict_arrays(odometry.delta, odometry.cov)

    def predict_arrays(self, u, Q) -> None:
        """Predict from ``u`` (3,) body-frame increment with covariance ``Q`` (3, 3)."""
        u, Q = as_odometry(u, Q)
        self.x, self.P = _work(self.x, True), _work(self.P, True)
        ref = self._pose_prior if self.config.jacobians == "fej" else self.x[:3].copy()
        predict_inplace(self.x, self.P, u, Q, ref)
        self._pose_prior = self.x[:3].copy()

    def update(self, observations: Sequence[RangeBearing]) -> UpdateResult:
        k = len(observations)
        z = np.empty((k, 2))
        R = np.empty((k, 2, 2))
        labels = np.full(k, -1, dtype=np.int64)
        has_label = np.zeros(k, dtype=bool)
        for j, ob in enumerate(observations):  # unpack the k observation objects of a scan
            z[j] = ob.z
            R[j] = ob.R
            if ob.label is not None:
                labels[j] = ob.label
                has_label[j] = True
        return self.update_arrays(z, R, labels if has_label.all() else None)

    def update_arrays(self, z, R, labels=None) -> UpdateResult:
        """Associate, update and augment with one scan: ``z`` (k, 2), ``R`` (2, 2) or
        (k, 2, 2), ``labels`` (k,) int or None (needed for ``association="known"``)."""
        if self.x.size + 2 * len(z) <= _BLAS_MIN_STATE:  # no BLAS call: no thread limit
            return self._update_arrays(z, R, labels)
        with _blas_limit(self.config.blas_threads):
            return self._update_arrays(z, R, labels)

    def _update_arrays(self, z, R, labels) -> UpdateResult:
        z, R = as_observations(z, R)
        k = z.shape[0]
        cfg = self.config
        if labels is not None:
            labels = np.asarray(labels, dtype=np.int64).reshape(-1)
            if labels.shape != (k,):
                raise ValueError(f"labels must have shape ({k},), got {labels.shape}")
        if cfg.association == "known" and labels is None:
            raise ValueError("association='known' needs a label on every observation")
        n = self.n_landmarks
        x_lin = self._x_lin()
        if k == 0:
            self._end_of_scan(np.zeros(0, dtype=np.intp), None)
            return UpdateResult(np.zeros(0, np.intp), np.zeros(0, bool), np.zeros(0))
        compatible = None  # landmarks some observation could be (NIS < augment gate)
        if cfg.association == "jcbb":
            jc = jcbb(self.x, self.P, z, R, confidence=cfg.jcbb_confidence)
            idx = jc.pairs
            new, nis, compatible = jcbb_outcome(jc.nis, idx, jc.ambiguous, cfg.augment_gate)
        elif cfg.association == "known":
            idx, new = self._associate_known(labels)
            nis = np.full(k, np.nan)
            if (idx >= 0).any():
                m = idx >= 0
                s, _ = association_scores(self.x, self.P, z[m], R[m], x_lin=x_lin)
                nis[m] = s[np.arange(m.sum()), idx[m]]
        else:
            idx, new, nis, scores = associate(
                self.x,
                self.P,
                z,
                R,
                reject_gate=cfg.reject_gate,
                augment_gate=cfg.augment_gate,
                method=cfg.association,
                exclusive=cfg.exclusive,
                x_lin=x_lin if cfg.fej_gating else None,
                return_scores=True,
                unambiguous_gate=cfg.unambiguous_gate,
            )
            compatible = (scores < cfg.augment_gate).any(axis=0)
        known = idx >= 0
        if known.any():
            self._update_known(z[known], R[known], idx[known], x_lin)
        assoc = idx.copy()
        if new.any():
            m = int(new.sum())
            self.x, self.P = augment(self.x, self.P, z[new], R[new])
            self._lm_first = np.concatenate([self._lm_first, self.x[3 + 2 * n :].reshape(m, 2)])
            lab = labels[new] if labels is not None else np.full(m, -1, np.int64)
            self.labels = np.concatenate([self.labels, lab])
            self.ids = np.concatenate([self.ids, self._next_id + np.arange(m)])
            self._next_id += m
            self.misses = np.concatenate([self.misses, np.zeros(m, np.int64)])
            self.hits = np.concatenate([self.hits, np.ones(m, np.int64)])
            assoc[new] = n + np.arange(m)
        if known.any():
            self.hits[idx[known]] += 1
        assoc = self._end_of_scan(assoc, compatible)
        return UpdateResult(assoc, new, nis)

    def _update_known(self, z, R, idx, x_lin) -> None:
        """:func:`update` of the filter's own state in place with the scan's associated
        observations (validated C-contiguous arrays: straight to the compiled steps)."""
        cfg = self.config
        self.x, self.P = _work(self.x, True), _work(self.P, True)
        xl = self.x if x_lin is None else x_lin
        args = (xl, cfg.joseph, cfg.iterations, cfg.relinearize_gate)
        if cfg.batch:
            _update_block(self.x, self.P, z, R, idx, *args)
        else:
            for j in range(idx.size):
                _update_block(self.x, self.P, z[j : j + 1], R[j : j + 1], idx[j : j + 1], *args)

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        return self.x[:3].copy(), self.P[:3, :3].copy()

    def landmarks(self) -> tuple[np.ndarray, np.ndarray]:
        return landmark_marginals(self.x, self.P)

    # ---- extras
    @property
    def n_landmarks(self) -> int:
        return (self.x.size - 3) // 2

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the full state ``(x, P)``."""
        return self.x.copy(), self.P.copy()

    def _x_lin(self):
        """FEJ linearization state ``[current pose, first landmark estimates]`` (None for
        standard Jacobians). Kept between scans: rebuilt when ``_lm_first`` is replaced
        (augment, removal, fusion all assign a new array), else only its pose is written."""
        if self.config.jacobians != "fej":
            return None
        xl = self._xl_cache
        if xl is None or self._xl_source is not self._lm_first:
            xl = np.concatenate([self.x[:3], self._lm_first.reshape(-1)])
            self._xl_cache, self._xl_source = xl, self._lm_first
        else:
            xl[:3] = self.x[:3]
        return xl

    def _associate_known(self, labels):
        k = labels.size
        idx = np.full(k, -1, dtype=np.intp)
        if self.labels.size:
            order = np.argsort(self.labels, kind="stable")
            sl = self.labels[order]
            pos = np.searchsorted(sl, labels)
            pos_c = np.minimum(pos, sl.size - 1)
            hit = sl[pos_c] == labels
            idx[hit] = order[pos_c[hit]]
        new = idx < 0
        # two observations with one new label in one scan: only the first creates it
        if np.any(new):
            _, first = np.unique(labels[new], return_index=True)
            keep = np.zeros(int(new.sum()), dtype=bool)
            keep[first] = True
            nw = np.flatnonzero(new)
            new[nw[~keep]] = False
        return idx, new

    def _end_of_scan(self, assoc: np.ndarray, compatible) -> np.ndarray:
        """State reduction and landmark fusion after a scan; returns remapped indices."""
        assoc = self._reduce(assoc, compatible)
        self._scans += 1
        cfg = self.config
        if cfg.merge_gate is not None and self._scans % cfg.merge_every == 0:
            assoc = self._merge_duplicates(assoc)
        return assoc

    def _merge_duplicates(self, assoc: np.ndarray) -> np.ndarray:
        """Fuse statistically identical landmark pairs (see ``AEKFConfig.merge_gate``)."""
        from scipy.spatial import cKDTree

        cfg = self.config
        n = self.n_landmarks
        if n < 2:
            return assoc
        lm = self.x[3:].reshape(n, 2)
        pairs = cKDTree(lm).query_pairs(cfg.merge_radius_m, output_type="ndarray")
        if pairs.size == 0:
            return assoc
        i, j = pairs[:, 0], pairs[:, 1]
        P = self.P
        a, b = 3 + 2 * i, 3 + 2 * j
        blk = lambda r, c: np.stack(  # noqa: E731
            [np.stack([P[r, c], P[r, c + 1]], -1), np.stack([P[r + 1, c], P[r + 1, c + 1]], -1)], -2
        )
        C = blk(a, a) + blk(b, b) - blk(a, b) - blk(b, a)
        d = lm[i] - lm[j]
        det = C[:, 0, 0] * C[:, 1, 1] - C[:, 0, 1] * C[:, 1, 0]
        q = (
            C[:, 1, 1] * d[:, 0] ** 2
            - 2 * C[:, 0, 1] * d[:, 0] * d[:, 1]
            + C[:, 0, 0] * d[:, 1] ** 2
        ) / det
        cand = np.flatnonzero((q < cfg.merge_gate) & (det > 0))
        if cand.size == 0:
            return assoc
        drop: list[int] = []
        used: set[int] = set()
        for c in cand[np.argsort(q[cand])]:  # the few compatible pairs, best first
            keep_i, gone = (
                (int(i[c]), int(j[c]))
                if self.ids[i[c]] < self.ids[j[c]]
                else (int(j[c]), int(i[c]))
            )
            if keep_i in used or gone in used:
                continue
            used.update((keep_i, gone))
            self._fuse(keep_i, gone)
            drop.append(gone)
        self.n_merged += len(drop)
        dropped = np.asarray(drop, dtype=np.intp)
        self.x, self.P = remove_landmarks(self.x, self.P, dropped)
        keep = np.ones(n, dtype=bool)
        keep[dropped] = False
        for name in ("_lm_first", "labels", "ids", "misses", "hits"):
            setattr(self, name, getattr(self, name)[keep])
        new_index = np.cumsum(keep) - 1
        out = assoc.copy()
        m = out >= 0
        out[m] = np.where(keep[out[m]], new_index[out[m]], -1)
        return out

    def _fuse(self, i: int, j: int) -> None:
        """Kalman update with the exact constraint ``x_i - x_j = 0`` (H = [.. I .. -I ..])."""
        a, b = 3 + 2 * i, 3 + 2 * j
        PHt = self.P[:, a : a + 2] - self.P[:, b : b + 2]
        S = PHt[a : a + 2] - PHt[b : b + 2]
        S = 0.5 * (S + S.T) + 1e-12 * np.eye(2)
        L = np.linalg.cholesky(S)
        W1 = trsolve(L, PHt.T).T
        y = -(self.x[a : a + 2] - self.x[b : b + 2])
        self.x += W1 @ trsolve(L, y)
        self.x[2] = wrap_scalar(float(self.x[2]))
        subtract_outer(self.P, W1)

    def _reduce(self, assoc: np.ndarray, compatible=None) -> np.ndarray:
        """Count misses of landmarks predicted inside the footprint that no observation of
        the scan was compatible with (NIS < augment gate: an observation rejected as
        ambiguous may be this landmark); remove landmarks missed ``max_misses`` scans in a
        row (the thesis's state reduction of corrupted landmarks); with
        ``provisional_misses``, landmarks seen once are removed after that many misses,
        compatible observations or not."""
        cfg = self.config
        n = self.n_landmarks
        if (cfg.max_misses is None and cfg.provisional_misses is None) or n == 0:
            return assoc
        drop, n_drop = count_misses(
            self.x,
            assoc,
            _NO_COMPATIBLE if compatible is None else compatible,
            self.hits,
            self.misses,
            cfg.max_range_m - cfg.reduction_margin_m,
            cfg.fov_half_angle_rad - math.radians(10.0),
            -1 if cfg.max_misses is None else cfg.max_misses,
            -1 if cfg.provisional_misses is None else cfg.provisional_misses,
        )
        if n_drop == 0:
            return assoc
        dropped = np.flatnonzero(drop)
        self.x, self.P = remove_landmarks(self.x, self.P, dropped)
        keep = ~drop
        for name in ("_lm_first", "labels", "ids", "misses", "hits"):
            setattr(self, name, getattr(self, name)[keep])
        self.n_removed += dropped.size
        new_index = np.cumsum(keep) - 1
        out = assoc.copy()
        m = out >= 0
        out[m] = np.where(keep[out[m]], new_index[out[m]], -1)
        return out
