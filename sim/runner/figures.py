"""PNG figures of a run (matplotlib, Agg backend): trajectory + map, side-scan mosaic.

Inputs are plain arrays so the figures can be redrawn from saved data.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.viz.rerun_log import CLASS_COLORS, ellipse_axes


@dataclass(frozen=True)
class VehiclePlotData:
    name: str
    true_xy: np.ndarray  # (k, 2)
    est_xy: np.ndarray  # (m, 2)
    landmarks: np.ndarray  # (n, 2)
    landmark_covs: np.ndarray  # (n, 2, 2)
    detections_xy: np.ndarray  # (d, 2) detections placed with the true pose


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def plot_trajectory_map(
    path: str | Path,
    vehicles: Sequence[VehiclePlotData],
    objects: Sequence[tuple[str, np.ndarray, np.ndarray]],
    title: str = "",
    extent: tuple[float, float, float, float] | None = None,
) -> Path:
    """True and estimated paths, true objects (boxes), estimated landmarks with 2-sigma
    ellipses and detections, in the world frame (x east, y north, m)."""
    plt = _plt()
    from matplotlib.patches import Ellipse, Rectangle

    fig, ax = plt.subplots(figsize=(9, 8), dpi=110)
    for cls, pos, size in objects:
        c = np.array(CLASS_COLORS.get(cls, (150, 150, 150))) / 255
        ax.add_patch(
            Rectangle(
                (pos[0] - size[0] / 2, pos[1] - size[1] / 2), size[0], size[1], color=c, alpha=0.6
            )
        )
        ax.annotate(
            cls,
            (pos[0], pos[1]),
            fontsize=7,
            ha="center",
            va="bottom",
            xytext=(0, 6),
            textcoords="offset points",
        )
    for i, v in enumerate(vehicles):
        col = plt.cm.tab10(i % 10)
        if len(v.true_xy):
            ax.plot(
                v.true_xy[:, 0], v.true_xy[:, 1], "-", color=col, lw=1.2, label=f"{v.name} true"
            )
        if len(v.est_xy):
            ax.plot(v.est_xy[:, 0], v.est_xy[:, 1], "--", color=col, lw=1.0, label=f"{v.name} SLAM")
        if len(v.detections_xy):
            ax.plot(
                v.detections_xy[:, 0],
                v.detections_xy[:, 1],
                "x",
                color="m",
                ms=4,
                label=f"{v.name} detections",
            )
        if len(v.landmarks):
            half, ang = ellipse_axes(v.landmark_covs)
            for p, h, a in zip(v.landmarks, half, ang):
                ax.add_patch(
                    Ellipse(
                        p, 2 * h[0], 2 * h[1], angle=np.degrees(a), fill=False, color=col, lw=0.8
                    )
                )
            ax.plot(
                v.landmarks[:, 0],
                v.landmarks[:, 1],
                "+",
                color=col,
                ms=8,
                label=f"{v.name} landmarks (2σ)",
            )
    if extent is not None:
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title(title or "trajectory and map")
    ax.legend(fontsize=7, loc="upper right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out)
    plt.close(fig)
    return out


def mosaic_grid(
    xy: np.ndarray, values: np.ndarray, extent: tuple[float, float, float, float], cell: float
) -> np.ndarray:
    """Mean of values falling in each cell of a north-up grid (rows = y descending).
    xy (N, 2) world m; NaN where no sample fell. Vectorized with np.add.at."""
    x0, x1, y0, y1 = extent
    nx = max(1, int(np.ceil((x1 - x0) / cell)))
    ny = max(1, int(np.ceil((y1 - y0) / cell)))
    ix = np.floor((xy[:, 0] - x0) / cell).astype(np.int64)
    iy = np.floor((y1 - xy[:, 1]) / cell).astype(np.int64)
    ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny) & np.isfinite(values)
    s = np.zeros((ny, nx))
    n = np.zeros((ny, nx))
    np.add.at(s, (iy[ok], ix[ok]), values[ok])
    np.add.at(n, (iy[ok], ix[ok]), 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, s / np.maximum(n, 1), np.nan)


def sss_sample_world_xy(poses: np.ndarray, ground_range: np.ndarray) -> np.ndarray:
    """World xy of every sample of every ping, (P, 2S, 2), port left (far first).

    poses (P, 3) [x, y, yaw] at each ping; ground_range (P, S) per starboard sample."""
    g = np.concatenate([-ground_range[:, ::-1], ground_range], axis=1)  # port negative
    # starboard is -y body (right), port +y body: lateral offset = -g
    x, y, yaw = poses[:, 0:1], poses[:, 1:2], poses[:, 2:3]
    lat = -g
    return np.stack([x - lat * np.sin(yaw), y + lat * np.cos(yaw)], axis=-1)


def sss_footprints(
    poses: np.ndarray,
    ground_range: np.ndarray,
    intensity: np.ndarray,
    cell: float,
    max_step_m: float = 5.0,
    max_sub: int = 16,
) -> tuple[np.ndarray, np.ndarray]:
    """World xy (N, 2) and values (N,) of every sample spread over the strip it covers up
    to the next ping: K lines between consecutive pings (pose interpolated, yaw the short
    way round, each sample keeping its ping's value), K so that the lines are at most
    ``cell``/2 apart at the far end. In a turn the far samples of consecutive pings are
    metres apart: without this the mosaic shows them as radial spokes. Pairs farther
    apart than ``max_step_m`` at nadir (a gap in the record) are not filled.

    poses (P, 3) [x, y, yaw]; ground_range (P, S); intensity (P, 2S) port far first."""
    xy = sss_sample_world_xy(poses, ground_range)
    if len(poses) < 2:
        return xy.reshape(-1, 2), intensity.reshape(-1)
    gap = np.linalg.norm(np.diff(xy, axis=0), axis=2).max(axis=1)  # (P-1,) far-end spacing
    near = np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1)
    k = int(
        np.clip(
            np.ceil(np.nanmax(np.where(near <= max_step_m, gap, 0.0)) / (0.5 * cell)), 1, max_sub
        )
    )
    pts, vals = [xy.reshape(-1, 2)], [intensity.reshape(-1)]
    dyaw = (np.diff(poses[:, 2]) + np.pi) % (2 * np.pi) - np.pi
    ok = near <= max_step_m
    for f in np.arange(1, k) / k:  # k − 1 sub-lines, each vectorised over all pings
        p = poses[:-1][ok].copy()
        p[:, :2] += f * np.diff(poses[:, :2], axis=0)[ok]
        p[:, 2] += f * dyaw[ok]
        g = ground_range[:-1][ok] + f * np.diff(ground_range, axis=0)[ok]
        pts.append(sss_sample_world_xy(p, g).reshape(-1, 2))
        vals.append(intensity[:-1][ok].reshape(-1))
    return np.concatenate(pts), np.concatenate(vals)


def plot_sss_mosaic(
    path: str | Path,
    mosaics: Mapping[str, tuple[np.ndarray, tuple[float, float, float, float]]],
    detections: Mapping[str, np.ndarray],
    objects: Sequence[tuple[str, np.ndarray, np.ndarray]],
    title: str = "",
) -> Path:
    """Georeferenced side-scan mosaics with detections and true objects. The grids hold
    the sonar's display values (log-compressed by the sonar, or linear): shown with a
    1-99.7 percentile stretch."""
    plt = _plt()
    n = max(1, len(mosaics))
    fig, axes = plt.subplots(1, n, figsize=(8 * n, 7), dpi=110, squeeze=False)
    for ax, (name, (grid, ext)) in zip(axes[0], mosaics.items()):
        g = np.where(np.isfinite(grid), grid, np.nan)
        lo, hi = np.nanpercentile(g, [1.0, 99.7]) if np.isfinite(g).any() else (0.0, 1.0)
        ax.imshow(
            g, extent=ext, cmap="copper", vmin=lo, vmax=hi, origin="upper", interpolation="nearest"
        )
        for _cls, p, size in objects:
            ax.add_patch(
                plt.Rectangle(
                    (p[0] - size[0] / 2, p[1] - size[1] / 2),
                    size[0],
                    size[1],
                    fill=False,
                    ec="c",
                    lw=0.8,
                )
            )
        d = detections.get(name)
        if d is not None and len(d):
            ax.plot(d[:, 0], d[:, 1], "o", mfc="none", mec="m", ms=8, label="detections")
            ax.legend(fontsize=7)
        ax.set_title(f"{title} {name}".strip())
        ax.set_xlabel("x east (m)")
        ax.set_ylabel("y north (m)")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out)
    plt.close(fig)
    return out


def write_figures(run, out) -> None:
    """The figures of a finished ScenarioRun into the RunDirectory ``out``:
    trajectory_map.png and, with side-scan pings, sss_mosaic.png."""
    objs = [(o.class_name, np.asarray(o.position), np.asarray(o.size)) for o in run.world.objects]
    vd = []
    mos = {}
    dets_by = {}
    sx, sy = run.scn.world.size_m
    ext = (-sx / 2, sx / 2, -sy / 2, sy / 2)
    for v in run.vehicles:
        lag = v.lagged
        est = np.array([r.x[:2] for r in lag.history]) if lag and lag.history else np.zeros((0, 2))
        means, covs = lag.estimator.landmarks() if lag else (np.zeros((0, 2)), np.zeros((0, 2, 2)))
        dets = v.tally.detections
        vd.append(
            VehiclePlotData(
                v.spec.name,
                np.array(v.true_pose)[:, :2],
                est,
                np.asarray(means).reshape(-1, 2),
                np.asarray(covs).reshape(-1, 2, 2),
                np.array([d.world_xy_true_pose for _, d in dets]).reshape(-1, 2),
            )
        )
        for s in v.sonars:
            if s.kind == "sss" and s.sss_pings:
                poses = np.array([p[0] for p in s.sss_pings])
                g = np.array([p[1] for p in s.sss_pings])
                inten = np.array([p[2] for p in s.sss_pings])
                xy, vals = sss_footprints(poses, g, inten, 0.5)
                key = f"{v.spec.name}/{s.spec.name}"
                mos[key] = (mosaic_grid(xy, vals, ext, 0.5), ext)
                dets_by[key] = np.array(
                    [d.world_xy_true_pose for sn, d in dets if sn == s.spec.name]
                ).reshape(-1, 2)
    plot_trajectory_map(out.path("trajectory_map.png"), vd, objs, title=run.scn.name, extent=ext)
    if mos:
        plot_sss_mosaic(out.path("sss_mosaic.png"), mos, dets_by, objs, title=run.scn.name)
