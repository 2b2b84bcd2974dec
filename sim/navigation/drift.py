"""Dead-reckoning drift of a navigation suite on a kinematic survey track.

No physics: :func:`lawnmower_states` generates the true states of a vehicle flying a
lawnmower at constant speed and altitude (straight legs joined by constant-rate
half-circle turns), and :func:`dead_reckoning_drift` feeds them to a
:class:`~sim.navigation.suite.NavSuite`, composes its odometry increments from the true
start pose (as SLAM's predict does) and compares the result with the truth. Drift is
reported as a fraction of the distance travelled (``% DT``, the figure navigation
datasheets quote), together with the NEES of the final pose against the covariance of
the composed increments (is the odometry's Q what the sensors do?).

Frames: world x east, y north, z up; yaw counter-clockwise from east, rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim.frames import wxyz_from_euler
from sim.navigation.suite import NavSuite, NavSuiteConfig
from sim.state import VehicleState

__all__ = ["DriftResult", "dead_reckoning_drift", "lawnmower_states"]


def lawnmower_states(
    speed: float,
    leg_m: float = 100.0,
    spacing_m: float = 20.0,
    n_legs: int = 6,
    dt: float = 0.05,
    altitude: float = 10.0,
    depth: float = 20.0,
) -> list[VehicleState]:
    """True states every ``dt`` s along a lawnmower: ``n_legs`` legs of ``leg_m`` m east
    and west, joined by half circles of diameter ``spacing_m`` (alternately left and
    right), at ``speed`` m/s. The pose advances with the mid-step heading (exact for
    constant-rate arcs to second order in dt)."""
    for name, v in (("speed", speed), ("leg_m", leg_m), ("spacing_m", spacing_m), ("dt", dt)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"lawnmower_states: {name} must be a finite number > 0, got {v!r}")
    if n_legs < 1:
        raise ValueError(f"lawnmower_states: n_legs must be >= 1, got {n_legs}")
    turn_rate = speed / (0.5 * spacing_m)
    t_leg, t_turn = leg_m / speed, math.pi / turn_rate
    segments = []  # (duration, yaw rate)
    for i in range(n_legs):
        segments.append((t_leg, 0.0))
        if i < n_legs - 1:
            segments.append((t_turn, turn_rate if i % 2 == 0 else -turn_rate))
    t_total = sum(d for d, _ in segments)
    n = math.floor(t_total / dt + 1e-9)
    ends = np.cumsum([d for d, _ in segments])
    rates = np.array([r for _, r in segments])
    t = np.arange(n + 1) * dt
    seg = np.minimum(np.searchsorted(ends, t + 1e-9 * dt, side="right"), len(segments) - 1)
    rate = rates[seg]
    yaw = np.concatenate([[0.0], np.cumsum(rate[:-1] * dt)])
    yaw_mid = yaw[:-1] + 0.5 * rate[:-1] * dt
    xy = np.concatenate(
        [np.zeros((1, 2)), np.cumsum(speed * dt * np.c_[np.cos(yaw_mid), np.sin(yaw_mid)], axis=0)]
    )
    return [
        VehicleState(
            t=float(t[k]),
            position=np.array([xy[k, 0], xy[k, 1], -depth]),
            quat_wxyz=wxyz_from_euler(0.0, 0.0, float(yaw[k])),
            velocity_body=np.array([speed, 0.0, 0.0]),
            angular_velocity_body=np.array([0.0, 0.0, rate[k]]),
            acceleration_body=np.array([0.0, speed * rate[k], 0.0]),
            water_velocity_world=np.zeros(3),
            altitude=altitude,
        )
        for k in range(n + 1)
    ]


@dataclass(frozen=True)
class DriftResult:
    """distance_m: distance travelled. final_error_m: horizontal dead-reckoning error at
    the end. drift_pct: final_error_m / distance_m in %. rms_drift_pct: RMS over the run
    of error / distance so far (after the first 10 % of the distance), %. nees_final:
    NEES (3 dof) of the final pose against the composed increments' covariance."""

    distance_m: float
    final_error_m: float
    drift_pct: float
    rms_drift_pct: float
    nees_final: float


def _compose(x: np.ndarray, P: np.ndarray, d: np.ndarray, Q: np.ndarray):
    """SLAM's predict: pose ⊕ increment with the first-order covariance."""
    c, s = math.cos(x[2]), math.sin(x[2])
    Fx = np.array([[1, 0, -s * d[0] - c * d[1]], [0, 1, c * d[0] - s * d[1]], [0, 0, 1.0]])
    Fu = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    yaw = x[2] + d[2]
    x_new = np.array(
        [
            x[0] + c * d[0] - s * d[1],
            x[1] + s * d[0] + c * d[1],
            math.atan2(math.sin(yaw), math.cos(yaw)),
        ]
    )
    return x_new, Fx @ P @ Fx.T + Fu @ Q @ Fu.T


def dead_reckoning_drift(
    config: NavSuiteConfig,
    states: list[VehicleState],
    rng: np.random.Generator,
    cut_every: int = 2,
) -> DriftResult:
    """Run ``config``'s suite over ``states``; cut an odometry increment every
    ``cut_every`` states (the runner cuts at sonar pings), compose them from the true
    start pose and measure the drift (see :class:`DriftResult`)."""
    if len(states) < 2:
        raise ValueError(f"dead_reckoning_drift needs at least 2 states, got {len(states)}")
    s0 = states[0]
    pose0 = np.array([s0.position[0], s0.position[1], float(s0.euler[2])])
    nav = NavSuite(config, rng, t0=s0.t, initial_velocity_body=s0.velocity_body)
    x, P = pose0.copy(), np.zeros((3, 3))
    dist, errs, dists = 0.0, [], []
    prev = np.asarray(s0.position[:2], float)
    for k, st in enumerate(states):
        nav.poll(st)
        p = np.asarray(st.position[:2], float)
        dist += float(np.hypot(*(p - prev)))
        prev = p
        if k and (k % cut_every == 0 or k == len(states) - 1):
            inc = nav.odometry(st.t)
            x, P = _compose(x, P, inc.delta, inc.cov)
            errs.append(float(np.hypot(*(x[:2] - p))))
            dists.append(dist)
    st = states[-1]
    e = np.array([st.position[0] - x[0], st.position[1] - x[1], 0.0])
    dyaw = float(st.euler[2]) - x[2]
    e[2] = math.atan2(math.sin(dyaw), math.cos(dyaw))
    nees = float(e @ np.linalg.solve(P + np.eye(3) * 1e-12, e))
    errs_a, dists_a = np.array(errs), np.array(dists)
    keep = dists_a > 0.1 * dist
    return DriftResult(
        distance_m=dist,
        final_error_m=errs[-1],
        drift_pct=100.0 * errs[-1] / dist,
        rms_drift_pct=100.0 * float(np.sqrt(np.mean((errs_a[keep] / dists_a[keep]) ** 2))),
        nees_final=nees,
    )
