"""Range checks of sonar config fields, shared by :mod:`sim.sonar.effects` and
:mod:`sim.sonar.transmit_pulse` (a ValueError names the field, its value and the range)."""

from __future__ import annotations

import math


def check_range(name: str, v: float, lo: float, hi: float) -> None:
    """``v`` must be a finite number in [lo, hi]."""
    if not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi):
        raise ValueError(f"{name} = {v!r} is outside the allowed range [{lo}, {hi}]")


def check_optional_range(name: str, v: float | None, lo: float, hi: float) -> None:
    """``v`` None (the field is off) or a finite number in [lo, hi]."""
    if v is not None:
        check_range(name, v, lo, hi)
