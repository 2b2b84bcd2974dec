"""The fleet's maps as data: a vehicle's map handed over for fusion (:class:`VehicleMap`,
from an estimator by :func:`vehicle_map_from`), a surface GPS fix (:class:`GpsFix`), the
fusion's settings (:class:`FleetFusionConfig`) and its result (:class:`FusedMap`). Poses
``[x m, y m, φ rad]``; frames as in :mod:`slam.fleet.fusion`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from slam.estimators.aekf import AEKFSlam

__all__ = [
    "FleetFusionConfig",
    "FusedMap",
    "GpsFix",
    "VehicleMap",
    "to_world",
    "vehicle_map_from",
]


def _check_cov(name: str, C: np.ndarray, n: int) -> np.ndarray:
    C = np.asarray(C, dtype=float)
    if C.shape != (n, n):
        raise ValueError(f"{name} must have shape ({n}, {n}), got {C.shape}")
    if not np.all(np.isfinite(C)):
        raise ValueError(f"{name} must be finite (got nan or inf)")
    if np.abs(C - C.T).max() > 1e-9 * max(1.0, float(np.abs(C).max())):
        raise ValueError(f"{name} must be symmetric")
    if n and np.linalg.eigvalsh(0.5 * (C + C.T)).min() < -1e-9 * max(1.0, float(np.abs(C).max())):
        raise ValueError(f"{name} must be positive semi-definite")
    return 0.5 * (C + C.T)


@dataclass(frozen=True)
class VehicleMap:
    """One vehicle's map. ``x (3 + 2m,)`` ``[x_v m, y_v m, φ_v rad, x_1, y_1, ...]`` in the
    map frame, ``P`` its covariance; ``frame (3,)`` the map frame's pose in the world frame
    (default the world frame itself), ``frame_cov (3, 3)`` its prior covariance or None
    (known: the map's covariance already holds the start uncertainty)."""

    x: np.ndarray
    P: np.ndarray
    name: str = ""
    frame: np.ndarray = field(default=None)  # type: ignore[assignment]
    frame_cov: np.ndarray | None = None

    def __post_init__(self) -> None:
        x = np.asarray(self.x, dtype=float).reshape(-1)
        who = f"VehicleMap {self.name!r}" if self.name else "VehicleMap"
        if x.size < 3 or (x.size - 3) % 2:
            raise ValueError(f"{who}.x must have shape (3 + 2m,), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{who}.x must be finite (got nan or inf)")
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "P", _check_cov(f"{who}.P", self.P, x.size))
        f = np.zeros(3) if self.frame is None else np.asarray(self.frame, float).reshape(-1)
        if f.shape != (3,) or not np.all(np.isfinite(f)):
            raise ValueError(f"{who}.frame must be finite [x, y, phi], got {self.frame!r}")
        object.__setattr__(self, "frame", f)
        if self.frame_cov is not None:
            C = _check_cov(f"{who}.frame_cov", self.frame_cov, 3)
            if np.linalg.eigvalsh(C).min() <= 0.0:
                raise ValueError(f"{who}.frame_cov must be positive definite (or None: known)")
            object.__setattr__(self, "frame_cov", C)

    @property
    def n_landmarks(self) -> int:
        return (self.x.size - 3) // 2


@dataclass(frozen=True)
class GpsFix:
    """A GPS fix of vehicle ``vehicle`` (index into the maps) at its map's pose:
    ``xy (2,)`` world m, ``cov (2, 2)`` m²."""

    vehicle: int
    xy: np.ndarray
    cov: np.ndarray

    def __post_init__(self) -> None:
        xy = np.asarray(self.xy, float).reshape(-1)
        if xy.shape != (2,) or not np.all(np.isfinite(xy)):
            raise ValueError(f"GpsFix.xy must be finite (2,), got {self.xy!r}")
        C = _check_cov("GpsFix.cov", self.cov, 2)
        if np.linalg.eigvalsh(C).min() <= 0.0:
            raise ValueError("GpsFix.cov must be positive definite")
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "cov", C)


