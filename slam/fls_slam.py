"""Front end + SLAM on a recorded forward-looking sonar: real data, no simulator.

A recording is a ``.npy`` array of polar frames ``(frames, n_bins, n_beams)`` (row 0 the
nearest bin, column j at ``bearings[j]``) with a JSON sidecar of the same stem
(``frames.npy`` + ``frames.json``, format in docs/pipeline.md): the geometry (bin
ranges, beam bearings, beam width, mounting), the display scale, per-frame time,
altitude and navigation (x, y, heading_deg as for side-scan XTF). The frames go through
the scenario runner's pipeline (slam.pipeline.SonarSlam: the FLS / MSIS polar front end
of slam.frontend.polar, the fixed-lag feeder, the estimator), with odometry between
consecutive frames from the navigation (slam.sidescan_slam.odometry_between) and the
error the user states.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from slam.frontend.polar import PolarDetection
from slam.pipeline import (
    EstimatorSpec,
    PipelineConfig,
    SonarFrame,
    SonarGeometry,
    SonarSlam,
    build_estimator,
    make_frontend,
)
from slam.pipeline.replay import recording_events, replay
from slam.sidescan_slam import local_poses_from_nav, odometry_between


@dataclass(frozen=True)
class FlsRecording:
    """Polar frames (N, n_bins, n_beams) float32, their geometry, times (N,) s,
    altitudes (N,) m (NaN: unknown) and navigation {x, y, heading_deg} (N,) each."""

    frames: np.ndarray
    geometry: SonarGeometry
    time_s: np.ndarray
    altitude_m: np.ndarray
    nav: dict


def _field(d: dict, key: str, path: Path):
    if key not in d:
        raise ValueError(f"{path}: sidecar field {key!r} missing")
    return d[key]


def load_fls_recording(npy_path: str | Path) -> FlsRecording:
    """Read ``X.npy`` and its sidecar ``X.json``; errors name the file and the field."""
    p = Path(npy_path)
    side = p.with_suffix(".json")
    if not p.is_file():
        raise FileNotFoundError(f"{p}: no such file")
    if not side.is_file():
        raise FileNotFoundError(f"{side}: the JSON geometry sidecar of {p.name} is missing")
    frames = np.load(p, allow_pickle=False)
    if frames.ndim != 3 or frames.shape[0] < 2:
        raise ValueError(f"{p}: expected (frames >= 2, n_bins, n_beams), got shape {frames.shape}")
    try:
        meta = json.loads(side.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{side}: invalid JSON: {exc}") from exc
    n, n_bins, n_beams = frames.shape
    ranges = np.asarray(_field(meta, "ranges_m", side), float)
    bearings = np.radians(np.asarray(_field(meta, "bearings_deg", side), float))
    if ranges.shape != (n_bins,) or bearings.shape != (n_beams,):
        raise ValueError(
            f"{side}: ranges_m has {ranges.size} and bearings_deg {bearings.size} values; "
            f"the frames have {n_bins} bins and {n_beams} beams"
        )
    spacing = float(np.median(np.abs(np.diff(bearings)))) if n_beams > 1 else 0.0
    beamwidth = math.radians(float(meta.get("beamwidth_deg", 0.0)))
    geom = SonarGeometry(
        "fls",
        ranges,
        bearings,
        mounting_xy=tuple(meta.get("mounting_xy_m", (0.0, 0.0))),
        angular_cell=max(beamwidth, spacing),
        log_compressed=bool(meta.get("log_compressed", False)),
        dynamic_range_db=float(meta.get("dynamic_range_db", 0.0)),
    )
    t = np.asarray(_field(meta, "time_s", side), float)
    alt = meta.get("altitude_m")
    alt = np.full(n, np.nan) if alt is None else np.broadcast_to(np.asarray(alt, float), (n,))
    nav = {k: np.asarray(v, float) for k, v in _field(meta, "nav", side).items()}
    for k, v in {"time_s": t, **{f"nav.{k}": v for k, v in nav.items()}}.items():
        if v.shape != (n,):
            raise ValueError(f"{side}: {k} has shape {v.shape}; expected ({n},), one per frame")
    return FlsRecording(frames.astype(np.float32, copy=False), geom, t, np.array(alt), nav)


@dataclass(frozen=True)
class FlsSlamConfig:
    """Settings of :func:`run_fls_slam`: the pipeline's, the estimator, the navigation's
    position units and the odometry error (as :class:`slam.sidescan_slam.SidescanSlamConfig`)."""

    pipeline: PipelineConfig = field(default_factory=PipelineConfig)
    estimator: EstimatorSpec = field(default_factory=EstimatorSpec)
    nav_units: str = "auto"
    odometry_sigma_frac: float = 0.02
    heading_sigma_deg_per_sqrt_s: float = 0.2


@dataclass(frozen=True)
class FlsSlamResult:
    """Poses (N, 3) [x east m, y north m, yaw rad] in the local frame of the first frame;
    the confirmed detections; the landmarks (K, 2) and their covariances."""

    nav_poses: np.ndarray
    est_poses: np.ndarray
    detections: list[PolarDetection]
    n_observations: int
    landmarks: np.ndarray
    landmark_cov: np.ndarray
    timing_s: dict

    def summary(self) -> dict:
        """JSON-friendly summary."""
        return {
            "frames": len(self.nav_poses),
            "detections": [
                {
                    "t_s": d.observation.t,
                    "range_m": float(d.observation.z[0]),
                    "bearing_deg": math.degrees(float(d.observation.z[1])),
                    "world_xy_nav_m": [float(v) for v in d.world_xy_nav],
                }
                for d in self.detections
            ],
            "observations": self.n_observations,
            "landmarks_m": self.landmarks.tolist(),
            "final_pose_nav": self.nav_poses[-1].tolist(),
            "final_pose_est": self.est_poses[-1].tolist(),
            "timing_s": self.timing_s,
        }


def run_fls_slam(rec: FlsRecording, config: FlsSlamConfig | None = None) -> FlsSlamResult:
    """The pipeline over a recorded FLS sequence (module docstring)."""
    cfg = config or FlsSlamConfig()
    t0 = time.perf_counter()
    poses, valid, _ = local_poses_from_nav(rec.nav, cfg.nav_units)
    if not valid.all():
        raise ValueError(f"frames {np.flatnonzero(~valid).tolist()} carry no navigation")
    if np.any(np.diff(rec.time_s) <= 0):
        raise ValueError("time_s must increase from frame to frame")
    frames = [
        SonarFrame("fls", img, rec.geometry, float(t), altitude=float(a))
        for img, t, a in zip(rec.frames, rec.time_s, rec.altitude_m)
    ]
    sig_h = math.radians(cfg.heading_sigma_deg_per_sqrt_s)
    odometry = [
        odometry_between(
            poses[i - 1],
            poses[i],
            float(rec.time_s[i] - rec.time_s[i - 1]),
            cfg.odometry_sigma_frac,
            sig_h,
            t=float(rec.time_s[i]),
        )
        for i in range(1, len(frames))
    ]
    pipe = cfg.pipeline
    est = build_estimator(cfg.estimator, poses[0], pipe)
    slam = SonarSlam(
        {"fls": make_frontend(rec.geometry, pipe)},
        est,
        pipe,
        t0=float(rec.time_s[0]),
        pose0=poses[0],
        record_dt=0.0,
    )
    outs, _ = replay(slam, recording_events(frames, odometry))
    hist = slam.lagged.history
    ht = np.array([r.t for r in hist])
    at = np.searchsorted(ht, rec.time_s, side="right") - 1
    est_poses = np.array([hist[j].x[:3] if j >= 0 else poses[0] for j in at])
    lm, lm_cov = est.landmarks()
    return FlsSlamResult(
        nav_poses=poses,
        est_poses=est_poses,
        detections=[d for o in outs for d in o.detections],
        n_observations=sum(len(o.observations) for o in outs),
        landmarks=np.asarray(lm).reshape(-1, 2),
        landmark_cov=np.asarray(lm_cov).reshape(-1, 2, 2),
        timing_s={"total": time.perf_counter() - t0},
    )
