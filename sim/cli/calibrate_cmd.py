"""``undersea calibrate REAL --preset deepeye680d --out my_sonar.toml``: fit the sonar's
realism levels so that a simulated survey at the recording's altitude and range matches
the recording's statistics (docs/realism.md), and write them as a preset file.

Fit on ``--pings`` (default the first half), report on ``--report-pings`` (default the
second half). The TOML is written only after a converged fit (temporary file + rename).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from sim.atomic import atomic_write
from sim.cli.calibrate_sides import (
    SideFit,
    leg_altitudes,
    model_first_return,
    report_fits,
    side_values,
    survey_geometry,
    toml_override_lines,
)
from sim.cli.realism_io import first_return_for, load_any, parse_pings
from slam.realism.calibration import CalibrationError, CalibrationResult, Parameter, calibrate
from slam.realism.compare import compare, format_table, json_ready
from slam.realism.statistics import RealismConfig, waterfall_statistics
from slam.realism.synthetic import FULL_SCALE, PARAMETERS, StatisticalSideScan

#: the ray-cast model's free parameters (sim.sonar.effects.RealismConfig fields).
RAYCAST_PARAMETERS = (
    Parameter("receiver_gain_db", -30.0, 20.0, 0.0),  # gain → saturation, headroom
    Parameter("texture_db", 0.0, 10.0, 1.5),  # sediment texture → speckle CV, dB std
    Parameter("texture_scale_m", 0.2, 5.0, 0.8, log=True),  # its size → texture across patches
    Parameter("range_cell_m", 0.005, 0.2, 0.02, log=True),  # speckle correlation in range
    Parameter("volume_sv_db", -120.0, -40.0, -80.0),  # reverberation → water column level
)

#: the display model's (recreational units that store the log-compressed 8-bit display):
#: the display mapping replaces the receiver gain, the speckle and texture stay.
DISPLAY_PARAMETERS = (
    Parameter("display_floor_db", 60.0, 180.0, 123.0),  # display black level → brightness
    Parameter("dynamic_range_db", 5.0, 120.0, 50.0),  # display contrast → CV, dB std
    Parameter("texture_db", 0.0, 10.0, 1.5),
    Parameter("range_cell_m", 0.005, 0.5, 0.02, log=True),
    Parameter("volume_sv_db", -120.0, -30.0, -80.0),
)
DISPLAY_BITS = 8

#: optional free parameters of the ray-cast models: ``--low-grazing`` (the sediment law's
#: knee below which it falls faster than Lambert; fitted with the far-range level) and
#: ``--fit-noise`` (the receiver's noise before TVG, beside the volume reverberation),
#: ``--micro-slope`` (the seabed's sub-mesh relief).
KNEE_PARAMETER = Parameter("low_grazing_knee_deg", 2.0, 45.0, 15.0)
NOISE_PARAMETER = Parameter("noise_level_db", -20.0, 100.0, 40.0)
SLOPE_PARAMETER = Parameter("micro_slope_deg", 0.0, 8.0, 1.0)
#: ``--fit-tvg``: the recorder's TVG spreading exponent n (r^n; 3 = "30 log R").
TVG_PARAMETER = Parameter("tvg_exponent", 2.0, 5.0, 4.0)
#: ``--video-filter``: the receiver's video filter (sim.sonar.transmit_pulse; the preset
#: must switch it on, its value is the start).
VIDEO_PARAMETER = Parameter("video_filter_m", 0.002, 0.2, 0.02, log=True)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("real", help="real recording: .xtf, .npy/.npz or image waterfall")
    parser.add_argument(
        "--preset",
        default="deepeye680d_realistic",
        help="side-scan preset: built-in name or preset file (e.g. an earlier calibration); "
        "the fit starts from its values",
    )
    parser.add_argument("--out", required=True, help="preset TOML to write")
    parser.add_argument(
        "--model",
        choices=("raycast", "raycast-display", "statistical"),
        default="raycast",
        help="raycast: the simulator's sonar over a flat seabed (default); "
        "raycast-display: the same, stored as an 8-bit log-compressed display "
        "(recreational units such as Humminbird); statistical: the fast statistical "
        "waterfall (slam.realism.synthetic; its values are not simulator fields)",
    )
    parser.add_argument(
        "--gain",
        choices=("solve", "fit"),
        default="solve",
        help="raycast model: solve the receiver gain from the recording's clipped fraction "
        "at every model run (default; needs a recording that clips) or fit it as a "
        "parameter",
    )
    parser.add_argument("--scale", choices=("intensity", "amplitude"), default=None)
    parser.add_argument(
        "--bottom",
        choices=("detect", "altitude"),
        default="detect",
        help="REAL's first bottom return: detected (default) or from its altitude",
    )
    parser.add_argument("--pings", default="first", help="pings to fit (A:B, first, second, all)")
    parser.add_argument("--report-pings", default="second", help="pings to report on too")
    parser.add_argument("--altitude", type=float, default=None, help="m (default: recording)")
    parser.add_argument("--max-range", type=float, default=None, help="m (default: recording)")
    parser.add_argument(
        "--altitude-track",
        choices=("legs", "median"),
        default="legs",
        help="legs (default): each simulated leg flies the median altitude of its share of "
        "the recording's pings (consecutive chunks), so the survey sees the recording's "
        "range of grazing angles; median: every leg at the median altitude",
    )
    parser.add_argument(
        "--low-grazing",
        action="store_true",
        help="ray-cast models: also fit the sediment law's low-grazing knee "
        "(low_grazing_knee_deg) with the far-range seabed level as a target (within 2 dB)",
    )
    parser.add_argument(
        "--fit-noise",
        action="store_true",
        help="ray-cast models: also fit the receiver noise before TVG (noise_level_db)",
    )
    parser.add_argument(
        "--fit-tvg",
        action="store_true",
        help="ray-cast models: also fit the recorder's TVG exponent (tvg_exponent, r^n) "
        "with the far-range seabed level as a target (within 2 dB); with tvg_reference "
        "= bottom in the --preset file the TVG is held at its bottom-return value over "
        "the water column",
    )
    parser.add_argument(
        "--micro-slope",
        action="store_true",
        help="ray-cast models: also fit the seabed's micro-relief (micro_slope_deg)",
    )
    parser.add_argument(
        "--video-filter",
        action="store_true",
        help="ray-cast models: also fit the receiver's video filter (video_filter_m; the "
        "preset sets its start)",
    )
    parser.add_argument(
        "--per-side",
        action="store_true",
        help="fit port and starboard each on their own (one transducer and receive channel "
        "per side): the preset gets [sonar.overrides.port] and [sonar.overrides.starboard]",
    )
    parser.add_argument(
        "--fix",
        default="",
        help="comma-separated free parameters to hold at the preset's values",
    )
    parser.add_argument("--sim-pings", type=int, default=128, help="pings per simulated run")
    parser.add_argument(
        "--sim-legs",
        type=int,
        default=8,
        help="short legs 30 m apart the simulated pings are split into (so port and "
        "starboard see the same sediment mix; pings/legs a multiple of 16)",
    )
    parser.add_argument("--max-evaluations", type=int, default=60, help="model runs at most")
    parser.add_argument(
        "--good-enough",
        type=float,
        default=0.8,
        help="stop at the first model run with every statistic within this many "
        "tolerances (default 0.8; 0 = search until the budget or the optimizer stops)",
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--save-sim",
        default=None,
        help="also write the calibrated model's waterfall (.npy, linear intensity) for "
        "`undersea realism SIM REAL --plot`",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def _unfixed(args, free: tuple[Parameter, ...]) -> tuple[Parameter, ...]:
    """The free parameters without those ``--fix`` holds at the preset's values."""
    fixed = {n for n in args.fix.split(",") if n}
    unknown = fixed - {p.name for p in free}
    if unknown:
        raise ValueError(f"--fix {sorted(unknown)}: not free parameters of --model {args.model}")
    return tuple(p for p in free if p.name not in fixed)


