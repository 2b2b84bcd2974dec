"""Figures like the thesis's 6.1–6.4 (matplotlib, Agg): true and estimated landmarks with
2σ ellipses, true and estimated path, and the average NEES over time with its bounds.
Functions return the written path; they never show windows."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import EllipseCollection

__all__ = ["plot_map", "plot_nees", "plot_nees_curves"]


def _ellipse_params(cov: np.ndarray, k: float):
    """Width, height (full axes, m) and angle (deg) of the k-σ ellipses of ``cov (m, 2, 2)``."""
    w, v = np.linalg.eigh(cov)
    w = np.maximum(w, 0.0)
    ang = np.degrees(np.arctan2(v[:, 1, 1], v[:, 0, 1]))
    return 2 * k * np.sqrt(w[:, 1]), 2 * k * np.sqrt(w[:, 0]), ang


def plot_map(run, true_landmarks, waypoints, path, *, title: str = "", named=None) -> Path:
    """Map figure of one :class:`~slam.experiments.runner.RunResult`: true landmarks (blue
    *), waypoints (green dots), estimated landmarks (red +) with 2σ ellipses, true path
    (grey) and estimated path (black) with the final pose's 2σ ellipse."""
    path = Path(path)
    fig, ax = plt.subplots(figsize=(8, 7), dpi=110)
    lm_true = np.asarray(true_landmarks)
    ax.plot(*np.asarray(waypoints).T, "o", color="tab:green", ms=5, label="waypoints")
    ax.plot(*lm_true.T, "*", color="tab:blue", ms=9, label="true landmarks")
    ax.plot(*run.true_poses[:, :2].T, "-", color="0.6", lw=1.0, label="true path")
    ax.plot(*run.est_poses[:, :2].T, "-", color="k", lw=1.0, label="estimated path")
    if run.lm_est.shape[0]:
        ax.plot(*run.lm_est.T, "+", color="tab:red", ms=8, mew=1.5, label="estimated landmarks")
        w, h, a = _ellipse_params(run.lm_cov, 2.0)
        ax.add_collection(
            EllipseCollection(
                w,
                h,
                a,
                units="xy",
                offsets=run.lm_est,
                offset_transform=ax.transData,
                facecolors="none",
                edgecolors="tab:red",
                linewidths=0.8,
            )
        )
    w, h, a = _ellipse_params(run.pose_cov[-1:, :2, :2], 2.0)
    ax.add_collection(
        EllipseCollection(
            w,
            h,
            a,
            units="xy",
            offsets=run.est_poses[-1:, :2],
            offset_transform=ax.transData,
            facecolors="none",
            edgecolors="tab:orange",
            linewidths=1.2,
        )
    )
    ax.plot(*run.est_poses[-1, :2], "^", color="c", ms=9, label="final pose (2σ ellipse)")
    for key, p in (named or {}).items():
        ax.annotate(key, p, textcoords="offset points", xytext=(6, 6), fontsize=9)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title or f"{run.filter}: landmark RMSE {run.landmark_rmse:.2f} m")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path


def plot_nees(avg_nees, bounds, path, *, t=None, title: str = "", runs: int | None = None) -> Path:
    """Average vehicle-pose NEES over time with its two-sided 95 % χ² bounds."""
    avg = np.asarray(avg_nees, dtype=float)
    inside = np.mean((avg >= bounds[0]) & (avg <= bounds[1]))
    title = title or (
        f"average NEES over {runs or '?'} runs; 95 % bounds [{bounds[0]:.2f}, {bounds[1]:.2f}], "
        f"{100 * inside:.0f} % inside"
    )
    return plot_nees_curves({"average NEES": avg}, bounds, path, t=t, title=title)


def plot_nees_curves(curves, bounds, path, *, t=None, title: str = "") -> Path:
    """Several average-NEES curves ``{label: (S,) array}`` over time (s, or scan index when
    ``t`` is None) on one log axis with the 95 % χ² bounds and the expectation n = 3:
    e.g. the reference's AEKF against a consistent variant on the same runs."""
    path = Path(path)
    fig, ax = plt.subplots(figsize=(8, 3.5), dpi=110)
    colors = ["k", "tab:orange", "tab:green", "tab:purple", "tab:brown"]
    for i, (label, avg) in enumerate(curves.items()):
        avg = np.asarray(avg, dtype=float)
        x = np.arange(avg.size) if t is None else np.asarray(t)
        ax.plot(x, avg, "-", color=colors[i % len(colors)], lw=0.8, label=label)
    for i, b in enumerate(bounds):
        ax.axhline(b, color="tab:red", ls="--", lw=1.0, label="95 % χ² bounds" if i == 0 else None)
    ax.axhline(3.0, color="tab:blue", ls=":", lw=1.0, label="expected (n = 3)")
    ax.set_yscale("log")
    ax.set_xlabel("scan" if t is None else "time [s]")
    ax.set_ylabel("NEES")
    ax.set_title(title)
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
