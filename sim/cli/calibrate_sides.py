"""Per-side calibration for ``undersea calibrate --per-side``: a side-scan has one
transducer and one receive channel per side, so port and starboard are fitted each on
their own (``slam.realism.calibration.calibrate(..., sides=(side,))``) and the preset
holds each side's values (``[sonar.overrides.port]``, ``[sonar.overrides.starboard]``).

A fit is a ``SideFit``: the side (None = one fit for both sides), the model, the
statistics config of its images, and the result (or the CalibrationError of a fit that
did not converge, whose ``best`` is the best point found). Also here: the survey geometry
read from the recording and the held-out report of the fitted values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from slam.realism.bottom import first_bottom_return
from slam.realism.calibration import SIDES, CalibrationError, CalibrationResult
from slam.realism.statistics import (
    RealismConfig,
    WaterfallStatistics,
    split_sides,
    waterfall_statistics,
)


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


def survey_geometry(rec, altitude: float | None, max_range: float | None) -> tuple[float, float]:
    """(altitude m, max slant range m) from the flags, else from the recording (nav
    altitude median; else the median first bottom return × range per sample)."""
    rng_m = max_range or rec.slant_range_m
    if not rng_m or not math.isfinite(rng_m) or rng_m <= 0:
        raise ValueError(f"{rec.source}: slant range unknown: give --max-range (m)")
    if altitude is None and rec.altitude_m is not None:
        a = rec.altitude_m[rec.altitude_m > 0]
        altitude = float(np.median(a)) if a.size else None
    if altitude is None:
        s = rec.intensity.shape[1] // 2
        first = [first_bottom_return(side).first_return for side in split_sides(rec.intensity)]
        altitude = float(np.nanmedian(np.concatenate(first))) * rng_m / s
    if not 0 < altitude < rng_m:
        raise ValueError(f"altitude {altitude:.2f} m is not inside the range (0, {rng_m:g}) m")
    return float(altitude), float(rng_m)


def leg_altitudes(rec, legs: int, max_range: float, mode: str) -> tuple[float, ...]:
    """Per-leg altitudes (m) flying the recording's altitude track: the median positive
    nav altitude of each of ``legs`` consecutive chunks of its pings (clipped to
    [0.5, 0.95·range]); () for ``mode`` "median" or a recording without altitude."""
    if mode != "legs" or rec.altitude_m is None or legs < 2:
        return ()
    out = []
    for chunk in np.array_split(np.asarray(rec.altitude_m, float), legs):
        ok = chunk[chunk > 0]
        if ok.size == 0:
            return ()
        out.append(float(np.clip(np.median(ok), 0.5, 0.95 * max_range)))
    return tuple(out)


def held_out(args, simulate, values, rep_rec, model_cfg):
    """(altitude m, statistics) of the calibrated preset with the report pings: the
    ray-cast survey flown again at the report pings' own altitude with the fitted values
    (the gain as written, not solved again); the statistical model's image as fitted."""
    survey = getattr(simulate, "survey", simulate)
    spec = getattr(survey, "spec", None)
    if spec is None:
        return float("nan"), waterfall_statistics(simulate(values), model_cfg)
    altitude, _ = survey_geometry(rep_rec, args.altitude, args.max_range)
    legs = leg_altitudes(rep_rec, spec.segments, spec.max_range_m, args.altitude_track)
    again = type(survey)(replace(spec, altitude_m=altitude, leg_altitudes_m=legs))
    img = again(values)
    fr = None
    if args.bottom == "altitude":  # as in the fit: the survey's known altitude
        fr = model_first_return(again.spec)
    return altitude, waterfall_statistics(img, model_cfg, first_return=fr)


def model_first_return(spec) -> np.ndarray:
    """(pings,) first-return sample of the survey's flat seabed: each leg's altitude over
    the range per sample."""
    per_leg = spec.pings // spec.segments
    alt = np.repeat([spec.leg_altitude(k) for k in range(spec.segments)], per_leg)
    return alt / (spec.max_range_m / spec.samples_per_side)


def report_fits(args, fits, rep_rec):
    """(altitude m of the report pings, their statistics per side combined, the fit
    pings' statistics after, before, the stitched fit image) of the fits' best points."""
    held, after, imgs = {}, {}, {}
    alt = float("nan")
    for f in fits:
        best, key = f.best, f.side or "both"
        after[key] = best.after
        alt, held[key] = held_out(args, f.simulate, best.values, rep_rec, f.model_config)
        if args.save_sim:
            imgs[key] = np.asarray(f.simulate(best.values), dtype=np.float32)
    img = stitch(imgs) if imgs else None
    return alt, combine(held), combine(after), fits[0].best.before, img
