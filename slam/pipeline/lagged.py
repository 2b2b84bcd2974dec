"""Honest timing for delayed sonar detections: a fixed-lag, time-ordered SLAM feeder.

A side-scan object is found in a waterfall window only after the vehicle has passed it;
the detection belongs to the pose at the ping where the object was seen. Choice made
here (documented in the README): **the SLAM filter runs behind real time**. Odometry
increments and observations are queued with their timestamps; the runner releases the
queue up to a *horizon*, the earliest ping time at which a detection may still appear
(the start of the waterfall region not yet segmented). Everything older is fed to the
estimator in time order: the odometry up to a ping time, then that ping's observations.
Each observation therefore updates the state exactly at the pose of its ping, with no
approximation and no double counting of odometry noise (unlike re-expressing a late
observation through the odometry already fused into the current pose, which correlates
the two). The price is latency: the filter's pose lags by one window; the current pose
is then the lagged estimate composed with the queued odometry (dead reckoning),
:meth:`LaggedSlam.current_pose`.

Consecutive odometry increments with no observation between them are composed into one
predict step (slam.estimators.aekf.compose_odometry: exact composition of the increments
and first-order propagation of their covariances, the same result a chain of predicts
gives, fewer calls). ``record_dt = 0`` predicts and records at every odometry cut.

The naive alternative (``timing = "naive"`` in a scenario) applies detections at the
time they are produced, as if seen from the current pose; kept for comparison.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from slam.estimators.aekf import compose_odometry
from slam.types import Odometry, RangeBearing, wrap_angle


def apply_increment(pose: np.ndarray, d: np.ndarray) -> np.ndarray:
    """World pose [x, y, phi] moved by a body-frame increment."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.array(
        [pose[0] + c * d[0] - s * d[1], pose[1] + s * d[0] + c * d[1], wrap_angle(pose[2] + d[2])]
    )


@dataclass(frozen=True)
class PoseRecord:
    """The filter's pose at one processed time: t s, x (3,), P (3, 3)."""

    t: float
    x: np.ndarray
    P: np.ndarray


class LaggedSlam:
    """Feeds one estimator in timestamp order up to a released horizon.

    on_update(t, observations, result) is called after each update (for logging/metrics).
    record_dt: s, the pose history gets a node at least this often (0: at every odometry
    cut, each increment its own predict).
    """

    def __init__(
        self, estimator, t0: float = 0.0, on_update: Callable | None = None, record_dt: float = 1.0
    ) -> None:
        self.estimator = estimator
        if not record_dt >= 0:
            raise ValueError(f"record_dt = {record_dt!r}: must be >= 0")
        self.record_dt = float(record_dt)
        self._next_record = float(t0) + self.record_dt
        self.t_done = float(t0)  # everything up to here has been fed
        self._odo: list[Odometry] = []  # contiguous increments after t_done, time ordered
        self._obs: list[tuple[float, int, list[RangeBearing]]] = []  # heap by time
        self._seq = 0
        self.on_update = on_update
        self.history: list[PoseRecord] = []
        self.n_predicts = 0
        self.n_updates = 0

    def add_odometry(self, odo: Odometry) -> None:
        """An increment ending at odo.t (must continue the previous one)."""
        last = self._odo[-1].t if self._odo else self.t_done
        if odo.t < last - 1e-9:
            raise ValueError(f"odometry out of order: t={odo.t} before {last}")
        self._odo.append(odo)

    def add_observations(self, t: float, observations: Sequence[RangeBearing]) -> None:
        """Observations made at time t (a ping time, which is an odometry cut time)."""
        if not observations:
            return
        if t < self.t_done - 1e-9:
            raise ValueError(
                f"observation at t={t} is older than the released horizon {self.t_done}"
            )
        heapq.heappush(self._obs, (float(t), self._seq, list(observations)))
        self._seq += 1

    def _predict_until(self, t: float) -> None:
        d = np.zeros(3)
        C = np.zeros((3, 3))
        n = 0
        while self._odo and self._odo[0].t <= t + 1e-9:
            o = self._odo.pop(0)
            d, C = compose_odometry(d, C, o.delta, o.cov)
            n += 1
            self.t_done = o.t
            if self.t_done >= self._next_record - 1e-9 and (
                self._odo and self._odo[0].t <= t + 1e-9
            ):
                # a history node on the record grid (predict so far, record, go on)
                self.estimator.predict(Odometry(d, C, self.t_done))
                self.n_predicts += 1
                self._record()
                d, C, n = np.zeros(3), np.zeros((3, 3)), 0
        if n:
            self.estimator.predict(Odometry(d, C, self.t_done))
            self.n_predicts += 1

    def release(self, horizon: float) -> None:
        """Feed everything with timestamps <= horizon, in time order."""
        while self._obs and self._obs[0][0] <= horizon + 1e-9:
            t, _, obs = heapq.heappop(self._obs)
            self._predict_until(t)
            res = self.estimator.update(obs)
            self.n_updates += 1
            self._record()
            if self.on_update is not None:
                self.on_update(t, obs, res)
        before = self.t_done
        self._predict_until(horizon)
        if self.t_done > before:
            self._record()

    def _record(self) -> None:
        if self.record_dt > 0:
            while self._next_record <= self.t_done + 1e-9:
                self._next_record += self.record_dt
        else:
            self._next_record = self.t_done
        x, P = self.estimator.pose()
        self.history.append(PoseRecord(self.t_done, np.array(x, float), np.array(P, float)))

    def current_pose(self) -> tuple[float, np.ndarray]:
        """(t, pose) now: the lagged estimate dead-reckoned through the queued odometry."""
        x, _ = self.estimator.pose()
        pose = np.array(x, float)
        t = self.t_done
        for o in self._odo:
            pose = apply_increment(pose, o.delta)
            t = o.t
        return t, pose

    @property
    def pending(self) -> int:
        return len(self._odo) + len(self._obs)
