"""Mission generators: lawnmower survey, loop through waypoints, straight line, hold.

A :class:`Mission` is a polyline of world waypoints (x east, y north, m) flown at one
speed and at a constant depth or a constant altitude above the seabed. The autopilot
flies the legs p_k -> p_{k+1} with line-of-sight guidance (sim.guidance.los); the first
leg starts wherever the vehicle is when the mission starts.

Lawnmower geometry (stated, so that tests can check it): tracks run along the
rectangle's length (direction ``heading``), spaced s = swath · (1 − overlap) across it.
n = floor(W / s) + 1 tracks fit inside the width W; the pattern is centred, so the
outer tracks sit (W − (n − 1) s)/2 < s/2 <= swath/2 inside the edges: every point of the
rectangle lies within swath/2 of a track (full coverage), and all tracks stay inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "Mission",
    "WorldBounds",
    "hold",
    "lawnmower",
    "lawnmower_spacing",
    "loop",
    "straight_line",
    "with_calibration_loop",
]


def _pos(name: str, v: float, allow_zero: bool = False) -> float:
    ok = isinstance(v, int | float) and math.isfinite(v) and (v >= 0 if allow_zero else v > 0)
    if not ok:
        raise ValueError(
            f"{name} must be a finite number {'>=' if allow_zero else '>'} 0, got {v!r}"
        )
    return float(v)


@dataclass(frozen=True)
class WorldBounds:
    """Horizontal extent the vehicle may use, world m, and optionally the seabed depth
    (m, positive down) below which no waypoint may lie."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    max_depth: float = math.inf

    def __post_init__(self) -> None:
        if not (self.x_min < self.x_max and self.y_min < self.y_max):
            raise ValueError(f"WorldBounds needs x_min < x_max and y_min < y_max, got {self}")

    def __str__(self) -> str:
        s = f"x in [{self.x_min:g}, {self.x_max:g}] m, y in [{self.y_min:g}, {self.y_max:g}] m"
        if math.isfinite(self.max_depth):
            s += f", depth <= {self.max_depth:g} m"
        return s


@dataclass(frozen=True)
class Mission:
    """waypoints (N, 2) world m; speed m/s; exactly one of depth (m, positive down) or
    altitude (m above the seabed); acceptance_radius m (a waypoint counts as reached
    inside it, or once the vehicle has passed the end of the leg along-track);
    hold_time s spent at the last waypoint before completion (station keeping)."""

    kind: str
    waypoints: np.ndarray
    speed: float
    depth: float | None = None
    altitude: float | None = None
    acceptance_radius: float = 2.0
    hold_time: float = 0.0

    def __post_init__(self) -> None:
        w = np.asarray(self.waypoints, float)
        if w.ndim != 2 or w.shape[1] != 2 or len(w) < 1:
            raise ValueError(f"Mission.waypoints must have shape (N >= 1, 2), got {w.shape}")
        bad = np.flatnonzero(~np.all(np.isfinite(w), axis=1))
        if len(bad):
            raise ValueError(f"Mission waypoint {bad[0]} is not finite: {w[bad[0]].tolist()}")
        if len(w) > 1:
            seg = np.hypot(*np.diff(w, axis=0).T)
            z = np.flatnonzero(seg < 1e-6)
            if len(z):
                raise ValueError(
                    f"Mission waypoints {z[0]} and {z[0] + 1} coincide at {w[z[0]].tolist()}"
                )
        w.setflags(write=False)
        object.__setattr__(self, "waypoints", w)
        _pos("Mission.speed", self.speed, allow_zero=self.kind == "hold")
        _pos("Mission.acceptance_radius", self.acceptance_radius)
        _pos("Mission.hold_time", self.hold_time, allow_zero=True)
        if (self.depth is None) == (self.altitude is None):
            raise ValueError(
                f"Mission needs exactly one of depth or altitude, got depth={self.depth!r}, "
                f"altitude={self.altitude!r}"
            )
        if self.depth is not None:
            _pos("Mission.depth", self.depth, allow_zero=True)
        if self.altitude is not None:
            _pos("Mission.altitude", self.altitude)

    @property
    def n_legs(self) -> int:
        return len(self.waypoints) - 1

    @property
    def length(self) -> float:
        """Polyline length from the first to the last waypoint, m."""
        return float(np.hypot(*np.diff(self.waypoints, axis=0).T).sum()) if self.n_legs else 0.0

    def validate_bounds(self, bounds: WorldBounds, margin: float = 0.0) -> None:
        """ValueError naming the first waypoint outside ``bounds`` shrunk by ``margin`` m,
        or a depth below the seabed."""
        w = self.waypoints
        lo = np.array([bounds.x_min + margin, bounds.y_min + margin])
        hi = np.array([bounds.x_max - margin, bounds.y_max - margin])
        out = np.flatnonzero(np.any((w < lo) | (w > hi), axis=1))
        if len(out):
            i = int(out[0])
            raise ValueError(
                f"{self.kind} mission waypoint {i} at ({w[i, 0]:.6g}, {w[i, 1]:.6g}) m leaves "
                f"the world bounds: allowed {bounds}"
                + (f" less a margin of {margin:g} m" if margin else "")
            )
        if self.depth is not None and self.depth > bounds.max_depth:
            raise ValueError(
                f"{self.kind} mission depth {self.depth:g} m is below the seabed: allowed "
                f"depth <= {bounds.max_depth:g} m"
            )


