"""Evaluate the improved Otsu TSM and the four baselines on the real SDVD effigy tiles.

Prints, for the tune half, the held-out test half and the full set (see
``slam.frontend.segmentation.evaluation`` for the split and the scoring rules): per method
the effigy hit rate (positive tiles with a detected centroid inside the mask), PPV and
FPR of the detections (positives + negatives), detections per positive / negative tile,
negative tiles with any detection, and the summed confusion matrix [[TP FN] [FP TN]].

    python scripts/eval_sdvd.py [--data DIR] [--preset sdvd] [--filter sdvd|sdvd-contrast|sdvd-shadow|none]
                                [--detector sdvd-trusted|sdvd-rules|thesis] [--tol PX] [--json]

PPV counts at most one true positive per effigy (effigies hit / detections); the thesis's
fragment-counting PPV = TP / (TP + FP) is printed beside it as "PPVfrag". With
``--detector`` every method runs as the first stage of that detection chain
(``slam.frontend.segmentation.detector``: annotations masked, no-echo regions dropped,
fragments merged, the same second stage), instead of ``--preset``/``--filter``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from slam.frontend.segmentation import (  # noqa: E402
    METHODS,
    PRESETS,
    REGION_FILTERS,
    get_preset,
    get_region_filter,
)
from slam.frontend.segmentation.detector import DETECTORS, get_detector  # noqa: E402
from slam.frontend.segmentation.evaluation import (  # noqa: E402
    default_sdvd_dir,
    evaluate,
    evaluate_detector,
    load_sdvd,
)


def _f(v, nd=3) -> str:
    return "  n/a" if v is None else f"{v:.{nd}f}"


def write_figure(path: Path, tiles, params, region_filter, n: int) -> None:
    """Montage rows: grey tile | improved Otsu overlay | max-entropy overlay."""
    import cv2
    import numpy as np

    from sim.cli.segment_cmd import overlay_image
    from slam.frontend.segmentation import segment_filtered

    pos = [t for t in tiles if t.positive]
    neg = [t for t in tiles if not t.positive]
    step = max(1, len(pos) // max(n - 2, 1))
    chosen = pos[::step][: max(n - 2, 1)] + neg[:: max(1, len(neg) // 2)][:2]
    rows = []
    for t in chosen:
        panels = [cv2.cvtColor(t.image, cv2.COLOR_GRAY2BGR)]
        for m in ("improved-otsu", "kapur"):
            res = segment_filtered(t.image, m, params, region_filter)
            panels.append(overlay_image(t.image, res, t.mask if t.positive else None))
        rows.append(np.hstack(panels))
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.vstack(rows))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(default_sdvd_dir()), help="SDVD folder")
    ap.add_argument("--preset", default="sdvd", choices=(*PRESETS, "auto"))
    ap.add_argument("--filter", default="sdvd", choices=tuple(REGION_FILTERS))
    ap.add_argument(
        "--tol", type=float, default=0.0, help="centroid tolerance px (0 = inside mask)"
    )
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument(
        "--detector",
        default=None,
        choices=tuple(DETECTORS),
        help="run each method as the first stage of this detection chain",
    )
    ap.add_argument("--json", action="store_true")
    ap.add_argument(
        "--figure",
        default=None,
        metavar="OUT.png",
        help="write a montage of test-half tiles: image | improved Otsu | max entropy "
        "(mask tinted green, landmarks magenta, effigy outline red)",
    )
    ap.add_argument("--figure-tiles", type=int, default=8, help="tiles in the montage")
    args = ap.parse_args(argv)
    data = Path(args.data)
    if not data.is_dir():
        print(
            f"eval_sdvd: {str(data)!r} not found (give --data or set $UNDERSEA_SHARED_DATA)",
            file=sys.stderr,
        )
        return 2
    methods = [m for m in args.methods.split(",") if m]
    for m in methods:
        if m not in METHODS:
            ap.error(f"--methods: {m!r} unknown; allowed {', '.join(METHODS)}")
    tiles = load_sdvd(data)
    rf = get_region_filter(args.filter)
    region_filter = None if rf.is_identity else rf
    params = get_preset(args.preset, (256, 256))
    splits = {
        "tune": [t for t in tiles if t.split == "tune"],
        "test": [t for t in tiles if t.split == "test"],
        "all": tiles,
    }
    detector = None if args.detector is None else get_detector(args.detector)

    def run(ts, m):
        if detector is not None:
            return evaluate_detector(ts, detector.with_(method=m), tol_px=args.tol)
        return evaluate(ts, m, params, region_filter, tol_px=args.tol)

    out = {
        "data": str(data),
        "detector": args.detector,
        "preset": params.name,
        "a_px": params.a_px,
        "n_max": params.n_max,
        "region_filter": rf.to_dict(),
        "tol_px": args.tol,
        "splits": {},
    }
    for name, ts in splits.items():
        out["splits"][name] = {
            "n_positive": sum(t.positive for t in ts),
            "n_negative": sum(not t.positive for t in ts),
            "methods": {m: run(ts, m).to_dict() for m in methods},
        }
    if args.figure:
        write_figure(Path(args.figure), splits["test"], params, region_filter, args.figure_tiles)
        out["figure"] = args.figure
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    if detector is not None:
        print(f"SDVD effigy tiles: detector {args.detector}, tolerance {args.tol} px")
    else:
        print(
            f"SDVD effigy tiles: preset {params.name} (a={params.a_px}, N_max={params.n_max}), "
            f"region filter {args.filter} {rf.to_dict()}, tolerance {args.tol} px"
        )
    for name, s in out["splits"].items():
        print(f"\n== {name}: {s['n_positive']} positive, {s['n_negative']} negative tiles ==")
        print(
            f"{'method':14s} {'hit':>6s} {'hitHF':>6s} {'hitLF':>6s} {'PPV':>6s} {'PPVfrag':>7s} "
            f"{'FPR':>6s} {'det/pos':>8s} {'det/neg':>8s} {'neg w/det':>9s} {'ms':>6s}  "
            "[[TP FN] [FP TN]]"
        )
        for m, e in s["methods"].items():
            cm = e["confusion_matrix"]
            print(
                f"{m:14s} {_f(e['hit_rate'])} {_f(e['hit_rate_hf'])} {_f(e['hit_rate_lf'])} "
                f"{_f(e['ppv'])} {_f(e['ppv_fragments']):>7s} {_f(e['fpr'])} "
                f"{_f(e['detections_per_positive_tile'], 2):>8s} "
                f"{_f(e['detections_per_negative_tile'], 2):>8s} "
                f"{e['negative_tiles_with_detections']:>4d}/{e['n_negative_tiles']:<4d} "
                f"{e['mean_ms']:6.2f}  [[{cm[0][0]} {cm[0][1]}] [{cm[1][0]} {cm[1][1]}]]"
            )
    if args.figure:
        print(f"\nfigure: {args.figure} (rows: tile | improved Otsu | max entropy)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
