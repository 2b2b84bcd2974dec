"""SonarSlam: the one path from sonar frames and odometry to SLAM updates.

The scenario runner, the gym envs, the dataset exporter's checks and ``undersea
sss-slam`` on recordings all feed this class, so the same frames and odometry give the
same detections and updates everywhere:

* :meth:`SonarSlam.add_odometry` queues a body-frame increment (and dead-reckons the
  navigation pose the FLS / MSIS persistence filter places candidates with);
* :meth:`SonarSlam.add_frame` runs the sonar's front end (side-scan waterfall windows,
  slam.frontend.sidescan_windows; FLS frames and MSIS scans, slam.frontend.polar) and
  queues the resulting observations at the time of their ping;
* :meth:`SonarSlam.release` feeds the estimator, in time order, everything up to the
  earliest time a detection may still appear (slam.pipeline.lagged): a side-scan window
  not yet segmented, an MSIS scan not yet complete. FLS never holds SLAM back.

Ground truth in the frames is carried along to the front end's scoring fields but never
used to run; scoring against labels is slam.pipeline.scoring.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from slam.frontend.polar import PolarFrontend, PolarResult
from slam.frontend.sidescan_records import Detection, PingRecord, WindowResult
from slam.frontend.sidescan_windows import SidescanProcessor
from slam.pipeline.config import Frontend, PipelineConfig
from slam.pipeline.frame import SonarFrame
from slam.pipeline.lagged import LaggedSlam, apply_increment
from slam.types import Odometry, RangeBearing


@dataclass(frozen=True)
class Update:
    """One estimator update: time s, the observations, the estimator's UpdateResult."""

    t: float
    observations: list[RangeBearing]
    result: object


@dataclass(frozen=True)
class FrameOutput:
    """What one :meth:`SonarSlam.add_frame` (or :meth:`SonarSlam.flush`) produced.

    kind / sonar of the frame; window: a processed side-scan window; polar: a processed
    FLS frame or MSIS scan, with ``frames`` the frames it covers (MSIS: one per ping);
    observations: what was queued for SLAM. Empty outputs (a ping that completed nothing)
    have neither window nor polar."""

    sonar: str
    kind: str
    window: WindowResult | None = None
    polar: PolarResult | None = None
    frames: tuple[SonarFrame, ...] = ()
    observations: list[RangeBearing] = field(default_factory=list)

    @property
    def detections(self) -> list:
        """Side-scan detections of the window, or the polar front end's confirmed ones."""
        if self.window is not None:
            return list(self.window.detections)
        if self.polar is not None:
            return [d for d in self.polar.detections if d.confirmed]
        return []


