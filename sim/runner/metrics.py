"""Run metrics against the simulator's ground truth (all deterministic given the seed).

* Landmark RMSE: estimated landmarks matched one-to-one to true objects by minimum total
  distance (Hungarian assignment, scipy) within ``match_radius``; RMSE over matched pairs;
  unmatched estimates count as spurious, true objects with more than one estimate inside
  the radius count as duplicated (data association turning one object into many).
* ATE: RMSE of the estimated (x, y) against the true position at the same times.
* Pose NEES: e_k^T P_k^-1 e_k with e = [dx, dy, wrap(dphi)] (3 dof), averaged over the
  run, with the fraction of steps inside the two-sided 95 % chi-square interval.
* Detections: a detection is a true positive when >= 10 % of the pixels of its region
  carry an object label (simulator per-sample object id > 0) - PPV = TP / detections;
  FPR = seabed pixels inside segmented regions / seabed pixels (pixel level, the
  reference reports FPR next to PPV; side-scan: every segmented region of the owned
  rows; FLS / MSIS: the regions kept by the area filter); recall = true objects
  detected / objects imaged.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

from slam.types import wrap_angle


def match_landmarks(est: np.ndarray, truth: np.ndarray, match_radius: float = 5.0):
    """Hungarian matching of estimated (n, 2) to true (m, 2) points; pairs farther than
    match_radius are not matched. Returns (est_idx, true_idx, distances)."""
    est = np.asarray(est, float).reshape(-1, 2)
    truth = np.asarray(truth, float).reshape(-1, 2)
    if len(est) == 0 or len(truth) == 0:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    D = np.linalg.norm(est[:, None, :] - truth[None, :, :], axis=-1)
    cost = np.where(D <= match_radius, D, 1e6)
    r, c = linear_sum_assignment(cost)
    keep = D[r, c] <= match_radius
    return r[keep], c[keep], D[r[keep], c[keep]]


def landmark_metrics(
    est: np.ndarray, est_cov: np.ndarray, truth: np.ndarray, match_radius: float = 5.0
) -> dict:
    est = np.asarray(est, float).reshape(-1, 2)
    truth = np.asarray(truth, float).reshape(-1, 2)
    ei, ti, d = match_landmarks(est, truth, match_radius)
    out = {
        "n_estimated": len(est),
        "n_true_mapped": len(ti),
        "n_spurious": int(len(est) - len(ei)),
        "rmse_m": float(np.sqrt(np.mean(d**2))) if len(d) else None,
        "max_error_m": float(d.max()) if len(d) else None,
    }
    if len(est) and len(truth):
        D = np.linalg.norm(est[:, None, :] - truth[None, :, :], axis=-1)
        near = (D <= match_radius) & (D == D.min(axis=1, keepdims=True))
        out["n_duplicated_objects"] = int(np.sum(near.sum(axis=0) > 1))
    else:
        out["n_duplicated_objects"] = 0
    if len(ei):
        e = est[ei] - truth[ti]
        C = np.asarray(est_cov, float).reshape(-1, 2, 2)[ei]
        nees = np.einsum("ni,nij,nj->n", e, np.linalg.inv(C), e)
        out["landmark_nees_mean"] = float(nees.mean())
        out["landmark_nees_95_upper"] = float(chi2.ppf(0.95, 2))
    return out


def pose_metrics(t: np.ndarray, est: np.ndarray, cov: np.ndarray, truth: np.ndarray) -> dict:
    """t (k,), est (k, 3) [x, y, phi], cov (k, 3, 3), truth (k, 3) at the same times."""
    est = np.asarray(est, float).reshape(-1, 3)
    truth = np.asarray(truth, float).reshape(-1, 3)
    if len(est) == 0:
        return {"ate_m": None, "nees_mean": None, "n_poses": 0}
    e = truth - est
    e[:, 2] = wrap_angle(e[:, 2])
    cov = np.asarray(cov, float).reshape(-1, 3, 3)
    # regularize exactly-zero covariance (start pose) so NEES stays defined
    cov = cov + np.eye(3) * 1e-12
    nees = np.einsum("ni,nij,nj->n", e, np.linalg.inv(cov), e)
    lo, hi = chi2.ppf(0.025, 3), chi2.ppf(0.975, 3)
    return {
        "n_poses": len(est),
        "ate_m": float(np.sqrt(np.mean(np.sum(e[:, :2] ** 2, axis=1)))),
        "final_position_error_m": float(np.linalg.norm(e[-1, :2])),
        "heading_rmse_deg": float(np.degrees(np.sqrt(np.mean(e[:, 2] ** 2)))),
        "nees_mean": float(np.mean(nees)),
        "nees_median": float(np.median(nees)),
        "nees_in_95_interval": float(np.mean((nees >= lo) & (nees <= hi))),
        "nees_95_interval": [float(lo), float(hi)],
    }


def detection_metrics(
    tp: int,
    fp: int,
    fg_bg_pixels: int,
    bg_pixels: int,
    detected_ids: Sequence[int],
    imaged_ids: Sequence[int],
) -> dict:
    n = tp + fp
    imaged = set(int(i) for i in imaged_ids if i > 0)
    found = set(int(i) for i in detected_ids if i > 0) & imaged
    return {
        "n_detections": n,
        "true_positives": tp,
        "false_positives": fp,
        "ppv": tp / n if n else None,
        "fpr_pixels": fg_bg_pixels / bg_pixels if bg_pixels else None,
        "objects_imaged": sorted(imaged),
        "objects_detected": sorted(found),
        "recall_objects": len(found) / len(imaged) if imaged else None,
    }
