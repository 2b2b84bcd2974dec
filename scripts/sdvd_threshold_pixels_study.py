"""Which pixels the first stage's threshold is computed from (``DetectorConfig.
threshold_pixels``): the whole tile (thesis), the tile without no-echo areas
(``"echo"``), or without no-echo areas and bright strips along the tile edges
(``"seabed"``), each on top of a named detector (``sdvd-saturated`` by default).

Per variant: the first stage's ceiling (positive tiles with any candidate centroid in
the effigy after stages 1–4), candidates per negative tile, and the chain with the
detector's second stage unchanged: hit rate (HF / LF), PPV one true positive per effigy,
fragment-counting PPV, false detections per negative tile. The split defaults to the
tune half (choose there; ``--split test|all`` only once the choice is fixed).

    python scripts/sdvd_threshold_pixels_study.py [--data DIR] [--detector NAME]
           [--split tune|test|all] [--variants all,echo,seabed] [--methods improved-otsu,kapur]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
for p in (REPO, REPO / "scripts"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

from train_sdvd_stage2 import inside_flags  # noqa: E402

from slam.frontend.segmentation.detector import (  # noqa: E402
    DETECTORS,
    THRESHOLD_PIXELS,
    candidate_regions,
    get_detector,
)
from slam.frontend.segmentation.evaluation import (  # noqa: E402
    default_sdvd_dir,
    evaluate_detector,
    load_sdvd,
)


def ceiling(tiles, cfg) -> tuple[float, float]:
    """(share of positive tiles with a candidate centroid in the effigy, candidates per
    negative tile) after stages 1–4 and the area limit of ``cfg``."""
    hits, neg = [], []
    for t in tiles:
        c = candidate_regions(t.image, cfg)
        regs = tuple(r for r in c.regions if r.area_px <= cfg.max_area_px)
        if t.positive:
            hits.append(bool(inside_flags(t.mask, regs, c.offset_rc).any()))
        else:
            neg.append(len(regs))
    return float(np.mean(hits)), float(np.mean(neg)) if neg else float("nan")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", default=str(default_sdvd_dir()), help="SDVD folder")
    ap.add_argument("--detector", default="sdvd-saturated", choices=tuple(DETECTORS))
    ap.add_argument("--split", default="tune", choices=("tune", "test", "all"))
    ap.add_argument("--variants", default=",".join(THRESHOLD_PIXELS))
    ap.add_argument("--methods", default="improved-otsu")
    args = ap.parse_args(argv)
    data = Path(args.data)
    if not data.is_dir():
        print(f"sdvd_threshold_pixels_study: {str(data)!r} not found", file=sys.stderr)
        return 2
    variants = [v for v in args.variants.split(",") if v]
    bad = [v for v in variants if v not in THRESHOLD_PIXELS]
    if bad:
        print(
            f"--variants: {bad[0]!r} unknown; allowed {', '.join(THRESHOLD_PIXELS)}",
            file=sys.stderr,
        )
        return 2
    tiles = [t for t in load_sdvd(data) if args.split in ("all", t.split)]
    base = get_detector(args.detector)
    print(
        f"{args.detector}, {args.split}: {sum(t.positive for t in tiles)} positive, "
        f"{sum(not t.positive for t in tiles)} negative tiles"
    )
    print(
        f"{'variant':15s} {'method':14s} {'ceil':>6s} {'cand/neg':>8s} {'hit':>6s} {'HF':>6s} "
        f"{'LF':>6s} {'PPV':>6s} {'PPVfrag':>7s} {'det/neg':>7s}"
    )
    for v in variants:
        for m in args.methods.split(","):
            cfg = base.with_(threshold_pixels=v, method=m)
            ceil, cand = ceiling(tiles, cfg)
            e = evaluate_detector(tiles, cfg).to_dict()
            print(
                f"{v:15s} {m:14s} {ceil:6.3f} {cand:8.2f} {e['hit_rate']:6.3f} "
                f"{e['hit_rate_hf']:6.3f} {e['hit_rate_lf']:6.3f} {e['ppv']:6.3f} "
                f"{e['ppv_fragments']:7.3f} {e['detections_per_negative_tile']:7.2f}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