class SonarSlam:
    """Front ends per sonar + a fixed-lag feeder around one estimator.

    frontends: sonar name -> SidescanProcessor | PolarFrontend | None (None: the sonar
    runs without a front end but still holds SLAM back as its kind does); their kinds
    come from the first frame of each. estimator: a slam.estimators estimator, or None
    (front end only). pose0: [x, y, yaw] start of the dead-reckoned navigation pose
    (default: the estimator's pose). record_dt: s between pose-history nodes.
    """

    def __init__(
        self,
        frontends: Mapping[str, Frontend | None],
        estimator,
        config: PipelineConfig,
        *,
        t0: float = 0.0,
        pose0=None,
        record_dt: float = 1.0,
    ) -> None:
        self.frontends = dict(frontends)
        self.config = config
        self.lagged = (
            LaggedSlam(estimator, t0=t0, on_update=self._on_update, record_dt=record_dt)
            if estimator is not None
            else None
        )
        if pose0 is None:
            if estimator is None:
                raise ValueError("SonarSlam without an estimator needs pose0")
            pose0 = estimator.pose()[0][:3]
        self.dr_t: list[float] = [float(t0)]
        self.dr_pose: list[np.ndarray] = [np.array(pose0, float).reshape(3)]
        self.t_now = float(t0)
        self.counts: dict[str, int] = defaultdict(int)
        self._horizon: dict[str, float] = {n: -math.inf for n in self.frontends}
        self._msis: dict[str, list[tuple[SonarFrame, np.ndarray]]] = defaultdict(list)
        self._kind: dict[str, str] = {}
        self._updates: list[Update] = []

    # -- input ----------------------------------------------------------------------
    @property
    def estimator(self):
        return self.lagged.estimator if self.lagged is not None else None

    def nav_pose(self) -> np.ndarray:
        """The dead-reckoned navigation pose [x, y, yaw] now (no SLAM correction)."""
        return self.dr_pose[-1]

    def add_odometry(self, odo: Odometry) -> None:
        """An increment ending at ``odo.t`` (continuing the previous one)."""
        if self.lagged is not None:
            self.lagged.add_odometry(odo)
        self.dr_t.append(float(odo.t))
        self.dr_pose.append(apply_increment(self.dr_pose[-1], odo.delta))
        self.t_now = max(self.t_now, float(odo.t))

    def add_frame(self, frame: SonarFrame) -> FrameOutput:
        """Run the frame's front end and queue its observations; see :class:`FrameOutput`."""
        kind = frame.geometry.kind
        if frame.sonar not in self.frontends:
            raise ValueError(
                f"SonarFrame.sonar = {frame.sonar!r}: no such sonar; known: {', '.join(self.frontends)}"
            )
        self._kind[frame.sonar] = kind
        if kind == "fls":
            self._horizon[frame.sonar] = math.inf
            return self._fls(frame)
        if kind == "msis":
            return self._msis_ping(frame)
        return self._sss(frame)

    def _sss(self, frame: SonarFrame) -> FrameOutput:
        proc = self.frontends[frame.sonar]
        out = FrameOutput(frame.sonar, "sss")
        if proc is None or not math.isfinite(frame.altitude):
            return out
        assert isinstance(proc, SidescanProcessor)
        speed = frame.speed if math.isfinite(frame.speed) else self._odometry_speed()
        truth = frame.truth
        rec = PingRecord(
            frame.time,
            frame.image,
            frame.geometry.ranges,
            float(frame.altitude),
            max(speed, self.config.min_speed_mps),
            labels=truth.labels if truth is not None else None,
            pose_true=truth.pose if truth is not None else None,
            pose_nav=self.nav_pose(),
        )
        res = proc.add(rec)
        return self._window(frame.sonar, res) if res is not None else out

    def _window(self, sonar: str, res: WindowResult) -> FrameOutput:
        self._horizon[sonar] = res.horizon_t
        by_t: dict[float, list] = defaultdict(list)
        for d in res.detections:
            by_t[d.t].append(d.observation)
        obs = []
        for t, ob in sorted(by_t.items()):
            if self.config.timing == "naive" and self.lagged is not None:
                t = max(self.lagged.t_done, self.t_now)  # as if seen now, from here
            obs += self._queue(t, ob)
        return FrameOutput(sonar, "sss", window=res, observations=obs)

    def _fls(self, frame: SonarFrame) -> FrameOutput:
        fe = self.frontends[frame.sonar]
        if fe is None:
            return FrameOutput(frame.sonar, "fls")
        assert isinstance(fe, PolarFrontend)
        res = fe.process(
            frame.image,
            altitude=frame.altitude if math.isfinite(frame.altitude) else None,
            poses_nav=self.nav_pose(),
            times=frame.time,
        )
        return self._polar(frame.sonar, "fls", res, (frame,))

    def _msis_ping(self, frame: SonarFrame) -> FrameOutput:
        buf = self._msis[frame.sonar]
        if not buf:  # a new scan starts: everything before it is final
            self._horizon[frame.sonar] = frame.time - 1e-9
        buf.append((frame, self.nav_pose().copy()))
        if len(buf) < len(frame.geometry.bearings):
            return FrameOutput(frame.sonar, "msis")
        frames = tuple(f for f, _ in buf)
        poses = np.array([p for _, p in buf])
        self._msis[frame.sonar] = []
        self._horizon[frame.sonar] = frame.time
        fe = self.frontends[frame.sonar]
        if fe is None:
            return FrameOutput(frame.sonar, "msis", frames=frames)
        assert isinstance(fe, PolarFrontend)
        res = fe.process(
            np.stack([f.image for f in frames]),
            altitude=frame.altitude if math.isfinite(frame.altitude) else None,
            poses_nav=poses,
            times=np.array([f.time for f in frames]),
        )
        return self._polar(frame.sonar, "msis", res, frames)

    def _polar(self, sonar: str, kind: str, res: PolarResult, frames) -> FrameOutput:
        c = self.counts
        c[f"{kind}_regions"] += res.n_regions
        c[f"{kind}_candidates"] += res.n_candidates
        conf = [d for d in res.detections if d.confirmed]
        c[f"{kind}_confirmed"] += len(conf)
        obs = []
        if conf:
            emitted = [d.observation for d in conf if d.emitted]
            c[f"{kind}_observations"] += len(emitted)
            by_t: dict[float, list] = defaultdict(list)
            for o in emitted:
                by_t[o.t].append(o)
            for t, ob in sorted(by_t.items()):
                obs += self._queue(t, ob)
        return FrameOutput(sonar, kind, polar=res, frames=tuple(frames), observations=obs)

    def _queue(self, t: float, obs: list) -> list:
        """Queue observations at their time; one older than the released horizon (cannot
        happen with ping ownership, kept as a guard) is counted and dropped."""
        if self.lagged is None:
            return []
        if t < self.lagged.t_done - 1e-9:
            self.counts["dropped_late"] += len(obs)
            return []
        self.lagged.add_observations(t, obs)
        return list(obs)

    def _odometry_speed(self) -> float:
        """m/s over the last odometry increment (0 before two nodes)."""
        if len(self.dr_t) < 2 or self.dr_t[-1] <= self.dr_t[-2]:
            return 0.0
        d = np.hypot(*(self.dr_pose[-1][:2] - self.dr_pose[-2][:2]))
        return float(d / (self.dr_t[-1] - self.dr_t[-2]))

    # -- output ---------------------------------------------------------------------
    def flush(self) -> list[FrameOutput]:
        """End of input: segment what is left of every side-scan waterfall; nothing holds
        SLAM back any more (an incomplete MSIS scan is dropped)."""
        outs = []
        for name, fe in self.frontends.items():
            if isinstance(fe, SidescanProcessor):
                res = fe.flush()
                if res is not None:
                    outs.append(self._window(name, res))
            if fe is not None:
                self._horizon[name] = math.inf
        return outs

    def horizon(self, t: float) -> float:
        """The earliest time a detection may still appear, capped at ``t``."""
        return min([*self._horizon.values(), t])

    def release(self, t: float, *, final: bool = False) -> list[Update]:
        """Feed the estimator up to :meth:`horizon` (``final``: up to ``t`` whatever is
        pending); returns the updates made."""
        self._updates = []
        if self.lagged is not None:
            h = t if final else self.horizon(t)
            if final or h > self.lagged.t_done:
                self.lagged.release(h)
        return self._updates

    def _on_update(self, t: float, obs, result) -> None:
        self._updates.append(Update(t, list(obs), result))

    def current_pose(self) -> tuple[float, np.ndarray]:
        """(t, pose): the lagged estimate dead-reckoned through the queued odometry."""
        if self.lagged is None:
            return self.dr_t[-1], self.nav_pose()
        return self.lagged.current_pose()


__all__ = ["Detection", "FrameOutput", "SonarSlam", "Update"]
