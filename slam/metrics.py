"""SLAM accuracy and consistency metrics.

* Landmark map error: estimated landmarks are associated to the true ones (by the label of
  the observation that created them when known, else a minimum-cost one-to-one assignment,
  ``scipy.optimize.linear_sum_assignment``, gated by a distance); RMSE over matched
  landmarks, per-landmark errors (the thesis's A, B, ... are errors at named true
  landmarks), unmatched estimates counted as duplicates/spurious.
* Trajectory error: position RMSE (absolute trajectory error; the filters start at the true
  pose in the world frame, so no alignment) and heading RMSE.
* Consistency: NEES ``eᵀ P⁻¹ e`` per step, its average over N Monte Carlo runs and the
  two-sided 95 % chi-square bounds ``χ²_{N n}(α/2) / N``, ``χ²_{N n}(1 - α/2) / N``
  (Bar-Shalom, Li and Kirubarajan, *Estimation with Applications to Tracking and
  Navigation*, 2001, §5.4); NIS likewise with the observation dimension.

Units: metres and radians; frames: the 2-D world frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

__all__ = [
    "LandmarkErrors",
    "average_nees",
    "chi2_bounds",
    "fraction_inside",
    "landmark_errors",
    "landmark_mahalanobis",
    "named_landmark_errors",
    "nees",
    "pose_error",
    "trajectory_rmse",
]


def _wrap(a):
    return np.mod(np.asarray(a, dtype=float) + np.pi, 2 * np.pi) - np.pi


@dataclass(frozen=True)
class LandmarkErrors:
    """Matched pairs ``est_index[i] <-> true_index[i]`` with Euclidean ``errors[i]`` (m),
    ``rmse`` over them (m, nan if none), ``n_unmatched_est`` (duplicates or spurious
    landmarks), ``n_unmatched_true`` (true landmarks without an estimate)."""

    est_index: np.ndarray
    true_index: np.ndarray
    errors: np.ndarray
    rmse: float
    n_unmatched_est: int
    n_unmatched_true: int


def landmark_errors(
    est,
    true,
    *,
    est_labels=None,
    max_distance: float = 10.0,
) -> LandmarkErrors:
    """Associate estimated landmarks ``est (m, 2)`` to true ``true (n, 2)`` and measure.

    est_labels : optional (m,) int, the true-landmark index each estimate was created from
        (-1 unknown). Estimates with a label are matched by it (the first estimate of a
        label wins; later ones with the same label count as duplicates); the rest by a
        minimum-total-distance one-to-one assignment among the still unmatched, accepting
        pairs closer than ``max_distance`` m.
    """
    est = np.asarray(est, dtype=float).reshape(-1, 2)
    true = np.asarray(true, dtype=float).reshape(-1, 2)
    m, n = est.shape[0], true.shape[0]
    if not (np.all(np.isfinite(est)) and np.all(np.isfinite(true))):
        raise ValueError("landmark positions must be finite")
    ei: list[int] = []
    ti: list[int] = []
    used_e = np.zeros(m, dtype=bool)
    used_t = np.zeros(n, dtype=bool)
    if est_labels is not None:
        lab = np.asarray(est_labels, dtype=np.int64).reshape(-1)
        if lab.shape != (m,):
            raise ValueError(f"est_labels must have shape ({m},), got {lab.shape}")
        if np.any(lab >= n):
            raise ValueError(
                f"est_labels must be < {n} (number of true landmarks), got {lab.max()}"
            )
        sel = np.flatnonzero(lab >= 0)
        used_e[sel] = True  # a labelled estimate is never re-matched by distance
        _, first = np.unique(lab[sel], return_index=True)  # first estimate of each label
        ei.extend(sel[first].tolist())
        ti.extend(lab[sel][first].tolist())
        used_t[lab[sel][first]] = True
    re = np.flatnonzero(~used_e)
    rt = np.flatnonzero(~used_t)
    if re.size and rt.size:
        D = np.hypot(est[re, None, 0] - true[None, rt, 0], est[re, None, 1] - true[None, rt, 1])
        r, c = linear_sum_assignment(np.where(D < max_distance, D, 1e9))
        ok = D[r, c] < max_distance
        ei.extend(re[r[ok]].tolist())
        ti.extend(rt[c[ok]].tolist())
    ei_a = np.asarray(ei, dtype=np.intp)
    ti_a = np.asarray(ti, dtype=np.intp)
    err = np.hypot(*(est[ei_a] - true[ti_a]).T) if ei_a.size else np.zeros(0)
    rmse = float(np.sqrt(np.mean(err**2))) if err.size else float("nan")
    return LandmarkErrors(ei_a, ti_a, err, rmse, m - ei_a.size, n - ti_a.size)


def named_landmark_errors(le: LandmarkErrors, est, true, named) -> dict[str, float]:
    """Errors (m) at named true landmarks, ``named = {"A": (x, y), ...}``: the true
    landmark nearest each named point, and the error of the estimate matched to it (nan
    when it has none)."""
    est = np.asarray(est, dtype=float).reshape(-1, 2)
    true = np.asarray(true, dtype=float).reshape(-1, 2)
    out = {}
    for key, p in named.items():
        t = int(np.argmin(np.hypot(*(true - np.asarray(p, dtype=float)).T)))
        j = np.flatnonzero(le.true_index == t)
        out[key] = float(np.hypot(*(est[le.est_index[j[0]]] - true[t]))) if j.size else float("nan")
    return out


def landmark_mahalanobis(est, cov, true) -> np.ndarray:
    """Mahalanobis distance ``sqrt(eᵀ C⁻¹ e)`` of matched pairs: ``est (k, 2)``,
    ``cov (k, 2, 2)``, ``true (k, 2)``. A landmark is inside its 3σ ellipse when <= 3."""
    e = np.asarray(true, dtype=float) - np.asarray(est, dtype=float)
    C = np.asarray(cov, dtype=float)
    a, b, d = C[:, 0, 0], C[:, 0, 1], C[:, 1, 1]
    det = a * d - b * b
    q = (d * e[:, 0] ** 2 - 2 * b * e[:, 0] * e[:, 1] + a * e[:, 1] ** 2) / det
    return np.sqrt(np.maximum(q, 0.0))


def pose_error(true, est) -> np.ndarray:
    """``true - est`` for poses ``(..., 3)`` with the heading difference wrapped."""
    e = np.asarray(true, dtype=float) - np.asarray(est, dtype=float)
    e[..., 2] = _wrap(e[..., 2])
    return e


def trajectory_rmse(true, est) -> tuple[float, float]:
    """Position RMSE (ATE, m) and heading RMSE (rad) of pose sequences ``(T, 3)``."""
    e = pose_error(true, est)
    return float(np.sqrt(np.mean(np.sum(e[:, :2] ** 2, axis=1)))), float(
        np.sqrt(np.mean(e[:, 2] ** 2))
    )


def nees(err, P) -> np.ndarray:
    """Normalized estimation error squared ``eᵀ P⁻¹ e`` of ``err (T, n)``, ``P (T, n, n)``;
    nan where P is singular."""
    err = np.asarray(err, dtype=float)
    P = np.asarray(P, dtype=float)
    out = np.full(err.shape[0], np.nan)
    try:
        sol = np.linalg.solve(P, err[..., None])[..., 0]
        out = np.einsum("ti,ti->t", err, sol)
    except np.linalg.LinAlgError:
        for t in range(err.shape[0]):  # fallback only when some P is singular
            try:
                out[t] = err[t] @ np.linalg.solve(P[t], err[t])
            except np.linalg.LinAlgError:
                out[t] = np.nan
    return out


def chi2_bounds(dof: int, n_runs: int, alpha: float = 0.05) -> tuple[float, float]:
    """Two-sided ``1 - alpha`` bounds of the average of ``n_runs`` chi-square(``dof``)
    variables: ``χ²_{N·dof}(α/2) / N`` and ``χ²_{N·dof}(1 - α/2) / N``. For dof 3 and
    50 runs: (2.36, 3.72)."""
    if dof < 1 or n_runs < 1:
        raise ValueError(f"dof and n_runs must be >= 1, got dof={dof}, n_runs={n_runs}")
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    k = dof * n_runs
    return float(chi2.ppf(alpha / 2, k) / n_runs), float(chi2.ppf(1 - alpha / 2, k) / n_runs)


def average_nees(nees_runs) -> np.ndarray:
    """Average over runs (axis 0) of per-step NEES ``(N, T)``, ignoring nan."""
    a = np.asarray(nees_runs, dtype=float)
    return np.nanmean(a, axis=0)


def fraction_inside(values, bounds: tuple[float, float]) -> float:
    """Fraction of finite ``values`` inside ``[lo, hi]``."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.mean((v >= bounds[0]) & (v <= bounds[1]))) if v.size else float("nan")