def _model(args, altitude: float, max_range: float, samples: int, target, legs=(), side=None):
    """(simulate callable, parameters, statistics config of the model's images); ``side``:
    a per-side fit's side (the solved gain then clips that side's fraction on both)."""
    if args.model == "statistical":
        model = StatisticalSideScan(
            pings=max(args.sim_pings, 32),
            samples_per_side=samples,
            water_column_fraction=min(max(altitude / max_range, 0.05), 0.8),
            seed=args.seed,
        )
        return model, _unfixed(args, PARAMETERS), RealismConfig(full_scale=FULL_SCALE)
    from sim.realism.survey import (  # mujoco only for this model
        GainProfiledSurvey,
        RaycastSurvey,
        SurveySpec,
    )

    survey = RaycastSurvey(
        SurveySpec(
            altitude,
            max_range,
            samples,
            pings=args.sim_pings,
            preset=args.preset,
            seed=args.seed,
            segments=args.sim_legs,
            display_bits=DISPLAY_BITS if args.model == "raycast-display" else 0,
            leg_altitudes_m=legs,
        )
    )
    free = DISPLAY_PARAMETERS if args.model == "raycast-display" else RAYCAST_PARAMETERS
    free = (
        free
        + (KNEE_PARAMETER,) * args.low_grazing
        + (NOISE_PARAMETER,) * args.fit_noise
        + (SLOPE_PARAMETER,) * args.micro_slope
        + (TVG_PARAMETER,) * args.fit_tvg
        + (VIDEO_PARAMETER,) * args.video_filter
    )
    free = _unfixed(args, free)
    model = survey
    if args.model == "raycast" and args.gain == "solve":
        sat = (target.port.saturation, target.starboard.saturation)
        if side is not None:
            sat = (target.sides()[side].saturation,) * 2
        model = GainProfiledSurvey(survey, sat)
        free = tuple(p for p in free if p.name != "receiver_gain_db")
    params = tuple(
        replace(p, initial=min(max(survey.start_value(p.name), p.lo), p.hi)) for p in free
    )
    return model, params, RealismConfig(full_scale=survey.full_scale({}))


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else '"nan"'
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return json.dumps(str(v))


