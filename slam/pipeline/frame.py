"""What the sonar-to-SLAM pipeline takes in: one sonar acquisition as plain arrays.

A :class:`SonarFrame` comes from the simulator (sim.runner, the envs) or from a recording
(slam.io, ``.npy`` FLS frames) alike; nothing in it needs a simulator. Ground truth
(:class:`FrameTruth`) is optional: only scoring (slam.pipeline.scoring) reads it.

Image layouts (``float32``, linear intensity or the sonar's log-compressed display values
in [0, 1], as ``SonarGeometry.log_compressed`` says):

* ``"sss"``: one ping, ``(2S,)``: port far -> near, then starboard near -> far;
* ``"fls"``: one frame, ``(n_bins, n_beams)``: row 0 the nearest bin, column j at
  ``bearings[j]``;
* ``"msis"``: one ping, ``(n_bins,)``, at head angle ``bearings[k]`` for the k-th ping of
  a scan (a scan has ``len(bearings)`` pings).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: sonar kinds the pipeline knows (side-scan, forward-looking, mechanically scanned)
SONAR_KINDS = ("sss", "fls", "msis")


def _array(obj, name: str, value, dtype=float) -> np.ndarray:
    a = np.asarray(value, dtype=dtype)
    if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
        raise ValueError(f"{type(obj).__name__}.{name} has NaN or infinite values")
    object.__setattr__(obj, name, a)
    return a


@dataclass(frozen=True)
class SonarGeometry:
    """Geometry and display settings of one sonar head.

    kind: "sss" | "fls" | "msis". ranges: (n_bins,) m, slant range of the bin centres
    (side-scan: one side, near -> far). bearings: rad, counter-clockwise from the body x
    axis: the beams of an FLS (n_beams,) or the head angles of one MSIS scan; empty for a
    side-scan. mounting_xy: m, the transducer in the vehicle body frame (x forward, y
    port). bin_width: m (NaN: the median spacing of ``ranges``). angular_cell: rad, the
    angular resolution (max of beam width and beam / step spacing; FLS, MSIS).
    along_track_beamwidth_deg: side-scan horizontal beam width. log_compressed: the image
    holds display values in [0, 1] spanning ``dynamic_range_db``; else linear intensity.
    """

    kind: str
    ranges: np.ndarray
    bearings: np.ndarray = field(default_factory=lambda: np.zeros(0))
    mounting_xy: tuple[float, float] = (0.0, 0.0)
    bin_width: float = math.nan
    angular_cell: float = 0.0
    along_track_beamwidth_deg: float = 0.0
    log_compressed: bool = False
    dynamic_range_db: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in SONAR_KINDS:
            raise ValueError(
                f"SonarGeometry.kind = {self.kind!r}; allowed: {', '.join(SONAR_KINDS)}"
            )
        r = _array(self, "ranges", self.ranges)
        b = _array(self, "bearings", self.bearings)
        if r.ndim != 1 or r.size < 2 or np.any(np.diff(r) <= 0):
            raise ValueError(
                f"SonarGeometry.ranges must be >= 2 increasing values, got shape {r.shape}"
            )
        if self.kind != "sss" and (b.ndim != 1 or b.size < 1):
            raise ValueError(f"SonarGeometry.bearings: a {self.kind} needs >= 1 bearing")
        if not math.isfinite(self.bin_width):
            object.__setattr__(self, "bin_width", float(np.median(np.diff(r))))
        if self.bin_width <= 0:
            raise ValueError(f"SonarGeometry.bin_width = {self.bin_width!r}: must be > 0")
        if not (math.isfinite(self.angular_cell) and self.angular_cell >= 0):
            raise ValueError(f"SonarGeometry.angular_cell = {self.angular_cell!r}: must be >= 0")
        object.__setattr__(
            self, "mounting_xy", (float(self.mounting_xy[0]), float(self.mounting_xy[1]))
        )


@dataclass(frozen=True)
class FrameTruth:
    """The simulator's ground truth of one frame (scoring only, never needed to run).

    labels: int32, the image's shape: object id per sample (k >= 1 object k, 0 seabed,
    -1 no return). pose: (3,) true vehicle pose [x, y, yaw] (world m, rad) at the frame."""

    labels: np.ndarray
    pose: np.ndarray

    def __post_init__(self) -> None:
        _array(self, "labels", self.labels, np.int32)
        if _array(self, "pose", self.pose).shape != (3,):
            raise ValueError(f"FrameTruth.pose must have shape (3,), got {self.pose.shape}")


@dataclass(frozen=True)
class SonarFrame:
    """One acquisition of one sonar (layouts in the module docstring).

    sonar: the sonar's name (one pipeline serves several heads). image: float32.
    time: s. altitude: m above the seabed (NaN: unknown; a side-scan ping without it is
    skipped, FLS / MSIS then take slant range as horizontal). speed: m/s along track
    (side-scan pixel size; NaN: from the odometry). truth: optional ground truth.
    """

    sonar: str
    image: np.ndarray
    geometry: SonarGeometry
    time: float
    altitude: float = math.nan
    speed: float = math.nan
    truth: FrameTruth | None = None

    def __post_init__(self) -> None:
        img = np.asarray(self.image)
        if img.dtype != np.float32:
            raise ValueError(f"SonarFrame.image must be float32, got {img.dtype}")
        want = {"sss": 1, "fls": 2, "msis": 1}[self.geometry.kind]
        if img.ndim != want:
            raise ValueError(
                f"SonarFrame.image of a {self.geometry.kind} must be {want}-D, got shape {img.shape}"
            )
        if not math.isfinite(self.time):
            raise ValueError(f"SonarFrame.time = {self.time!r}: must be finite")
        if self.truth is not None and self.truth.labels.shape != img.shape:
            raise ValueError(
                f"SonarFrame.truth.labels shape {self.truth.labels.shape} != image {img.shape}"
            )
        object.__setattr__(self, "image", img)
