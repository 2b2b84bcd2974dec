"""PID controller with output saturation and anti-windup.

Textbook form (Åström & Murray, *Feedback Systems*, §11.3; Åström & Hägglund,
*Advanced PID Control*, §3.5):

    v = u_ff + kp e + I + kd ė,     u = clip(v, u_min, u_max),

with the derivative taken on the measurement (the caller passes ``error_rate``, e.g.
``-measured_rate`` for a constant set-point, to avoid derivative kick). Anti-windup by
conditional integration ("clamping"): dI/dt = ki e, except while the output is
saturated and the error pushes it further into saturation; and I itself is kept inside
the output range. (Back-calculation, dI/dt = ki e + (u − v)/T_t, was tried first and
rejected: with a large kp·e beyond the limit — a heading error of 90° — it drives I to
u_max − kp e, far negative, and the loop undershoots once the error shrinks.)
Written here (not python-control / simple-pid) because it is a dozen lines and runs
in the control loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["PID", "PIDGains"]


@dataclass(frozen=True)
class PIDGains:
    """kp (output/error), ki (output/(error·s)), kd (output·s/error) >= 0; output limits
    u_min < u_max (may be infinite); anti_windup False disables the clamping (for
    comparison)."""

    kp: float
    ki: float = 0.0
    kd: float = 0.0
    u_min: float = -math.inf
    u_max: float = math.inf
    anti_windup: bool = True

    def __post_init__(self) -> None:
        for n in ("kp", "ki", "kd"):
            v = getattr(self, n)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"PIDGains.{n} must be a finite number >= 0, got {v!r}")
        if math.isnan(self.u_min) or math.isnan(self.u_max) or not self.u_min < self.u_max:
            raise ValueError(
                f"PIDGains needs u_min < u_max, got u_min={self.u_min!r}, u_max={self.u_max!r}"
            )

    def scaled(self, factor: float) -> PIDGains:
        """Same controller with all gains and limits multiplied by ``factor`` > 0."""
        if not factor > 0:
            raise ValueError(f"factor must be > 0, got {factor!r}")
        return PIDGains(
            self.kp * factor,
            self.ki * factor,
            self.kd * factor,
            self.u_min * factor,
            self.u_max * factor,
            self.anti_windup,
        )


class PID:
    """Stateful PID; ``update(error, dt, error_rate=None, feedforward=0.0) -> u``."""

    def __init__(self, gains: PIDGains) -> None:
        self.gains = gains
        self.integral = 0.0
        self._prev_error: float | None = None
        self.saturated = False

    def reset(self, integral: float = 0.0) -> None:
        self.integral = float(integral)
        self._prev_error = None
        self.saturated = False

    def update(
        self,
        error: float,
        dt: float,
        error_rate: float | None = None,
        feedforward: float = 0.0,
    ) -> float:
        g = self.gains
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"PID.update dt must be > 0 s, got {dt!r}")
        if not math.isfinite(error):
            raise ValueError(f"PID.update error must be finite, got {error!r}")
        if error_rate is None:
            error_rate = 0.0 if self._prev_error is None else (error - self._prev_error) / dt
        self._prev_error = error
        v = feedforward + g.kp * error + self.integral + g.kd * error_rate
        u = min(max(v, g.u_min), g.u_max)
        self.saturated = u != v
        if g.ki > 0:
            di = g.ki * error * dt
            if g.anti_windup:
                if (v > g.u_max and di > 0) or (v < g.u_min and di < 0):
                    di = 0.0
                self.integral = min(max(self.integral + di, g.u_min), g.u_max)
            else:
                self.integral += di
        return u
