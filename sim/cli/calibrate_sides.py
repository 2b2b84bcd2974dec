"""Per-side calibration for ``undersea calibrate --per-side``: a side-scan has one
transducer and one receive channel per side, so port and starboard are fitted each on
their own (``slam.realism.calibration.calibrate(..., sides=(side,))``) and the preset
holds each side's values (``[sonar.overrides.port]``, ``[sonar.overrides.starboard]``).

A fit is a ``SideFit``: the side (None = one fit for both sides), the model, the
statistics config of its images, and the result (or the CalibrationError of a fit that
did not converge, whose ``best`` is the best point found).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from slam.realism.calibration import SIDES, CalibrationError, CalibrationResult
from slam.realism.statistics import RealismConfig, WaterfallStatistics


@dataclass(frozen=True)
class SideFit:
    """One calibration: ``side`` None for both sides at once."""

    side: str | None
    simulate: Any
    model_config: RealismConfig
    outcome: CalibrationResult | CalibrationError

    @property
    def best(self) -> CalibrationResult | None:
        o = self.outcome
        return o if isinstance(o, CalibrationResult) else o.best


def combine(per_side: dict[str, WaterfallStatistics]) -> WaterfallStatistics:
    """One WaterfallStatistics from per-side runs: each side's statistics from its own
    run ({"port": ..., "starboard": ...}; a single run under any key is returned as is)."""
    if len(per_side) == 1:
        return next(iter(per_side.values()))
    return WaterfallStatistics(
        port=per_side["port"].port, starboard=per_side["starboard"].starboard
    )


def stitch(per_side: dict[str, np.ndarray]) -> np.ndarray:
    """(P, 2S) waterfall whose port half is the port run's and starboard half the
    starboard run's (a single run as is)."""
    if len(per_side) == 1:
        return next(iter(per_side.values()))
    port, stbd = per_side["port"], per_side["starboard"]
    s = port.shape[1] // 2
    return np.concatenate([port[:, :s], stbd[:, s:]], axis=1)


def side_values(fits: list[SideFit]) -> dict[str | None, dict[str, float]]:
    """{side: fitted values} of the fits that have a result (best point when failed)."""
    return {f.side: dict(f.best.values) for f in fits if f.best is not None}


def toml_override_lines(
    values: dict[str | None, dict[str, float]], fmt, table: str = "sonar.overrides"
) -> list[str]:
    """The fitted values as preset lines: under the current table (``table``) for one
    fit, else one ``[<table>.<side>]`` table per side (``fmt`` formats a TOML value)."""
    if set(values) == {None}:
        return [f"{k} = {fmt(float(v))}" for k, v in values[None].items()]
    lines: list[str] = []
    for side in SIDES:
        lines += ["", f"[{table}.{side}]"]
        lines += [f"{k} = {fmt(float(v))}" for k, v in values[side].items()]
    return lines
