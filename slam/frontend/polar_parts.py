"""Pieces of the FLS / MSIS polar front end (slam.frontend.polar): the conditioning of a
frame (step 1), region moments in
metres, their range-bearing form, the footprint-gap grouping of an extended object's
regions, and the k-of-n persistence filter with keyframing. Vectorized with numpy /
scipy; the persistence filter loops over the handful of confirmed objects of a frame."""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING

import cv2
import numpy as np
from scipy import ndimage
from scipy.sparse.csgraph import connected_components

from slam.types import wrap_angle

if TYPE_CHECKING:
    from slam.frontend.polar import PolarFrontendConfig


def condition_polar(
    image: np.ndarray, *, log_compressed: bool, dynamic_range_db: float, cfg: PolarFrontendConfig
) -> tuple[np.ndarray, np.ndarray]:
    """Step 1: a sonar's display image (values in [0, 1] spanning ``dynamic_range_db`` when
    ``log_compressed``, else linear intensity) -> (uint8 image on the fixed scale
    [0, top_db] dB above background, float32 dB above background clipped at 0)."""
    x = np.asarray(image, dtype=np.float64)
    if x.ndim != 2 or x.size == 0:
        raise ValueError(f"image must be a non-empty 2-D array, got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("image has NaN or infinite values")
    lin = np.power(10.0, x * (dynamic_range_db / 10.0)) if log_compressed else x
    valid = x > (cfg.floor if log_compressed else cfg.floor * max(float(x.max()), 1e-30))
    if not valid.any():
        z = np.zeros(x.shape, np.float32)
        return z.astype(np.uint8), z
    fill = float(np.median(lin[valid]))
    bg = ndimage.median_filter(np.where(valid, lin, fill), size=cfg.background_window)
    m = np.where(valid, lin / np.maximum(bg, 1e-30), 1.0).astype(np.float32)
    if cfg.looks > 1:
        m = cv2.blur(m, (cfg.looks, cfg.looks))
    db = (10.0 * np.log10(np.clip(m, 1.0, 10.0 ** (cfg.top_db / 10.0)))).astype(np.float32)
    g8 = np.round(db * (255.0 / cfg.top_db)).astype(np.uint8)
    return g8, db


def region_moments(
    labels: np.ndarray, n: int, x: np.ndarray, y: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid (n, 2) m, second-moment matrix (n, 2, 2) m² and cell count (n,) of the
    cells of labels 1..n, with per-cell metric coordinates ``x``, ``y`` (same shape as
    ``labels``). Vectorized (numpy.bincount); a label without cells gets count 0 and
    NaN moments."""
    lab = labels.ravel()
    xs, ys = x.ravel(), y.ravel()
    cnt = np.bincount(lab, minlength=n + 1)[1 : n + 1].astype(float)
    with np.errstate(invalid="ignore", divide="ignore"):
        sx = np.bincount(lab, xs, n + 1)[1:] / cnt
        sy = np.bincount(lab, ys, n + 1)[1:] / cnt
        sxx = np.bincount(lab, xs * xs, n + 1)[1:] / cnt - sx**2
        syy = np.bincount(lab, ys * ys, n + 1)[1:] / cnt - sy**2
        sxy = np.bincount(lab, xs * ys, n + 1)[1:] / cnt - sx * sy
    C = np.empty((n, 2, 2))
    C[:, 0, 0] = np.maximum(sxx, 0.0)
    C[:, 1, 1] = np.maximum(syy, 0.0)
    C[:, 0, 1] = C[:, 1, 0] = sxy
    return np.column_stack([sx, sy]), C, cnt


def xy_to_range_bearing(
    xy: np.ndarray, C_xy: np.ndarray, var_range: np.ndarray, var_bearing: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body (x, y) (n, 2) with covariance (n, 2, 2) -> range (n,), bearing (n,) and the
    covariance J C Jᵀ + diag(var_range, var_bearing) (first order; the cell terms are
    native polar variances)."""
    x, y = xy[:, 0], xy[:, 1]
    rho = np.hypot(x, y)
    if np.any(rho <= 0):
        raise ValueError("detection at the sonar origin (range 0): bearing undefined")
    J = np.zeros((len(x), 2, 2))
    J[:, 0, 0], J[:, 0, 1] = x / rho, y / rho
    J[:, 1, 0], J[:, 1, 1] = -y / rho**2, x / rho**2
    R = J @ C_xy @ np.swapaxes(J, -1, -2)
    R[:, 0, 0] += var_range
    R[:, 1, 1] += var_bearing
    return rho, np.arctan2(y, x), 0.5 * (R + np.swapaxes(R, -1, -2))


def footprint_gap_groups(xy: np.ndarray, M: np.ndarray, radius: float) -> np.ndarray:
    """Group index (n,) of regions joined by chains of footprint gaps <= radius (m).

    The gap between regions i and j is their centroid distance less each one's half
    extent along the line joining them, sqrt(3 dᵀ M d) (half the length of a uniform bar
    with that variance; M the (n, 2, 2) second moments): two fragments of one 20 m wreck
    have distant centroids but a small gap. Connected components with
    scipy.sparse.csgraph."""
    n = len(xy)
    if n <= 1 or radius <= 0:
        return np.arange(n)
    d = xy[None, :, :] - xy[:, None, :]
    dist = np.linalg.norm(d, axis=-1)
    u = d / np.maximum(dist, 1e-12)[..., None]
    half = np.sqrt(3.0 * np.maximum(np.einsum("ijk,ikl,ijl->ij", u, M, u), 0.0))
    gap = dist - half - half.T
    _, lab = connected_components(gap <= radius, directed=False)
    return lab


class PersistenceFilter:
    """k-of-n confirmation of detections at world positions, plus keyframing per track.

    :meth:`step` takes one frame's candidate world positions (m, 2) (placed with the
    navigation pose) and that pose [x, y, yaw]; returns (confirmed (m,) bool, emit (m,)
    bool). A candidate is confirmed when, counting this frame, at least k of the last n
    frames hold a candidate within ``radius`` of it. Confirmed candidates are matched to
    tracks (nearest within ``track_radius``); a new track, or vehicle motion of at least
    ``keyframe_distance`` m or ``keyframe_angle`` rad since the track's last emission,
    marks the candidate ``emit`` (one per track per frame)."""

    def __init__(
        self,
        k: int,
        n: int,
        radius: float,
        *,
        track_radius: float,
        keyframe_distance: float = 0.0,
        keyframe_angle: float = 0.0,
    ) -> None:
        if not 1 <= k <= n:
            raise ValueError(f"need 1 <= k <= n, got k={k}, n={n}")
        self.k, self.n, self.radius = int(k), int(n), float(radius)
        self.track_radius = float(track_radius)
        self.keyframe_distance = float(keyframe_distance)
        self.keyframe_angle = float(keyframe_angle)
        self._past: deque[np.ndarray] = deque(maxlen=max(self.n - 1, 0) or None)
        self.tracks = np.zeros((0, 2))  # latest world position per track
        self._emit_pose = np.zeros((0, 3))  # vehicle pose at each track's last emission

    def step(self, world_xy: np.ndarray, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = np.asarray(world_xy, float).reshape(-1, 2)
        pose = np.asarray(pose, float).reshape(3)
        m = len(w)
        hits = np.ones(m, int)
        for P in self._past if self.n > 1 else ():
            if len(P) and m:
                d = np.linalg.norm(w[:, None, :] - P[None, :, :], axis=-1).min(axis=1)
                hits += d <= self.radius
        if self.n > 1:
            self._past.append(w.copy())
        confirmed = hits >= self.k
        emit = np.zeros(m, bool)
        idx = np.flatnonzero(confirmed)
        if idx.size == 0:
            return confirmed, emit
        used = set()
        # a handful of confirmed objects per frame: a short loop over them, not pixels
        for i in idx[np.argsort(-hits[idx], kind="stable")]:
            if len(self.tracks):
                d = np.linalg.norm(self.tracks - w[i], axis=1)
                j = int(np.argmin(d))
                if d[j] > self.track_radius:
                    j = -1
            else:
                j = -1
            if j < 0:
                self.tracks = np.vstack([self.tracks, w[i]])
                self._emit_pose = np.vstack([self._emit_pose, pose])
                used.add(len(self.tracks) - 1)
                emit[i] = True
                continue
            self.tracks[j] = w[i]
            if j in used:
                continue
            used.add(j)
            moved = np.hypot(*(pose[:2] - self._emit_pose[j, :2]))
            turned = abs(float(wrap_angle(pose[2] - self._emit_pose[j, 2])))
            if moved >= self.keyframe_distance or (
                self.keyframe_angle > 0 and turned >= self.keyframe_angle
            ):
                self._emit_pose[j] = pose
                emit[i] = True
        return confirmed, emit