def preset_toml(args, values, before, after, meta, base=None) -> str:
    """The preset file: [sonar] preset + overrides (scenario-ready), [calibration] record.
    ``values``: {None: fitted values} or {side: that side's values} (``--per-side``);
    ``base``: (built-in preset, its file's overrides) when ``--preset`` was a preset file
    (the fitted values go over them)."""
    name, kept = base or (args.preset, {})
    fitted = set().union(*(v.keys() for v in values.values()))
    lines = [
        f"# Sonar preset calibrated by `undersea calibrate` to {meta['recording']}.",
        "# In a scenario: [[vehicles.sonars]] preset = <sonar.preset>, overrides = <sonar.overrides>",
    ]
    if args.model == "statistical":
        lines += [
            "# model = statistical: these values are NOT simulator fields",
            "[statistical_model]",
        ]
    else:
        lines += ["[sonar]", f"preset = {_toml_value(name)}", "", "[sonar.overrides]"]
        lines += [f"{k} = {_toml_value(v)}" for k, v in kept.items() if k not in fitted]
    table = "statistical_model" if args.model == "statistical" else "sonar.overrides"
    lines += toml_override_lines(values, _toml_value, table)
    lines += ["", "[calibration]"]
    lines += [f"{k} = {_toml_value(v)}" for k, v in meta.items()]
    for when, st in (("before", before), ("after", after)):
        for side, s in st.sides().items():
            lines += ["", f"[calibration.{when}.{side}]"]
            lines += [f"{k} = {_toml_value(v)}" for k, v in s.scalars().items()]
    return "\n".join(lines) + "\n"


def _fit(args, geometry, samples: int, target, side=None) -> SideFit:
    """One calibration (``side`` None: both sides; else that side alone), the solved gain
    added to the values."""
    altitude, max_range, legs = geometry
    simulate, params, model_cfg = _model(args, altitude, max_range, samples, target, legs, side)
    try:
        result = calibrate(
            simulate,
            target,
            params,
            max_evaluations=args.max_evaluations,
            good_enough=args.good_enough,
            model_config=model_cfg,
            fit_tile_texture=args.model != "statistical",
            fit_far_range=(args.low_grazing or args.fit_tvg) and args.model != "statistical",
            model_first_return=(
                model_first_return(simulate.spec)
                if args.bottom == "altitude" and args.model != "statistical"
                else None
            ),
            sides=(side,) if side else ("port", "starboard"),
        )
    except CalibrationError as exc:
        if exc.best is not None:  # the best point's report uses its solved gain too
            exc.best = _with_solved_gain(simulate, exc.best)
        return SideFit(side, simulate, model_cfg, exc)
    return SideFit(side, simulate, model_cfg, _with_solved_gain(simulate, result))


def _with_solved_gain(simulate, result: CalibrationResult) -> CalibrationResult:
    """``result`` with the gain solved at its values (the solved gain belongs to the preset
    too); unchanged when the model does not solve the gain."""
    if not hasattr(simulate, "gain_for"):
        return result
    gain = simulate.gain_for(result.values)
    return replace(result, values={**result.values, "receiver_gain_db": gain})


