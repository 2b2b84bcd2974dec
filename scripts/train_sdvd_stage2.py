"""Train the learned second stage of the ``"sdvd-trusted"`` detector and choose its
merge gap, probability threshold and count on the TUNE half of the SDVD tiles only.

For each merge gap of the grid, every tune tile runs stages 1–4 of the detector
(annotations masked, improved Otsu, no-echo suppression, fragment merging) and the area
filter; each region gets its eight features and the label "centroid inside the effigy
mask"; a logistic model is fitted (``fit_region_classifier``). Then every (threshold,
count) of the grid is scored on the tune half; the selection rule, fixed before looking
at the test half: highest effigy hit rate among the settings with PPV (one true positive
per effigy) >= 0.5 and false detections per negative tile <= 0.7; ties go to fewer false
detections per negative tile, then to higher PPV. Prints the grid and the chosen
``RegionClassifier`` literal to paste into ``slam/frontend/segmentation/detector.py``.

    python scripts/train_sdvd_stage2.py [--data DIR] [--gaps 0,4] [--invert-saturated LEVEL] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from slam.frontend.segmentation.detector import (  # noqa: E402
    DetectorConfig,
    candidate_regions,
    fit_region_classifier,
    get_detector,
    region_features,
)
from slam.frontend.segmentation.evaluation import default_sdvd_dir, load_sdvd  # noqa: E402

GAPS = (0, 4)
THRESHOLDS = (0.05, 0.1, 0.15, 0.2, 0.3)
COUNTS = (1, 2)


def candidates_with_features(image, cfg: DetectorConfig, features=None):
    """Stages 1–4 of ``cfg`` and its area filter on one image: ``(candidates, kept
    regions, their feature rows)``; ``features(gray8, labels, regions)`` defaults to the
    detector's :func:`region_features`."""
    c = candidate_regions(image, cfg)
    regs = tuple(r for r in c.regions if r.area_px <= cfg.max_area_px)
    return c, regs, (features or region_features)(c.gray8, c.labels, regs)


def tune_regions(tiles, gap: int, base: DetectorConfig | None = None, features=None):
    """Per tune tile: (positive, features (n, k), inside-mask flags (n,))."""
    base = get_detector("sdvd-trusted") if base is None else base
    cfg = base.with_(merge_gap_px=gap, classifier=None, max_count=0)
    out = []
    for t in tiles:
        c, regs, feats = candidates_with_features(t.image, cfg, features)
        out.append((t.positive, feats, inside_flags(t.mask, regs, c.offset_rc)))
    return out


def inside_flags(mask, regions, offset_rc=(0, 0)) -> np.ndarray:
    """``(n,)`` bool: the centroid pixel of each region (shifted by ``offset_rc`` into the
    mask's coordinates, clipped to it) lies inside the truth ``mask``."""
    h, w = mask.shape
    dr, dc = offset_rc
    return np.array(
        [
            bool(
                mask[
                    min(max(round(r.centroid_rc[0] + dr), 0), h - 1),
                    min(max(round(r.centroid_rc[1] + dc), 0), w - 1),
                ]
            )
            for r in regions
        ],
        dtype=bool,
    )


def score(rows, clf, k: int) -> dict:
    hits = n_pos = n_neg = det = det_neg = 0
    for positive, feats, inside in rows:
        n_pos += positive
        n_neg += not positive
        if len(feats) == 0:
            continue
        p = clf.probability(feats)
        keep = [i for i in np.argsort(-p, kind="stable") if p[i] >= clf.threshold][:k]
        det += len(keep)
        if positive:
            hits += bool(inside[keep].any()) if keep else 0
        else:
            det_neg += len(keep)
    return {
        "hit_rate": hits / max(n_pos, 1),
        "ppv": hits / max(det, 1),
        "detections_per_negative_tile": det_neg / max(n_neg, 1),
    }


def first_stage_ceiling(rows) -> float:
    """Fraction of positive tiles with any candidate centroid inside the effigy."""
    pos = [bool(inside.any()) for positive, _f, inside in rows if positive]
    return sum(pos) / max(len(pos), 1)


