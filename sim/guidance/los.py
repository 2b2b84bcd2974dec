"""Lookahead-based line-of-sight guidance for straight-line path following.

Fossen (2011), *Handbook of Marine Craft Hydrodynamics and Motion Control*, §10.3.2
(eqs. 10.56–10.62 and 10.73): for the leg from waypoint p_k to p_{k+1} with path angle
π_p = atan2(y_{k+1} − y_k, x_{k+1} − x_k),

    along-track  s = (x − x_k) cos π_p + (y − y_k) sin π_p
    cross-track  e = −(x − x_k) sin π_p + (y − y_k) cos π_p
    desired course  χ_d = π_p − atan(e / Δ)            (Δ > 0: lookahead distance, m)

In our world frame (x east, y north, angles counter-clockwise from east), ``e > 0``
means the vehicle is to the LEFT (port side) of the path direction; χ_d then turns it
right, towards the path. Integral LOS (Børhaug, Pavlov & Pettersen 2008; Fossen eq.
10.84) adds an integral state against currents:  χ_d = π_p − atan((e + σ y_int)/Δ),
ẏ_int = Δ e / (Δ² + (e + σ y_int)²). Pure functions: no library implements this.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["LOSResult", "los_guidance", "wrap"]


def wrap(a: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    w = (a + math.pi) % (2.0 * math.pi) - math.pi
    return math.pi if w == -math.pi else w


@dataclass(frozen=True)
class LOSResult:
    """course: desired course χ_d, rad (CCW from east). cross_track e, m (+ = left of the
    path). along_track s, m from the leg start. path_angle π_p, rad. leg_length, m."""

    course: float
    cross_track: float
    along_track: float
    path_angle: float
    leg_length: float

    @property
    def remaining(self) -> float:
        """Along-track distance still to go to the leg end, m (negative once past it)."""
        return self.leg_length - self.along_track


def los_guidance(
    position_xy, wp_from, wp_to, lookahead: float, integral: float = 0.0, sigma: float = 0.0
) -> LOSResult:
    """Lookahead LOS for the leg ``wp_from -> wp_to`` (world xy, m) at ``position_xy``.

    ``integral`` is the integral-LOS state y_int and ``sigma`` its gain (0: plain LOS).
    """
    if not (math.isfinite(lookahead) and lookahead > 0):
        raise ValueError(f"lookahead must be > 0 m, got {lookahead!r}")
    p = np.asarray(position_xy, float)[:2]
    a = np.asarray(wp_from, float)[:2]
    b = np.asarray(wp_to, float)[:2]
    d = b - a
    length = float(math.hypot(d[0], d[1]))
    if length < 1e-9:
        raise ValueError(f"leg from {a.tolist()} to {b.tolist()} has zero length")
    pi_p = math.atan2(d[1], d[0])
    c, s = math.cos(pi_p), math.sin(pi_p)
    r = p - a
    along = float(r[0] * c + r[1] * s)
    e = float(-r[0] * s + r[1] * c)
    chi = wrap(pi_p - math.atan((e + sigma * integral) / lookahead))
    return LOSResult(
        course=chi, cross_track=e, along_track=along, path_angle=pi_p, leg_length=length
    )


def integral_los_rate(cross_track: float, integral: float, lookahead: float, sigma: float) -> float:
    """ẏ_int of integral LOS (Fossen eq. 10.84b): Δ e / (Δ² + (e + σ y_int)²)."""
    return lookahead * cross_track / (lookahead**2 + (cross_track + sigma * integral) ** 2)
