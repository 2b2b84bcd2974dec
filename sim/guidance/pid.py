"""PID controller with output saturation and back-calculation anti-windup.

Textbook form (Åström & Murray, *Feedback Systems*, §11.3, and Åström & Hägglund,
*Advanced PID Control*, §3.5):

    v = u_ff + kp e + I + kd ė,     u = clip(v, u_min, u_max),
    dI/dt = ki e + (u - v) / T_t,

with the derivative taken on the measurement (the caller passes ``error_rate``, e.g.
``-measured_rate`` for a constant set-point, to avoid derivative kick) and the tracking
time ``T_t`` = √(T_i T_d) for a PID, T_i for a PI (T_i = kp/ki, T_d = kd/kp). While the
output is saturated the integrator is driven back so that v stays near the limit, which
prevents integrator windup. Written here (not python-control / simple-pid) because it is
ten lines and must be allocation-free in the control loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["PID", "PIDGains"]


@dataclass(frozen=True)
class PIDGains:
    """kp (output/error), ki (output/(error·s)), kd (output·s/error) >= 0; output limits
    u_min < u_max (may be infinite); tracking_time T_t > 0 in s (None: the default above);
    anti_windup False disables back-calculation (for comparison)."""

    kp: float
    ki: float = 0.0
    kd: float = 0.0
    u_min: float = -math.inf
    u_max: float = math.inf
    tracking_time: float | None = None
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
        if self.tracking_time is not None and not (
            math.isfinite(self.tracking_time) and self.tracking_time > 0
        ):
            raise ValueError(
                f"PIDGains.tracking_time must be > 0 s or None, got {self.tracking_time!r}"
            )

    @property
    def tt(self) -> float:
        """The tracking time used, s."""
        if self.tracking_time is not None:
            return self.tracking_time
        if self.ki <= 0:
            return math.inf
        ti = self.kp / self.ki if self.kp > 0 else 1.0 / self.ki
        td = self.kd / self.kp if self.kp > 0 else 0.0
        return math.sqrt(ti * td) if td > 0 else ti

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
            self.tracking_time,
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
        di = g.ki * error
        if g.anti_windup and g.ki > 0:
            tt = g.tt
            # exact decay of the tracking term over dt keeps the update stable for dt > T_t
            di += (u - v) * (1.0 - math.exp(-dt / tt)) / dt
        self.integral += di * dt
        return u
