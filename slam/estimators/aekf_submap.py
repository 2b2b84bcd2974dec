"""Sub-mapping AEKF-SLAM for large areas (the thesis's named future work, §5.7).

A sequence of independent local AEKF-SLAM maps (Tardós, Neira, Newman and Leonard,
"Robust mapping and localization in indoor environments using sonar data", IJRR 2002;
Estrada, Neira and Tardós, "Hierarchical SLAM", IEEE T-RO 2005): each local map starts at
the vehicle's pose with zero covariance in its own frame; when it holds
``max_landmarks`` landmarks a new local map starts. The global level keeps the chain of
local-map origins ``o_{k+1} = o_k ⊕ x_v^{(k)}`` with first-order covariance. Every update
costs O(m²) in the local map size m, independent of the total map size.

What this mode does not do (stated, not hidden): it does not fuse landmarks across local
maps or close loops at the global level (a revisited area gets new local landmarks), and
global landmark covariances ignore the correlation between local maps through the chain.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from slam.estimators.aekf import AEKFConfig, AEKFSlam
from slam.estimators.base import UpdateResult
from slam.types import Odometry, RangeBearing

__all__ = ["SubmapAEKFSlam", "compose_pose"]


def compose_pose(a, Pa, b, Pb) -> tuple[np.ndarray, np.ndarray]:
    """``a ⊕ b`` for poses ``(3,)`` with independent covariances: first-order covariance
    ``J_a Pa J_aᵀ + J_b Pb J_bᵀ``."""
    c, s = math.cos(a[2]), math.sin(a[2])
    x = np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]])
    x[2] = (x[2] + math.pi) % (2 * math.pi) - math.pi
    Ja = np.array([[1.0, 0.0, -s * b[0] - c * b[1]], [0.0, 1.0, c * b[0] - s * b[1]], [0, 0, 1]])
    Jb = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return x, Ja @ Pa @ Ja.T + Jb @ Pb @ Jb.T


def _points_to_global(o, Po, pts, covs):
    """Local points ``(m, 2)`` with covariances ``(m, 2, 2)`` into the frame in which the
    local origin is ``o`` with covariance ``Po`` (vectorized over points)."""
    c, s = math.cos(o[2]), math.sin(o[2])
    Rm = np.array([[c, -s], [s, c]])
    g = pts @ Rm.T + o[:2]
    Jo = np.zeros((pts.shape[0], 2, 3))
    Jo[:, 0, 0] = 1.0
    Jo[:, 1, 1] = 1.0
    Jo[:, 0, 2] = -s * pts[:, 0] - c * pts[:, 1]
    Jo[:, 1, 2] = c * pts[:, 0] - s * pts[:, 1]
    C = Jo @ Po @ np.swapaxes(Jo, 1, 2) + Rm @ covs @ Rm.T
    return g, C


class SubmapAEKFSlam:
    """AEKF-SLAM in a sequence of local maps of at most ``max_landmarks`` landmarks.

    Parameters: ``max_landmarks`` (local map size, default 100), ``x0``/``P0`` the global
    start pose, everything else goes to :class:`AEKFConfig` of each local map.
    Implements :class:`slam.estimators.base.SlamEstimator` with global-frame outputs.
    """

    name = "aekf-submap"

    def __init__(
        self, max_landmarks: int = 100, *, x0=None, P0=None, rng=None, seed=None, **params
    ):
        del rng, seed  # deterministic; accepted for the common factory keywords
        if not (isinstance(max_landmarks, int | np.integer) and max_landmarks >= 1):
            raise ValueError(f"max_landmarks must be an integer >= 1, got {max_landmarks!r}")
        self.max_landmarks = int(max_landmarks)
        self.config = AEKFConfig(**params)
        start = AEKFSlam(self.config, x0=x0, P0=P0)  # validates x0, P0
        self.origin = np.zeros(3)
        self.P_origin = np.zeros((3, 3))
        self.local = start
        self.frozen: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self._offset = 0  # global index of the first landmark of the local map

    @property
    def n_submaps(self) -> int:
        return len(self.frozen) + 1

    def predict(self, odometry: Odometry) -> None:
        self.local.predict(odometry)

    def predict_arrays(self, u, Q) -> None:
        self.local.predict_arrays(u, Q)

    def update(self, observations: Sequence[RangeBearing]) -> UpdateResult:
        res = self.local.update(observations)
        return self._after_update(res)

    def update_arrays(self, z, R, labels=None) -> UpdateResult:
        return self._after_update(self.local.update_arrays(z, R, labels))

    def _after_update(self, res: UpdateResult) -> UpdateResult:
        assoc = np.where(res.associations >= 0, res.associations + self._offset, -1)
        if self.local.n_landmarks >= self.max_landmarks:
            self._new_submap()
        return UpdateResult(assoc, res.new, res.nis)

    def _new_submap(self) -> None:
        lm, cov = self.local.landmarks()
        self.frozen.append(
            (self.origin.copy(), self.P_origin.copy(), lm, cov, self.local.labels.copy())
        )
        xv, Pv = self.local.pose()
        self.origin, self.P_origin = compose_pose(self.origin, self.P_origin, xv, Pv)
        self._offset += lm.shape[0]
        self.local = AEKFSlam(self.config)

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        xv, Pv = self.local.pose()
        return compose_pose(self.origin, self.P_origin, xv, Pv)

    def landmarks(self) -> tuple[np.ndarray, np.ndarray]:
        parts = [(o, Po, lm, cov) for o, Po, lm, cov, _ in self.frozen]
        parts.append((self.origin, self.P_origin, *self.local.landmarks()))
        means, covs = [], []
        for o, Po, lm, cov in parts:  # one block per local map (few), vectorized inside
            if lm.shape[0]:
                g, C = _points_to_global(o, Po, lm, cov)
                means.append(g)
                covs.append(C)
        if not means:
            return np.empty((0, 2)), np.empty((0, 2, 2))
        return np.concatenate(means), np.concatenate(covs)

    @property
    def labels(self) -> np.ndarray:
        """Creating-observation label of each global landmark (-1 when unknown)."""
        return np.concatenate([f[4] for f in self.frozen] + [self.local.labels])
