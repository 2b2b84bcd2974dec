"""Side-scan records the windowing keeps and emits: pings in, detections and windows out.

slam.frontend.sidescan_windows turns :class:`PingRecord` s into :class:`WindowResult` s
holding :class:`Detection` s; slam.pipeline consumes and scores them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from slam.types import RangeBearing


@dataclass(frozen=True)
class PingRecord:
    """One side-scan ping as the windowing keeps it.

    t: acquisition time, s. intensity (2S,) float32, port left (far range first).
    slant_range (S,) m of the starboard half's samples (near to far; port mirrored).
    altitude: measured altitude (DVL or first return), m. speed: along-track speed
    estimate, m/s (for the along-track pixel size).
    Ground truth, optional (scoring only; a recording has none): labels (2S,) int32
    object id per sample (0 seabed, -1 no return, k >= 1 object k); pose_true (3,)
    [x, y, yaw]. Without them detections carry object id 0, are not true positives and
    are placed with ``pose_nav`` (the navigation pose, when given).
    """

    t: float
    intensity: np.ndarray
    slant_range: np.ndarray
    altitude: float
    speed: float = 1.5
    labels: np.ndarray | None = None
    pose_true: np.ndarray | None = None
    pose_nav: np.ndarray | None = None


@dataclass(frozen=True)
class Detection:
    """One side-scan detection tied to the ping of its centroid."""

    t: float
    ping: int
    side: str  # "port" | "starboard"
    slant_range: float
    ground_range: float
    area_px: int
    observation: RangeBearing
    object_id: int  # majority simulator label of the region (0 = none) - scoring only
    true_positive: bool
    world_xy_true_pose: np.ndarray  # placed with the true pose (else the nav pose, else NaN)


@dataclass
class WindowResult:
    """One segmented window: its image, class-id overlay and detections owned here."""

    start: int
    image: np.ndarray
    overlay: np.ndarray
    detections: list[Detection]
    horizon_t: float  # every ping at or before this time is final (no later detections)
    fp_pixels: int = 0
    bg_pixels: int = 0
    imaged_ids: set = field(default_factory=set)


def placing_pose(p: PingRecord) -> np.ndarray:
    """The pose a detection is placed with: true (scoring), else navigation, else NaN."""
    if p.pose_true is not None:
        return np.asarray(p.pose_true, float)
    if p.pose_nav is not None:
        return np.asarray(p.pose_nav, float)
    return np.full(3, np.nan)
