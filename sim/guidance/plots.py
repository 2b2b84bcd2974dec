"""Figures of flown missions (matplotlib, Agg-safe; returns the Figure, never shows)."""

from __future__ import annotations

import numpy as np

from sim.guidance.missions import Mission

__all__ = ["plot_mission_track"]


def plot_mission_track(
    mission: Mission,
    track_xy,
    cross_track=None,
    t=None,
    title: str | None = None,
):
    """Plan view of ``mission`` (waypoints, legs) and the flown ``track_xy`` (N, 2) world
    m; with ``cross_track`` (N,) m and ``t`` (N,) s a second panel shows e(t).

    Returns the matplotlib Figure (the caller saves it)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    track = np.asarray(track_xy, float)
    if track.ndim != 2 or track.shape[1] != 2:
        raise ValueError(f"track_xy must have shape (N, 2), got {track.shape}")
    two = cross_track is not None and t is not None
    fig, axes = plt.subplots(1, 2 if two else 1, figsize=(11 if two else 6, 5), squeeze=False)
    ax = axes[0, 0]
    w = mission.waypoints
    ax.plot(w[:, 0], w[:, 1], "--", color="0.5", lw=1, label=f"{mission.kind} plan")
    ax.plot(w[:, 0], w[:, 1], "o", color="0.3", ms=4)
    ax.plot(track[:, 0], track[:, 1], "-", color="C0", lw=1.5, label="flown")
    ax.plot(track[:1, 0], track[:1, 1], "^", color="C2", ms=8, label="start")
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.legend(loc="best", fontsize=8)
    if title:
        ax.set_title(title)
    if two:
        ax2 = axes[0, 1]
        ax2.plot(np.asarray(t, float), np.asarray(cross_track, float), color="C1")
        ax2.axhline(0.0, color="0.5", lw=0.8)
        ax2.set_xlabel("t (s)")
        ax2.set_ylabel("cross-track error e (m, + = port of leg)")
    fig.tight_layout()
    return fig
