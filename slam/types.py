"""Plain data passed into the SLAM side. No simulator types: real recordings build these too.

Frames and units (see ARCHITECTURE.md): 2-D world frame x east, y north; body frame x
forward, y port; bearings counter-clockwise from body x, radians, wrapped to (-pi, pi].
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def wrap_angle(a):
    """Wrap angle(s) in radians to (-pi, pi]."""
    a = np.asarray(a, dtype=float)
    w = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    # mod maps +pi to -pi; the convention keeps +pi.
    return np.where(w == -np.pi, np.pi, w) if w.ndim else (np.pi if w == -np.pi else float(w))


@dataclass(frozen=True)
class Odometry:
    """Dead-reckoned pose increment over one interval, expressed in the body frame at the
    start of the interval.

    delta : (3,) ``[dx, dy, dphi]`` in m, m, rad.
    cov   : (3, 3) covariance of ``delta`` (m², rad²).
    t     : time at the end of the interval, s.
    """

    delta: np.ndarray
    cov: np.ndarray
    t: float = 0.0

    def __post_init__(self) -> None:
        d = np.asarray(self.delta, dtype=float).reshape(-1)
        c = np.asarray(self.cov, dtype=float)
        if d.shape != (3,):
            raise ValueError(f"Odometry.delta must have shape (3,), got {d.shape}")
        if c.shape != (3, 3):
            raise ValueError(f"Odometry.cov must have shape (3, 3), got {c.shape}")
        if not (np.all(np.isfinite(d)) and np.all(np.isfinite(c))):
            raise ValueError(f"Odometry must be finite, got delta={d}, cov={c.tolist()}")
        object.__setattr__(self, "delta", d)
        object.__setattr__(self, "cov", c)


@dataclass(frozen=True)
class RangeBearing:
    """One landmark observation in the vehicle body frame.

    z     : (2,) ``[range m, bearing rad]``.
    R     : (2, 2) measurement covariance.
    t     : time of the observation, s.
    label : optional identity (known data association, e.g. simulator object id); None
            when unknown, which is the normal case for real data.
    """

    z: np.ndarray
    R: np.ndarray
    t: float = 0.0
    label: int | None = None
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self) -> None:
        z = np.asarray(self.z, dtype=float).reshape(-1)
        R = np.asarray(self.R, dtype=float)
        if z.shape != (2,):
            raise ValueError(f"RangeBearing.z must have shape (2,), got {z.shape}")
        if R.shape != (2, 2):
            raise ValueError(f"RangeBearing.R must have shape (2, 2), got {R.shape}")
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(R))):
            raise ValueError(f"RangeBearing must be finite, got z={z}, R={R.tolist()}")
        if z[0] <= 0.0:
            raise ValueError(f"RangeBearing.z range must be > 0 m, got {z[0]}")
        object.__setattr__(self, "z", z)
        object.__setattr__(self, "R", R)
