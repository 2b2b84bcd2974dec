"""Front end + SLAM on a recorded side-scan waterfall: real data, no simulator.

The same pipeline the scenario runner uses on simulated pings (slam.pipeline.SonarSlam,
with the :data:`~slam.pipeline.REAL_SIDESCAN` settings), fed from a file
(:func:`slam.io.xtf.read_xtf` or any :class:`slam.io.waterfall.Waterfall`):

1. navigation → local poses: XTF positions in degrees (lon, lat) are projected
   equirectangularly about the first fix (metres east/north; errors < 1 mm over a few km);
   positions already in metres are used as they are. Compass heading (deg clockwise from
   north) becomes yaw (rad counter-clockwise from east). Pings without navigation
   (x = y = 0, as ping 0 of many files) are dropped.
2. odometry between consecutive pings from those poses, with a covariance the user states
   (``odometry_sigma_frac`` of the distance travelled, along and across track;
   ``heading_sigma_deg_per_sqrt_s`` heading random walk) — a recording's navigation is
   itself an estimate, so this is the dead-reckoning error SLAM is asked to correct.
3. altitude per ping: the first seabed return (the sonar's own measurement over a flat
   seabed: the bottom track, :func:`slam.frontend.bottom_track.track_bottom`, gaps
   interpolated) or the file's ``altitude_m``. It sets the water-column mask, the
   first-return edge and the slant-to-ground-range correction of every detection.
4. each ping becomes a :class:`slam.pipeline.SonarFrame`; windows of the waterfall →
   normalization → segmentation (improved Otsu by default) → regions → range-bearing
   observations, each tied to the ping of its centroid. Normalization defaults to the along-track column median rather than the thesis's MIRA:
   on the real Scotsman recording MIRA's two exponentials cannot follow the bright band
   just beyond the first return, and the threshold then takes whole seabed bands as
   regions of ~40,000 px; ``normalization="mira"`` keeps the thesis's choice.
5. SLAM in ping order through the pipeline's fixed-lag feeder
   (:func:`slam.pipeline.replay.replay`): each
   ping's odometry is its own predict, every observation meets the pose of its own ping.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from slam.frontend.bottom_track import fill_track, track_bottom
from slam.frontend.sidescan_records import Detection
from slam.io.waterfall import Waterfall
from slam.pipeline import (
    REAL_SIDESCAN,
    EstimatorSpec,
    PipelineConfig,
    SonarFrame,
    SonarGeometry,
    SonarSlam,
    build_estimator,
    make_frontend,
)
from slam.pipeline.replay import recording_events, replay
from slam.types import Odometry

EARTH_RADIUS_M = 6_371_008.8  # IUGG mean radius


@dataclass(frozen=True)
class SidescanSlamConfig:
    """Settings of :func:`run_sidescan_slam`: the pipeline's (slam.pipeline.PipelineConfig,
    the recorded-data preset :data:`~slam.pipeline.REAL_SIDESCAN` by default), the
    estimator, and what only a recording needs: the altitude source ("first_return" |
    "nav"), the navigation's position units ("auto" | "degrees" | "metres", see
    :func:`local_poses_from_nav`) and the odometry error the user states
    (``odometry_sigma_frac`` of the distance travelled; heading random walk in
    deg/sqrt(s))."""

    pipeline: PipelineConfig = REAL_SIDESCAN
    estimator: EstimatorSpec = field(default_factory=EstimatorSpec)
    altitude: str = "first_return"
    nav_units: str = "auto"
    odometry_sigma_frac: float = 0.02
    heading_sigma_deg_per_sqrt_s: float = 0.2

    def __post_init__(self) -> None:
        if self.altitude not in ("first_return", "nav"):
            raise ValueError(f"altitude: got {self.altitude!r}; allowed: first_return, nav")
        for name in ("odometry_sigma_frac", "heading_sigma_deg_per_sqrt_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be > 0, got {v}")


@dataclass(frozen=True)
class SidescanSlamResult:
    """What a run produced. Poses ``(P, 3)`` are ``[x east m, y north m, yaw rad]`` in
    the local frame (origin at the first navigated ping) for the pings kept (``pings``:
    their indices in the input waterfall)."""

    pings: np.ndarray
    nav_poses: np.ndarray
    est_poses: np.ndarray
    est_cov: np.ndarray
    altitude: np.ndarray
    landmarks: np.ndarray
    landmark_cov: np.ndarray
    detections: list[Detection]
    n_windows: int
    timing_s: dict
    origin: tuple[float, float] | None  # (lon, lat) deg of the local origin, when projected

    def summary(self) -> dict:
        """JSON-friendly summary."""
        return {
            "pings_used": int(self.pings.size),
            "windows": self.n_windows,
            "detections": [
                {
                    "ping": int(self.pings[d.ping]),
                    "t_s": d.t,
                    "side": d.side,
                    "ground_range_m": d.ground_range,
                    "slant_range_m": d.slant_range,
                    "area_px": d.area_px,
                    "world_xy_nav_m": [float(v) for v in d.world_xy_true_pose],
                }
                for d in self.detections
            ],
            "landmarks_m": self.landmarks.tolist(),
            "landmark_sigma_m": np.sqrt(np.linalg.eigvalsh(self.landmark_cov).max(axis=1)).tolist()
            if len(self.landmarks)
            else [],
            "final_pose_nav": self.nav_poses[-1].tolist(),
            "final_pose_est": self.est_poses[-1].tolist(),
            "altitude_m": {
                "min": float(np.min(self.altitude)),
                "max": float(np.max(self.altitude)),
            },
            "origin_lonlat_deg": list(self.origin) if self.origin else None,
            "timing_s": self.timing_s,
        }


def local_poses_from_nav(
    nav: Mapping[str, np.ndarray], units: str = "auto"
) -> tuple[np.ndarray, np.ndarray, tuple | None]:
    """Per-ping local poses from a waterfall's navigation.

    units : "degrees" (x = lon, y = lat), "metres" (projected), or "auto": the XTF
        header's NavUnits when the reader recorded it (``xtf_nav_units``: 3 degrees,
        0 metres), else degrees when every position lies within [-180, 180] × [-90, 90].

    Returns ``(poses (P, 3), valid (P,) bool, origin)``: ``[x east m, y north m, yaw rad]``,
    which pings carry navigation, and the (lon, lat) of the origin when the positions were
    geographic. Raises ValueError when there is no usable position or heading.
    """
    missing = [k for k in ("x", "y", "heading_deg") if k not in nav]
    if missing:
        raise ValueError(
            f"the recording has no navigation field(s) {missing}: SLAM needs per-ping "
            "position (x, y) and heading_deg"
        )
    x = np.asarray(nav["x"], dtype=np.float64)
    y = np.asarray(nav["y"], dtype=np.float64)
    hdg = np.asarray(nav["heading_deg"], dtype=np.float64)
    valid = np.isfinite(x) & np.isfinite(y) & np.isfinite(hdg) & ~((x == 0) & (y == 0))
    if valid.sum() < 2:
        raise ValueError(f"only {int(valid.sum())} ping(s) carry navigation; need >= 2")
    first = int(np.flatnonzero(valid)[0])
    if units not in ("auto", "degrees", "metres"):
        raise ValueError(f"nav units: got {units!r}; allowed: auto, degrees, metres")
    if units == "auto" and "xtf_nav_units" in nav:
        code = float(np.asarray(nav["xtf_nav_units"])[first])
        units = "degrees" if code == 3 else "metres" if code == 0 else "auto"
    if units == "auto":
        geographic = bool(np.all(np.abs(x[valid]) <= 180) and np.all(np.abs(y[valid]) <= 90))
    else:
        geographic = units == "degrees"
    origin = None
    if geographic:
        lon0, lat0 = x[first], y[first]
        origin = (float(lon0), float(lat0))
        east = np.radians(x - lon0) * EARTH_RADIUS_M * math.cos(math.radians(lat0))
        north = np.radians(y - lat0) * EARTH_RADIUS_M
    else:
        east, north = x - x[first], y - y[first]
    yaw = np.pi / 2 - np.radians(hdg)
    yaw = np.mod(yaw + np.pi, 2 * np.pi) - np.pi
    return np.stack([east, north, yaw], axis=1), valid, origin


def odometry_between(
    p0: np.ndarray,
    p1: np.ndarray,
    dt: float,
    sigma_frac: float,
    heading_sigma_rad_sqrt_s: float,
    t: float = 0.0,
) -> Odometry:
    """Body-frame increment from pose ``p0`` to ``p1`` (the AEKF motion model's inverse),
    ending at time ``t``, with covariance ``diag((σ_f d)², (σ_f d)², σ_ψ² dt)``; d floored
    at 1 cm."""
    dx, dy = p1[0] - p0[0], p1[1] - p0[1]
    c, s = math.cos(p0[2]), math.sin(p0[2])
    dphi = (p1[2] - p0[2] + math.pi) % (2 * math.pi) - math.pi
    d = max(math.hypot(dx, dy), 0.01)
    cov = np.diag(
        [(sigma_frac * d) ** 2, (sigma_frac * d) ** 2, heading_sigma_rad_sqrt_s**2 * max(dt, 1e-3)]
    )
    return Odometry(delta=[c * dx + s * dy, -s * dx + c * dy, dphi], cov=cov, t=t)


def ping_altitudes(wf: Waterfall, source: str) -> np.ndarray:
    """(P,) altitude per ping, m: the bottom track's first seabed return (both sides
    together; pings without a pick interpolated between their neighbours) or the file's
    ``altitude_m``. Raises ValueError when no ping has a bottom."""
    if source == "nav":
        if "altitude_m" not in wf.nav:
            raise ValueError("altitude='nav' but the recording has no altitude_m navigation")
        return np.asarray(wf.nav["altitude_m"], dtype=np.float64)
    return fill_track(track_bottom(wf))


def run_sidescan_slam(
    wf: Waterfall, config: SidescanSlamConfig | None = None
) -> SidescanSlamResult:
    """Run the front end and SLAM over a recorded waterfall (see the module docstring)."""
    cfg = config or SidescanSlamConfig()
    t_start = time.perf_counter()
    poses_all, valid, origin = local_poses_from_nav(wf.nav, cfg.nav_units)
    t_all = np.asarray(wf.time_s, dtype=np.float64)
    valid &= np.isfinite(t_all)
    keep = np.flatnonzero(valid)
    pipe = cfg.pipeline
    if keep.size < pipe.window_pings // 2:
        raise ValueError(
            f"only {keep.size} navigated pings; need at least window_pings/2 = {pipe.window_pings // 2}"
        )
    pipe = replace(
        pipe,
        window_pings=min(pipe.window_pings, keep.size),
        hop_pings=min(pipe.hop_pings, keep.size),
    )
    poses = poses_all[keep]
    t = t_all[keep]
    alt = ping_altitudes(wf, cfg.altitude)[keep]
    if not np.all(np.isfinite(alt)):
        raise ValueError("altitude has non-finite values on navigated pings")
    step = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    dt = np.diff(t)
    speed = np.concatenate([[0.0], step / np.where(dt > 0, dt, np.inf)])
    speed[0] = speed[1] if speed.size > 1 else 0.0
    frames = sidescan_frames(wf, keep, alt, speed)
    odometry = [
        odometry_between(
            poses[i - 1],
            poses[i],
            float(dt[i - 1]),
            cfg.odometry_sigma_frac,
            math.radians(cfg.heading_sigma_deg_per_sqrt_s),
            t=float(t[i]),
        )
        for i in range(1, len(poses))
    ]
    est = build_estimator(cfg.estimator, poses[0], pipe)
    frontend = make_frontend(frames[0].geometry, pipe)
    slam = SonarSlam({"sss": frontend}, est, pipe, t0=float(t[0]), pose0=poses[0], record_dt=0.0)
    outs, _ = replay(slam, recording_events(frames, odometry))
    t_end = time.perf_counter()
    detections = [d for o in outs if o.window is not None for d in o.window.detections]
    hist = slam.lagged.history
    ht = np.array([r.t for r in hist])
    at = np.searchsorted(ht, t, side="right") - 1
    x0, P0 = poses[0], pipe.initial_covariance()
    est_poses = np.array([hist[j].x[:3] if j >= 0 else x0 for j in at])
    est_cov = np.array([hist[j].P[:3, :3] if j >= 0 else P0 for j in at])
    lm, lm_cov = est.landmarks()
    return SidescanSlamResult(
        pings=keep,
        nav_poses=poses,
        est_poses=est_poses,
        est_cov=est_cov,
        altitude=alt,
        landmarks=np.asarray(lm).reshape(-1, 2),
        landmark_cov=np.asarray(lm_cov).reshape(-1, 2, 2),
        detections=detections,
        n_windows=sum(1 for o in outs if o.window is not None),
        timing_s={"total": t_end - t_start},
        origin=origin,
    )


def sidescan_frames(wf: Waterfall, keep: np.ndarray, alt: np.ndarray, speed: np.ndarray) -> list:
    """The kept pings of a waterfall as pipeline frames (slant ranges from each ping's
    range setting; linear intensity)."""
    s = wf.samples_per_side
    frames = []
    geom = None
    for i, k in enumerate(keep):
        slant = (np.arange(s) + 0.5) * wf.slant_range_m[k] / s
        if geom is None or not np.array_equal(geom.ranges, slant):
            geom = SonarGeometry("sss", slant)
        frames.append(
            SonarFrame(
                "sss",
                np.asarray(wf.intensity[k], np.float32),
                geom,
                float(wf.time_s[k]),
                altitude=float(alt[i]),
                speed=float(speed[i]),
            )
        )
    return frames


def plot_sidescan_slam(wf: Waterfall, result: SidescanSlamResult, path) -> None:
    """Two panels: the waterfall (dB, port left) with detections, and the map (navigation
    and SLAM tracks, landmarks with 2σ ellipses, detections placed with the navigation)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse

    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(13, 6))
    img = wf.intensity[result.pings].astype(np.float64)
    db = 10 * np.log10(np.clip(img, np.percentile(img, 1) + 1e-9, None))
    ax0.imshow(
        db, cmap="copper", aspect="auto", vmin=np.percentile(db, 2), vmax=np.percentile(db, 99.5)
    )
    s = wf.samples_per_side
    for d in result.detections:
        col = s + d.slant_range / wf.slant_range_m[result.pings[d.ping]] * s
        if d.side == "port":
            col = 2 * s - col
        ax0.plot(col, d.ping, "o", mfc="none", mec="cyan", ms=12)
    ax0.set(title="waterfall (port | starboard) and detections", xlabel="sample", ylabel="ping")
    ax1.plot(*result.nav_poses[:, :2].T, "k-", lw=1, label="navigation")
    ax1.plot(*result.est_poses[:, :2].T, "b--", lw=1, label="SLAM")
    if result.detections:
        xy = np.array([d.world_xy_true_pose for d in result.detections])
        ax1.plot(*xy.T, "mx", label="detections (nav pose)")
    for m, C in zip(result.landmarks, result.landmark_cov):
        w, v = np.linalg.eigh(C)
        ang = math.degrees(math.atan2(v[1, 1], v[0, 1]))
        ax1.add_patch(
            Ellipse(m, 4 * math.sqrt(w[1]), 4 * math.sqrt(w[0]), angle=ang, fill=False, ec="r")
        )
        ax1.plot(*m, "r+", ms=10)
    ax1.plot([], [], "r+", label="landmarks (2σ)")
    ax1.set(title="map", xlabel="x east (m)", ylabel="y north (m)", aspect="equal")
    ax1.legend(loc="best", fontsize=8)
    ax1.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