def rule_key(s: dict):
    """The selection rule (module docstring) as a sort key of a scored setting ``s``
    (higher is better), or None when it misses PPV >= 0.5 or <= 0.7 false detections
    per negative tile."""
    if s["ppv"] < 0.5 or s["detections_per_negative_tile"] > 0.7:
        return None
    return (s["hit_rate"], -s["detections_per_negative_tile"], s["ppv"])


def choose(tiles, base: DetectorConfig | None = None, features=None, gaps=GAPS):
    """The grid on the tune ``tiles`` and the rule (module docstring): ``(grid, best)``,
    ``best = (entry, classifier)`` or None when no setting meets the limits."""
    grid = []
    best = None
    for gap in gaps:
        rows = tune_regions(tiles, gap, base, features)
        x = np.vstack([f for _, f, _ in rows if len(f)])
        y = np.concatenate([i for _, f, i in rows if len(f)])
        fitted = fit_region_classifier(x, y)
        for tau in THRESHOLDS:
            clf = fit_region_classifier(x, y, threshold=tau) if tau != fitted.threshold else fitted
            for k in COUNTS:
                s = score(rows, clf, k)
                entry = {"merge_gap_px": gap, "threshold": tau, "max_count": k, **s}
                entry["first_stage_ceiling"] = first_stage_ceiling(rows)
                grid.append(entry)
                key = rule_key(s)
                if key is not None and (best is None or key > best[0]):
                    best = (key, entry, clf)
    return grid, None if best is None else best[1:]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(default_sdvd_dir()), help="SDVD folder")
    ap.add_argument("--gaps", default=",".join(map(str, GAPS)), help="merge gaps of the grid (px)")
    ap.add_argument(
        "--invert-saturated",
        type=float,
        default=None,
        help="stages 1-4 with DetectorConfig.invert_saturated at this seabed level",
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    try:
        gaps = tuple(int(g) for g in args.gaps.split(",") if g)
    except ValueError:
        ap.error(f"--gaps: {args.gaps!r} is not a comma-separated list of integers")
    base = get_detector("sdvd-trusted")
    if args.invert_saturated is not None:
        base = base.with_(invert_saturated=args.invert_saturated)
    data = Path(args.data)
    if not data.is_dir():
        print(f"train_sdvd_stage2: {str(data)!r} not found", file=sys.stderr)
        return 2
    tiles = [t for t in load_sdvd(data) if t.split == "tune"]
    grid, best = choose(tiles, base, gaps=gaps)
    out = {"n_tune_tiles": len(tiles), "grid": grid}
    if best is not None:
        entry, clf = best
        out["chosen"] = entry
        out["classifier"] = {
            "mean": clf.mean,
            "scale": clf.scale,
            "weights": clf.weights,
            "bias": clf.bias,
            "threshold": clf.threshold,
        }
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    print(f"tune half: {len(tiles)} tiles")
    print(f"{'gap':>4s} {'tau':>5s} {'k':>2s} {'hit':>6s} {'PPV':>6s} {'det/neg':>8s}")
    for e in grid:
        print(
            f"{e['merge_gap_px']:4d} {e['threshold']:5.2f} {e['max_count']:2d} "
            f"{e['hit_rate']:6.3f} {e['ppv']:6.3f} {e['detections_per_negative_tile']:8.3f}"
        )
    if best is None:
        print("no setting meets PPV >= 0.5 and det/neg <= 0.7 on the tune half")
        return 1
    entry, clf = best
    print(f"chosen: {entry}")
    print(
        "RegionClassifier(\n"
        f"    mean={tuple(round(v, 6) for v in clf.mean)},\n"
        f"    scale={tuple(round(v, 6) for v in clf.scale)},\n"
        f"    weights={tuple(round(v, 6) for v in clf.weights)},\n"
        f"    bias={clf.bias:.6f},\n"
        f"    threshold={clf.threshold},\n)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