def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    try:
        rec = load_any(args.real, args.scale)
        fit_sl = parse_pings(args.pings, rec.n_pings)
        rep_sl = parse_pings(args.report_pings, rec.n_pings)
        fit_rec = rec.pings(fit_sl.start, fit_sl.stop)
        rep_rec = rec.pings(rep_sl.start, rep_sl.stop)
        try:
            target = waterfall_statistics(
                fit_rec.intensity, first_return=first_return_for(fit_rec, args.bottom)
            )
            report = waterfall_statistics(
                rep_rec.intensity, first_return=first_return_for(rep_rec, args.bottom)
            )
        except ValueError as exc:
            raise ValueError(f"REAL {args.real}: {exc}") from exc
        altitude, max_range = survey_geometry(fit_rec, args.altitude, args.max_range)
        legs = leg_altitudes(fit_rec, args.sim_legs, max_range, args.altitude_track)
        samples = rec.intensity.shape[1] // 2
        fits = [
            _fit(args, (altitude, max_range, legs), samples, target, side)
            for side in (("port", "starboard") if args.per_side else (None,))
        ]
        failed = [f for f in fits if not isinstance(f.outcome, CalibrationResult)]
        if any(f.best is None for f in failed):
            raise failed[0].outcome
        values = side_values(fits)
        rep_alt, held_out, after_st, before_st, img = report_fits(args, fits, rep_rec)
        if failed:
            for side, vals in values.items():
                vs = ", ".join(f"{k} = {v:.4g}" for k, v in vals.items())
                print(f"best found{f' ({side})' if side else ''}: {vs}", file=sys.stderr)
            print(format_table(compare(after_st, target)), file=sys.stderr)
            print(f"report pings {rep_sl.start}:{rep_sl.stop} at {rep_alt:.2f} m:", file=sys.stderr)
            print(format_table(compare(held_out, report)), file=sys.stderr)
            msg = "; ".join(f"{f.side or 'both sides'}: {f.outcome}" for f in failed)
            raise CalibrationError(msg)
    except (ValueError, CalibrationError) as exc:
        best = getattr(exc, "best", None)
        if best is not None:  # show where the fit got to, on stderr
            vals = ", ".join(f"{k} = {v:.4g}" for k, v in best.values.items())
            print(f"best found: {vals}", file=sys.stderr)
            print(format_table(compare(best.after, target)), file=sys.stderr)
        print(f"undersea calibrate: {exc}; nothing written", file=sys.stderr)
        return 2
    results = [f.outcome for f in fits]
    meta = {
        "recording": str(args.real),
        "fit_pings": [fit_sl.start, fit_sl.stop],
        "report_pings": [rep_sl.start, rep_sl.stop],
        "model": args.model,
        "per_side": bool(args.per_side),
        "altitude_m": altitude,
        "leg_altitudes_m": list(legs),
        "max_range_m": max_range,
        "samples_per_side": samples,
        "sim_pings": args.sim_pings,
        "sim_legs": args.sim_legs,
        "seed": args.seed,
        "evaluations": sum(r.evaluations for r in results),
        "loss_before": float(np.mean([r.initial_loss for r in results])),
        "loss_after": float(np.mean([r.loss for r in results])),
    }
    sim0 = fits[0].simulate
    base = getattr(sim0, "base", None)
    base = (base, sim0.base_overrides) if base else None
    atomic_write(out, preset_toml(args, values, before_st, after_st, meta, base).encode())
    if args.save_sim:
        np.save(args.save_sim, img)
    before, after = compare(before_st, target), compare(after_st, target)
    held = compare(held_out, report)
    if args.json:
        doc = {
            "values": values if args.per_side else values[None],
            "initial_values": results[0].initial_values,
            "calibration": meta,
            "before": before.to_dict(),
            "after": after.to_dict(),
            "report_pings": held.to_dict(),
            "out": str(out),
        }
        print(json.dumps(json_ready(doc), allow_nan=False, indent=1))
        return 0
    print(
        f"REAL {args.real}: fit on pings {fit_sl.start}:{fit_sl.stop}, model {args.model}, "
        f"altitude {altitude:.2f} m, range {max_range:.2f} m, {meta['evaluations']} runs"
    )
    for side, vals in values.items():
        vs = ", ".join(f"{k} = {v:.4g}" for k, v in vals.items())
        print(f"fitted{f' ({side})' if side else ''}: {vs}")
    for title, c in (
        ("BEFORE (preset values) vs REAL fit pings", before),
        ("AFTER (calibrated) vs REAL fit pings", after),
        (
            f"AFTER vs REAL report pings {rep_sl.start}:{rep_sl.stop} (simulated at their "
            f"altitude, {rep_alt:.2f} m)",
            held,
        ),
    ):
        print(f"\n== {title}\n" + format_table(c))
    print(f"\nwrote {out}")
    return 0