def lawnmower_spacing(swath_width: float, overlap: float) -> float:
    """Track spacing s = swath · (1 − overlap), m; overlap in [0, 1)."""
    _pos("swath_width", swath_width)
    if not (isinstance(overlap, int | float) and 0.0 <= overlap < 1.0):
        raise ValueError(f"overlap must be a fraction in [0, 1), got {overlap!r}")
    return swath_width * (1.0 - overlap)


def lawnmower(
    center,
    length: float,
    width: float,
    swath_width: float,
    overlap: float,
    *,
    heading: float = 0.0,
    speed: float,
    depth: float | None = None,
    altitude: float | None = None,
    acceptance_radius: float = 2.0,
    spacing: float | None = None,
) -> Mission:
    """Boustrophedon survey of the rectangle centred at ``center`` (x, y m), ``length`` m
    along ``heading`` (rad CCW from east) by ``width`` m across. ``spacing`` (m) overrides
    the swath/overlap spacing. Tracks start at the right-hand (starboard) edge seen
    along ``heading`` and step to port."""
    _pos("length", length)
    _pos("width", width)
    s = lawnmower_spacing(swath_width, overlap) if spacing is None else _pos("spacing", spacing)
    n = math.floor(width / s + 1e-9) + 1
    offsets = (np.arange(n) - (n - 1) / 2.0) * s  # centred, to port positive
    u = np.array([math.cos(heading), math.sin(heading)])  # along-track
    v = np.array([-u[1], u[0]])  # to port
    c = np.asarray(center, float).reshape(2)
    wps = []
    for i, off in enumerate(offsets):
        a = c + off * v - 0.5 * length * u
        b = c + off * v + 0.5 * length * u
        wps.extend([a, b] if i % 2 == 0 else [b, a])
    return Mission(
        "lawnmower", np.array(wps), speed, depth, altitude, acceptance_radius=acceptance_radius
    )


def loop(
    waypoints,
    *,
    laps: int = 1,
    speed: float,
    depth: float | None = None,
    altitude: float | None = None,
    acceptance_radius: float = 2.0,
) -> Mission:
    """Fly the closed polygon ``waypoints`` (N >= 2, 2) ``laps`` times, ending where it
    started."""
    w = np.asarray(waypoints, float)
    if w.ndim != 2 or w.shape[1] != 2 or len(w) < 2:
        raise ValueError(f"loop waypoints must have shape (N >= 2, 2), got {w.shape}")
    if not (isinstance(laps, int) and laps >= 1):
        raise ValueError(f"laps must be an integer >= 1, got {laps!r}")
    closed = w if np.allclose(w[0], w[-1]) else np.vstack([w, w[:1]])
    path = np.vstack([closed] + [closed[1:]] * (laps - 1))
    return Mission("loop", path, speed, depth, altitude, acceptance_radius=acceptance_radius)


def with_calibration_loop(
    mission: Mission, at: float, radius: float, laps: int = 1, n_per_lap: int = 16
) -> Mission:
    """``mission`` with ``laps`` full turns of ``radius`` m to starboard flown from the
    point ``at`` m along its first leg, back to that point on the same heading, before
    the rest of the leg: a compass-calibration loop (every heading flown once per lap,
    the start of the loop re-imaged at its end). Each lap is a regular polygon of
    ``n_per_lap`` waypoints tangent to the leg; a lawnmower's lines step to port, so the
    loop lies outside its box."""
    w = mission.waypoints
    if mission.n_legs < 1:
        raise ValueError(f"a calibration loop needs a mission with a first leg, got {w.tolist()}")
    leg = w[1] - w[0]
    length = float(np.hypot(*leg))
    if not (isinstance(at, int | float) and 0.0 < at < length):
        raise ValueError(
            f"calibration loop at must lie inside the first leg (0, {length:g}) m, got {at!r}"
        )
    _pos("calibration loop radius", radius)
    if not (isinstance(laps, int) and laps >= 1):
        raise ValueError(f"calibration loop laps must be an integer >= 1, got {laps!r}")
    u = leg / length
    port = np.array([-u[1], u[0]])
    p = w[0] + at * u
    c = p - radius * port  # centre to starboard
    th = (
        math.atan2(port[1], port[0])
        - 2.0 * math.pi * np.arange(1, n_per_lap * laps + 1) / n_per_lap
    )
    ring = c + radius * np.column_stack([np.cos(th), np.sin(th)])
    ring[-1] = p  # closes exactly where it started
    wps = np.vstack([w[:1], p, ring, w[1:]])
    return Mission(
        mission.kind,
        wps,
        mission.speed,
        mission.depth,
        mission.altitude,
        acceptance_radius=mission.acceptance_radius,
        hold_time=mission.hold_time,
    )


def straight_line(
    start,
    end,
    *,
    speed: float,
    depth: float | None = None,
    altitude: float | None = None,
    acceptance_radius: float = 2.0,
) -> Mission:
    """One leg from ``start`` to ``end`` (x, y m)."""
    return Mission(
        "line",
        np.array([start, end], float),
        speed,
        depth,
        altitude,
        acceptance_radius=acceptance_radius,
    )


def hold(
    point,
    *,
    duration: float,
    depth: float | None = None,
    altitude: float | None = None,
    acceptance_radius: float = 1.0,
) -> Mission:
    """Go to ``point`` (x, y m) and keep station there for ``duration`` s."""
    return Mission(
        "hold",
        np.array([point], float),
        0.5,
        depth,
        altitude,
        acceptance_radius=acceptance_radius,
        hold_time=_pos("duration", duration),
    )
