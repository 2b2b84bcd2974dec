"""``undersea segment IMAGE...``: threshold segmentation of sonar images (improved Otsu TSM
or a baseline), region landmarks with centroids, thresholds and timing; with ``--masks``
the reference's confusion matrix, FPR, PPV and recall (thesis ch. 3.3–3.4)."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from sim.cli.common import finite_float, print_json

MASK_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".pgm")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from slam.frontend.segmentation import METHODS, PRESETS, REGION_FILTERS

    parser.add_argument("images", nargs="+", metavar="IMAGE", help="PNG/JPG/TIFF image files")
    parser.add_argument(
        "--method",
        default="improved-otsu",
        choices=(*METHODS, "all"),
        help="threshold method (default improved-otsu; 'all' runs every method)",
    )
    parser.add_argument(
        "--preset",
        default="auto",
        choices=(*PRESETS, "auto"),
        help="a / N_max / Canny / dilation preset; 'auto' derives them from the image size "
        "(default)",
    )
    parser.add_argument(
        "--masks",
        default=None,
        metavar="DIR",
        help="ground-truth masks (same file name or stem as each image; > 127 = object)",
    )
    parser.add_argument(
        "--tol", type=finite_float, default=0.0, help="centroid match tolerance in px (default 0)"
    )
    parser.add_argument(
        "--merge-components",
        action="store_true",
        help="treat each mask as one object (default: each 8-connected component)",
    )
    parser.add_argument(
        "--filter",
        default="none",
        choices=tuple(REGION_FILTERS),
        help="landmark filter preset applied after Algorithm 2 (default none; sdvd-contrast "
        "and sdvd-shadow add the side-scan local-contrast / acoustic-shadow tests); the "
        "options below override its fields",
    )
    parser.add_argument(
        "--min-contrast-db",
        type=finite_float,
        default=None,
        help="detection filter: min local contrast, dB (region vs background ring)",
    )
    parser.add_argument(
        "--far-range",
        default=None,
        choices=("left", "right", "either"),
        help="detection filter: side of far range along the columns, where the shadow lies",
    )
    parser.add_argument("--min-area", type=int, default=None, help="region filter: min area px")
    parser.add_argument(
        "--max-area", type=finite_float, default=None, help="region filter: max area px"
    )
    parser.add_argument(
        "--max-elongation", type=finite_float, default=None, help="region filter: max major/minor"
    )
    parser.add_argument(
        "--max-count", type=int, default=None, help="region filter: keep the N largest (0 = all)"
    )
    parser.add_argument(
        "--overlay",
        default=None,
        metavar="OUT.png",
        help="write a PNG overlay of the segmentation and centroids (several images or "
        "methods: OUT is a directory, one <stem>_<method>.png each)",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object")


def find_mask(mask_dir: Path, image: Path) -> Path:
    exact = mask_dir / image.name
    if exact.is_file():
        return exact
    for suf in MASK_SUFFIXES:
        cand = mask_dir / (image.stem + suf)
        if cand.is_file():
            return cand
    raise ValueError(f"--masks: no mask for {image.name!r} in {str(mask_dir)!r}")


def overlay_image(gray8, result, truth=None):
    """BGR overlay: segmentation mask tinted green, landmark centroids as magenta stars,
    ground-truth outlines (if given) in red."""
    import cv2
    import numpy as np

    out = cv2.cvtColor(gray8, cv2.COLOR_GRAY2BGR)
    m = result.mask
    tint = np.array([0, 160, 0], dtype=np.float32)
    out[m] = (0.55 * out[m].astype(np.float32) + 0.45 * tint).astype(np.uint8)
    if truth is not None:
        contours, _ = cv2.findContours(
            truth.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE
        )
        cv2.drawContours(out, contours, -1, (0, 0, 255), 1)
    size = max(5, round(min(gray8.shape) / 40))
    for r in result.landmarks:
        x, y = r.centroid_xy
        cv2.drawMarker(out, (round(x), round(y)), (255, 0, 255), cv2.MARKER_STAR, size, 1)
    return out


def _fmt(v) -> str:
    return "n/a" if v is None else f"{v:.3f}"


def run(args: argparse.Namespace) -> int:
    import cv2

    from slam.frontend.segmentation import (
        METHODS,
        DetectionFilter,
        RegionFilter,
        get_preset,
        get_region_filter,
        load_gray8,
        load_mask,
        score_result,
        segment_filtered,
        sum_scores,
    )

    methods = list(METHODS) if args.method == "all" else [args.method]
    try:
        base = get_region_filter(args.filter)
        overrides = {
            "min_area_px": args.min_area,
            "max_area_px": args.max_area,
            "max_elongation": args.max_elongation,
            "max_count": args.max_count,
        }
        geo = base.region if isinstance(base, DetectionFilter) else base
        geo = RegionFilter(
            **{k: (getattr(geo, k) if v is None else v) for k, v in overrides.items()}
        )
        if isinstance(base, DetectionFilter) or (
            args.min_contrast_db is not None or args.far_range is not None
        ):
            det = base if isinstance(base, DetectionFilter) else DetectionFilter()
            changes = {"region": geo}
            if args.min_contrast_db is not None:
                changes["min_contrast_db"] = args.min_contrast_db
            if args.far_range is not None:
                changes["far_range"] = args.far_range
            region_filter = det.with_(**changes)
        else:
            region_filter = geo
    except ValueError as exc:
        print(f"undersea segment: {exc}", file=sys.stderr)
        return 2
    if args.tol < 0 or not math.isfinite(args.tol):
        print(
            f"undersea segment: --tol={args.tol}: must be a finite distance >= 0 px",
            file=sys.stderr,
        )
        return 2
    mask_dir = Path(args.masks) if args.masks else None
    if mask_dir is not None and not mask_dir.is_dir():
        print(f"undersea segment: --masks {args.masks!r} is not a directory", file=sys.stderr)
        return 2
    overlay_dir = None
    if args.overlay and (len(args.images) > 1 or len(methods) > 1):
        overlay_dir = Path(args.overlay)
        overlay_dir.mkdir(parents=True, exist_ok=True)

    records = []
    failed: list[dict] = []  # unreadable images: reported, the others still processed
    scores: dict[str, list] = {m: [] for m in methods}
    for path_str in args.images:
        path = Path(path_str)
        try:
            gray = load_gray8(path)
            truth = load_mask(find_mask(mask_dir, path), gray.shape) if mask_dir else None
        except (ValueError, OSError) as exc:
            print(f"undersea segment: skipped {str(path)!r}: {exc}", file=sys.stderr)
            failed.append({"image": str(path), "error": str(exc)})
            continue
        params = get_preset(args.preset, gray.shape)
        for method in methods:
            res = segment_filtered(
                gray, method, params, None if region_filter.is_identity else region_filter
            )
            rec = {"image": str(path), "shape": list(gray.shape), **res.to_dict()}
            if truth is not None:
                sc = score_result(
                    res, truth, tol_px=args.tol, merge_components=args.merge_components
                )
                scores[method].append(sc)
                rec["score"] = sc.to_dict()
            records.append(rec)
            if args.overlay:
                out_path = (
                    overlay_dir / f"{path.stem}_{method}.png" if overlay_dir else Path(args.overlay)
                )
                out_path.parent.mkdir(parents=True, exist_ok=True)
                cv2.imwrite(str(out_path), overlay_image(gray, res, truth))
                rec["overlay"] = str(out_path)
            if not args.json:
                _print_record(rec)
    summary = {}
    if mask_dir is not None:
        for m in methods:
            summary[m] = sum_scores(scores[m]).to_dict()
    if args.json:
        print_json(
            {
                "preset": args.preset,
                "filter": args.filter,
                "region_filter": region_filter.to_dict(),
                "tol_px": args.tol,
                "images": records,
                "failed": failed,
                "summary": summary,
            },
            indent=1,
        )
    elif summary:
        print("== summary over all images (counts summed) ==")
        for m, s in summary.items():
            cm = s["confusion_matrix"]
            print(
                f"{m:14s} images {s['n_images']:4d}  [[TP {cm[0][0]} FN {cm[0][1]}] "
                f"[FP {cm[1][0]} TN {cm[1][1]}]]  FPR {_fmt(s['fpr'])}  PPV {_fmt(s['ppv'])}  "
                f"recall {_fmt(s['recall'])}  hit-rate {_fmt(s['hit_rate'])}"
            )
    if failed:
        print(
            f"undersea segment: {len(failed)} of {len(args.images)} image(s) could not be read "
            "(named above); the others were processed",
            file=sys.stderr,
        )
        return 2
    return 0


def _print_record(rec: dict) -> None:
    t = rec["timing_ms"]
    line = (
        f"{rec['image']} [{rec['method']}, preset {rec['preset']} a={rec['a_px']} "
        f"N_max={rec['n_max']}] T={rec['threshold']:.0f} ({rec['threshold_normalized']:.4f})"
    )
    if rec["method"] == "improved-otsu":
        line += (
            f" N_a={rec['n_small_contours']} T*={rec['threshold_star']:.0f} "
            f"({rec['threshold_star_normalized']:.4f}) retriggered={rec['retriggered']}"
        )
    line += f" regions={rec['n_regions']} landmarks={rec['n_landmarks']} time={t.get('total', 0):.2f} ms"
    print(line)
    for r in rec["landmarks"]:
        x, y = r["centroid_xy"]
        print(f"   landmark x={x:8.2f} y={y:8.2f} area={r['area_px']:6d} px bbox={r['bbox']}")
    if "score" in rec:
        s = rec["score"]
        cm = s["confusion_matrix"]
        print(
            f"   vs mask: [[TP {cm[0][0]} FN {cm[0][1]}] [FP {cm[1][0]} TN {cm[1][1]}]] "
            f"FPR {_fmt(s['fpr'])} PPV {_fmt(s['ppv'])} recall {_fmt(s['recall'])}"
        )
    if "overlay" in rec:
        print(f"   overlay: {rec['overlay']}")
