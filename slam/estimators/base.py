"""The small interface every SLAM estimator implements, so experiments swap them.

An estimator is stepped with odometry increments and batches of range-bearing
observations; it reports the vehicle pose and landmark map with covariances.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from slam.types import Odometry, RangeBearing


@dataclass(frozen=True)
class UpdateResult:
    """What one ``update`` did with its observations.

    associations : (k,) int, per input observation: index of the landmark it updated or
                   created, or -1 when rejected (ambiguous, between the gates).
    new          : (k,) bool, True where the observation created a new landmark.
    nis          : (k,) float, normalized innovation squared of each associated
                   observation (nan for new or rejected ones).
    """

    associations: np.ndarray
    new: np.ndarray
    nis: np.ndarray


@runtime_checkable
class SlamEstimator(Protocol):
    name: str

    def predict(self, odometry: Odometry) -> None:
        """Propagate the vehicle pose by one odometry increment."""

    def update(self, observations: Sequence[RangeBearing]) -> UpdateResult:
        """Associate, update with known landmarks and augment new ones."""

    def pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Vehicle pose estimate ``(x (3,), P (3, 3))``: ``[x m, y m, phi rad]``."""

    def landmarks(self) -> tuple[np.ndarray, np.ndarray]:
        """Landmark estimates ``(means (n, 2) m, covariances (n, 2, 2) m²)``."""
