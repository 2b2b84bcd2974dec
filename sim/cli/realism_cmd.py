"""``undersea realism SIM REAL``: realism statistics of two side-scan waterfalls side by side
(definitions: docs/realism.md)."""

from __future__ import annotations

import argparse
import json
import sys


def add_arguments(parser: argparse.ArgumentParser) -> None:
    for name, what in (("sim", "simulated"), ("real", "real")):
        parser.add_argument(
            name,
            help=f"{what} waterfall: .xtf, .npy/.npz (linear intensity), image, "
            "recording.rrd or an `undersea run` directory",
        )
        parser.add_argument(
            f"--{name}-scale",
            choices=("intensity", "amplitude"),
            default=None,
            help=f"what the {what} file's values are (default: by type, see docs/realism.md)",
        )
        parser.add_argument(
            f"--{name}-bottom",
            choices=("detect", "altitude"),
            default="detect",
            help="first bottom return: detected (default) or from the recording's altitude",
        )
        parser.add_argument(
            f"--{name}-pings",
            default=None,
            help="pings to use: 'A:B', 'first' or 'second' half, 'all' (default)",
        )
    parser.add_argument("--plot", default=None, help="write a side-by-side figure (PNG)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def recording_summary(rec, stats) -> dict:
    return {
        "source": rec.source,
        "kind": rec.kind,
        "pings": rec.n_pings,
        "samples_per_side": rec.intensity.shape[1] // 2,
        "statistics": {side: s.scalars() for side, s in stats.sides().items()},
    }


def run(args: argparse.Namespace) -> int:
    # scipy.stats, cv2, scikit-image: imported here, not for `undersea realism --help`
    from sim.cli.realism_io import first_return_for, load_any, parse_pings
    from slam.realism.compare import compare, format_table, json_ready
    from slam.realism.statistics import waterfall_statistics

    try:
        recs, stats = {}, {}
        for name in ("sim", "real"):
            rec = load_any(getattr(args, name), getattr(args, f"{name}_scale"))
            sl = parse_pings(getattr(args, f"{name}_pings"), rec.n_pings)
            recs[name] = rec.pings(sl.start, sl.stop)
            try:
                bottom = first_return_for(recs[name], getattr(args, f"{name}_bottom"))
                stats[name] = waterfall_statistics(recs[name].intensity, first_return=bottom)
            except ValueError as exc:
                raise ValueError(f"{name.upper()} {getattr(args, name)}: {exc}") from exc
        comp = compare(stats["sim"], stats["real"])
    except ValueError as exc:
        print(f"undersea realism: {exc}", file=sys.stderr)
        return 2
    if args.plot:
        from sim.cli.realism_plot import plot_realism  # matplotlib only when plotting

        plot_realism(args.plot, recs["sim"], recs["real"], stats["sim"], stats["real"])
    if args.json:
        doc = {
            "sim": recording_summary(recs["sim"], stats["sim"]),
            "real": recording_summary(recs["real"], stats["real"]),
            "comparison": comp.to_dict(),
        }
        print(json.dumps(json_ready(doc), allow_nan=False, indent=1))
    else:
        print(f"SIM  {recs['sim'].source} ({recs['sim'].n_pings} pings)")
        print(f"REAL {recs['real'].source} ({recs['real'].n_pings} pings)\n")
        print(format_table(comp))
        if args.plot:
            print(f"\nfigure: {args.plot}")
    return 0