@dataclass(frozen=True)
class FleetFusionConfig:
    """``confidence``: χ² quantile of the joint-compatibility test between maps;
    ``cross_correlation``: ``"independent"`` (the maps' errors are independent: the exact
    MAP) or ``"unknown"`` (covariance intersection, Julier and Uhlmann 1997: each map's
    information scaled by a weight, the weights summing to 1 and chosen to minimize the
    trace of the covariance of the fused positions (landmarks and vehicles); consistent
    whatever the maps' errors share, at the price of larger covariances); ``max_nodes``:
    JCBB search budget; ``iterations``/``tolerance``: Gauss–Newton (stop when the largest
    step is below ``tolerance``, m or rad); ``jitter``: relative diagonal added
    to each map covariance before whitening (a filter's P can be singular to rounding)."""

    confidence: float = 0.99
    cross_correlation: str = "independent"
    max_nodes: int = 20000
    iterations: int = 50
    tolerance: float = 1e-10
    jitter: float = 1e-10

    def __post_init__(self) -> None:
        if self.cross_correlation not in ("independent", "unknown"):
            raise ValueError(
                "cross_correlation must be 'independent' or 'unknown', "
                f"got {self.cross_correlation!r}"
            )
        if not 0.0 < self.confidence < 1.0:
            raise ValueError(f"confidence must be in (0, 1), got {self.confidence!r}")
        if not (isinstance(self.iterations, int) and self.iterations >= 1):
            raise ValueError(f"iterations must be an integer >= 1, got {self.iterations!r}")
        for n in ("tolerance", "jitter"):
            if not (math.isfinite(getattr(self, n)) and getattr(self, n) >= 0.0):
                raise ValueError(f"{n} must be a finite number >= 0, got {getattr(self, n)!r}")


@dataclass(frozen=True)
class FusedMap:
    """The fleet's map, world frame. ``landmarks (M, 2)`` m and marginal covariances
    ``(M, 2, 2)``; ``frames (K, 3)``/``frame_cov`` the map frames (known ones with zero
    covariance); ``poses (K, 3)``/``pose_cov`` each vehicle's pose at hand-over;
    ``assignment[k] (m_k,)`` the fused landmark of each landmark of map k; ``theta``/``cov``
    the full solution; ``n_paired`` landmarks fused across maps, ``n_ambiguous`` left
    apart as ambiguous; ``chi2``/``dof`` the weighted residual (≈ dof if maps are consistent)."""

    landmarks: np.ndarray
    landmark_cov: np.ndarray
    frames: np.ndarray
    frame_cov: np.ndarray
    poses: np.ndarray
    pose_cov: np.ndarray
    assignment: tuple[np.ndarray, ...]
    theta: np.ndarray
    cov: np.ndarray
    n_paired: int
    n_ambiguous: int
    chi2: float
    dof: int

    @property
    def n_landmarks(self) -> int:
        return len(self.landmarks)


def to_world(T, p) -> np.ndarray:
    """World points ``T ⊕ p`` for local points ``p (n, 2)``."""
    c, s = math.cos(T[2]), math.sin(T[2])
    return p @ np.array([[c, s], [-s, c]]) + T[:2]


def vehicle_map_from(estimator, name: str = "") -> tuple[VehicleMap, bool]:
    """A vehicle's map in the world frame from its estimator, and whether its covariance is
    the joint one: the AEKF's full ``(x, P)``, the sub-map AEKF's joined global map; for
    other estimators (FastSLAM, iSAM2, robocentric) the pose and landmark marginals
    side by side, their cross-correlations unknown (``False``: an approximation)."""
    if callable(getattr(estimator, "join", None)):
        gm = estimator.join()
        return VehicleMap(gm.x, 0.5 * (gm.P + gm.P.T), name), True
    if isinstance(estimator, AEKFSlam):
        x, P = estimator.state()
        return VehicleMap(x, 0.5 * (P + P.T), name), True
    xv, Pv = estimator.pose()
    means, covs = estimator.landmarks()
    m = len(means)
    P = np.zeros((3 + 2 * m, 3 + 2 * m))
    P[:3, :3] = Pv
    for i in range(m):  # block diagonal (few landmarks)
        P[3 + 2 * i : 5 + 2 * i, 3 + 2 * i : 5 + 2 * i] = covs[i]
    x = np.r_[np.asarray(xv, float)[:3], np.asarray(means, float).reshape(-1)]
    return VehicleMap(x, 0.5 * (P + P.T), name), False
